/*
 * cluster.h - vertex-clustering simplification with face-count control
 * after Kanaya et al., "Real-time vertex-clustering simplification on the
 * GPU" (../shared/reference/gpu-vertex-clustering.md; sections cited as
 * "Kanaya 2.x").
 *
 * Build (Kanaya 2.1, 2.2; on the CPU): the vertices are split by an
 * octree whose every cell is cut into eight by vertex count (median in x,
 * then in y within each half, then in z within each quarter; ties by
 * vertex index), down to one vertex per cell.  Each internal node gets
 * as its representative the point that minimizes the quadric error of
 * the triangles touching its vertices (Lindstrom 2000, the alternative of
 * Kanaya 2.2; lib/mesh/cluster_quadric.c), from the mean of its vertices
 * along the well-conditioned directions and clamped to their bounding
 * box, an integer
 * i_level = INT(log2(Length_max / Length_current)) from the longest edge
 * of its vertices' bounding box (eq. 1), and the fractional r_level =
 * i_level + k / number_i, k its rank by descending length among the nodes
 * of its i_level (eq. 2).  r_level never decreases from a node to its
 * children.
 *
 * A level r selects, for each vertex, the node nearest the root on its
 * path whose r_level is above r (Kanaya 2.5, pass 2: "the internal node
 * whose level is larger than the r_level"), or the vertex itself when no
 * ancestor is.  Only the order of the r_levels matters, so a level is
 * carried as the integer T = the number of nodes with r_level <= r, and a
 * node is "above r" when its rank (position in r_level order) is >= T:
 * exact integer tests, the same on every CPU and GPU.  T = 0 collapses
 * everything into the root; T = nnodes keeps the input.
 *
 * Face counts (Kanaya 2.3, pass 1): a triangle survives at T when its
 * three vertices fall into three different clusters, which happens
 * exactly when T exceeds the rank of each pair's lowest common ancestor.
 * The build records that threshold per triangle and counts them, so the
 * face count at every T is known in advance (F[T]); the paper counts only
 * at integer i_levels and interpolates (eq. 3).  Both ways of choosing T
 * for a face budget are offered: GV_CLUSTER_EXACT picks the T whose F[T]
 * is nearest the request, GV_CLUSTER_PAPER interpolates eq. 3 between the
 * integer levels.  Degenerate triangles (two corners in one cluster) are
 * dropped (Kanaya 2.5, pass 3); identical triangles are kept.
 *
 * The selection itself is a pass over the vertices and one over the
 * faces: gv_cluster_select here, lib/gpu/gpu_cluster.c on the GPU with the
 * tree in storage buffers; gv_cluster_collect makes the mesh from either,
 * so the CPU and the GPU give the same mesh, byte for byte.
 */
#ifndef GV_MESH_CLUSTER_H
#define GV_MESH_CLUSTER_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "mesh/mesh.h"

#define GV_CLUSTER_NONE UINT32_MAX

/* The clustering information of one mesh (read-only after the build). */
struct gv_cluster_tree {
    const struct gv_mesh *mesh;  /* borrowed: must outlive the tree */
    uint32_t nnodes;        /* internal nodes; node 0 is the root */
    uint32_t *parent;       /* per node: its parent, GV_CLUSTER_NONE at the root */
    uint32_t *rank;         /* per node: its place in r_level order */
    uint32_t *depth;        /* per node: root 0 */
    float *rep;             /* per node: 4 floats, the representative and
                               its r_level (Kanaya figure 3's texel) */
    uint32_t *leaf_parent;  /* per vertex: the node holding it as a leaf
                               (GV_CLUSTER_NONE with a single vertex) */
    uint32_t *faces_at;     /* nnodes + 1 entries: faces_at[T] = triangles
                               that survive at T */
    uint32_t *rank_ilevel;  /* per rank: the node's i_level */
    uint32_t max_ilevel;
};

enum gv_cluster_mode { GV_CLUSTER_EXACT, GV_CLUSTER_PAPER };

/* Build the tree of m (the CPU part, Kanaya 2.1-2.3).  Returns 0, or -1
 * with *err (GV_ENOMEM, GV_ETIMEOUT past time_limit seconds if > 0).
 * Free with gv_cluster_tree_free.  Thread-safe. */
int gv_cluster_build(const struct gv_mesh *m, double time_limit,
                     struct gv_cluster_tree *t, struct gv_error *err);
void gv_cluster_tree_free(struct gv_cluster_tree *t);

/* The level T for about `faces` triangles (see above); *expect gets
 * faces_at[T]. */
uint32_t gv_cluster_level(const struct gv_cluster_tree *t, uint64_t faces,
                          enum gv_cluster_mode mode, uint32_t *expect);

/*
 * The selection at level T on the CPU: cluster[v] (nverts entries) is the
 * selected node, or nnodes + v for the vertex itself; keep[f] (ntris
 * entries) is 1 for a triangle with three different clusters.  Either the
 * reference or what lib/gpu/gpu_cluster.c computes must go into
 * gv_cluster_collect.
 */
void gv_cluster_select(const struct gv_cluster_tree *t, uint32_t T,
                       uint32_t *cluster, uint8_t *keep);

/*
 * The simplified mesh from a selection: the used clusters in ascending
 * cluster id, each at its representative (from vpos, 4 floats per input
 * vertex with the selected position, when not NULL; else from the tree),
 * and the kept triangles in input order.  Returns 0, or -1 (GV_ENOMEM).
 */
int gv_cluster_collect(const struct gv_cluster_tree *t, const uint32_t *cluster,
                       const uint8_t *keep, const float *vpos,
                       struct gv_mesh *out, struct gv_error *err);

#endif
