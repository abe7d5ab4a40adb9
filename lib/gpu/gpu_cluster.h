/*
 * gpu_cluster.h - the selection passes of vertex clustering (Kanaya et
 * al. 2.4, 2.5; lib/mesh/cluster.h) on the GPU: the tree goes into
 * storage buffers once (the Tree-buffer and Leaf-buffer of figures 2-4,
 * with the triangles), then each level is one compute dispatch over the
 * vertices and one over the triangles.  The result equals
 * gv_cluster_select's, to the bit, and goes into gv_cluster_collect.
 */
#ifndef GV_GPU_CLUSTER_H
#define GV_GPU_CLUSTER_H

#include "gpu/gpu.h"
#include "mesh/cluster.h"

struct gv_gpu_cluster;

/* Upload tree t (which must outlive the result) on context g.  Returns
 * the handle, or NULL with *err: GV_ELIMIT when a buffer exceeds the
 * context's storage-block size, GV_EUNAVAIL without storage buffers,
 * GV_EINVAL for a shader that does not build (also listed on stderr),
 * GV_ENOMEM.  Any thread but
 * g's GL thread. */
struct gv_gpu_cluster *gv_gpu_cluster_new(struct gv_gpu *g,
                                          const struct gv_cluster_tree *t,
                                          struct gv_error *err);

/* Select at level T: cluster (nverts), keep (ntris) and vpos (4 floats
 * per vertex: the selected position) as gv_cluster_select and
 * gv_cluster_collect define them.  Returns 0, or -1 with *err. */
int gv_gpu_cluster_select(struct gv_gpu_cluster *c, uint32_t T,
                          uint32_t *cluster, uint8_t *keep, float *vpos,
                          struct gv_error *err);

/* Release the buffers; NULL does nothing. */
void gv_gpu_cluster_free(struct gv_gpu_cluster *c);

/* new + select + free in one call, as cluster_run.h's select callback:
 * ctx is the struct gv_gpu *. */
int gv_gpu_cluster_run(void *ctx, const struct gv_cluster_tree *t, uint32_t T,
                       uint32_t *cluster, uint8_t *keep, float *vpos,
                       struct gv_error *err);

#endif
