/*
 * gpu_zfield.h - the z-field simplification sweep (lib/mesh/zfield.h) on
 * the GPU: one compute dispatch per level of vertices, children before
 * parents, as the paper ("GPU z-field simplification", sections 4 and 5)
 * runs one set of fragment passes per level.  The enabled states come
 * back packed 32 to a word (section 5.3 packs 8 to a byte) and equal
 * gv_zfield_enable's exactly; the mesh is then built on the CPU from them
 * (gv_zfield_mesh), as in the paper.
 *
 * The heights stay on the GPU between calls, so that a client that moves
 * its camera re-runs only the sweep (the view-dependent mode, per frame).
 */
#ifndef GV_GPU_ZFIELD_H
#define GV_GPU_ZFIELD_H

#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "mesh/zfield.h"

struct gv_gpu_zfield;

/* How a sweep is made (gv_gpu_zfield_new).  One shader source for both
 * paths (shaders/zfield_*). */
struct gv_gpu_zfield_opts {
    /* GV_GPU_PATH_COMPUTE (0): a compute dispatch per level, storage
     * buffers; GV_GPU_PATH_WEBGL2: GLSL ES 3.00 as WebGL2 runs it, a draw
     * of one point per vertex per level into alternating R8UI targets
     * (needs an ES context) */
    enum gv_gpu_path path;
};

/* Compile the sweep programs described by *o (NULL: every option 0) on g
 * (borrowed: close it after gv_gpu_zfield_free).  NULL with *err
 * (GV_EFORMAT: the path is not available on this context; a shader that
 * does not compile is also listed on stderr). */
struct gv_gpu_zfield *gv_gpu_zfield_new(struct gv_gpu *g,
                                        const struct gv_gpu_zfield_opts *o,
                                        struct gv_error *err);

/* Free the programs and buffers.  NULL does nothing. */
void gv_gpu_zfield_free(struct gv_gpu_zfield *zf);

/* Upload an n x n grid of heights (n = 2^k + 1), replacing the last one.
 * Returns 0, or -1 with *err (GV_EINVAL for n, GL failures). */
int gv_gpu_zfield_heights(struct gv_gpu_zfield *zf, const float *z, uint32_t n,
                          struct gv_error *err);

/* Run the sweep for p over the uploaded grid and write every vertex's
 * enabled state (n * n bytes, 1 or 0) as gv_zfield_enable would.  The
 * coarse phase is the CPU's (p->no_coarse is ignored: the GPU evaluates
 * every vertex).  Returns 0, or -1 with *err. */
int gv_gpu_zfield_enable(struct gv_gpu_zfield *zf, const struct gv_zfield_params *p,
                         uint8_t *enabled, struct gv_error *err);

#endif
