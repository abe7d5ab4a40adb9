/*
 * gpu_height.h - decoding tiles of 16-bit codes on the GPU: height stores
 * (docs/FORMAT.md section 12) and sample stores (section 13, a height tile
 * buffer a channel), bit for bit what lib/codec/height_tile.c does.
 *
 * A decoded tile lives on the GPU as a 513x513xC R16UI array texture (a
 * layer a channel, C = 1 for a height store) named by a handle.  On the compute path (GLSL ES 3.10 / GL 4.30) a compute pass
 * (shaders/height_rans.comp.glsl, one invocation per stream) entropy-
 * decodes the buffer into a storage buffer of q, then a fragment pass
 * (shaders/height_decode.frag.glsl) predicts from the parent texture and
 * adds q (2e + 1).  On the WebGL2 path (GLSL ES 3.00, as the browser) the
 * CPU entropy-decodes into an R32I texture for the same fragment pass.
 * Every function may be called from any thread but the GPU's own (the
 * work runs there, through gv_gpu_call).
 *
 * `gigaview render` decodes height and sample stores with it, behind the
 * GPU tile cache (gpu_cache.h, gv_gpu_tiles_codes); gigaviewd and
 * `gigaview mesh` read heights through the CPU decoder
 * (lib/render/height_region.c).  tests/test_gpu_height runs both paths
 * against the CPU decoder, which checks shaders/height_*.glsl.  The WebGL2 path compiles the very
 * fragment shader with which the browser viewer (client/web/
 * codes_decode.js, with GV_LAYERED) decodes height and sample stores.
 */
#ifndef GV_GPU_HEIGHT_H
#define GV_GPU_HEIGHT_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "codec/samples_tile.h"
#include "gpu/gpu.h"
#include "gpu/gpu_decode.h"

struct gv_gpu_height;

/* How a height decoder is made (gv_gpu_height_new). */
struct gv_gpu_height_opts {
    /* GV_GPU_PATH_COMPUTE (0) or GV_GPU_PATH_WEBGL2 (needs an ES context,
     * else GV_EFORMAT) */
    enum gv_gpu_path path;
    /* channels of codes a tile, 1 to GV_SAMPLES_MAX_CHANNELS (0: 1; else
     * GV_EINVAL) */
    int channels;
};

/* Compile the programs described by *o (NULL: every option 0).  g is
 * borrowed.  NULL with *err on failure (a shader that does not compile is
 * listed on stderr). */
struct gv_gpu_height *gv_gpu_height_new(struct gv_gpu *g,
                                        const struct gv_gpu_height_opts *o,
                                        struct gv_error *err);

/* Free every texture and program.  NULL does nothing. */
void gv_gpu_height_free(struct gv_gpu_height *h);

/* Upload 513x513 pixels of C interleaved codes (the root tile) as a new
 * texture: 0 with *handle, or -1. */
int gv_gpu_height_upload(struct gv_gpu_height *h, const uint16_t *codes,
                         uint32_t *handle, struct gv_error *err);

/* Decode tile buffer buf (C height tile buffers one after another,
 * checked with gv_samples_tile_check first) against the parent texture
 * and quadrant (qx,qy) into a new texture: 0 with *handle, or -1 with
 * *err. */
int gv_gpu_height_decode(struct gv_gpu_height *h, const uint8_t *buf,
                         size_t len, uint32_t parent, int qx, int qy,
                         uint32_t *handle, struct gv_error *err);

/* Decode n tiles in one call to the GL thread, as gv_gpu_height_decode
 * would one by one, in order: the image decoder's job shape
 * (gpu_decode.h, struct gv_gpu_tile_job), so that a tile may name an
 * earlier job as its parent and a pyramid decodes level by level in one
 * batch.  Every buffer is checked first.  0 with every jobs[i].handle
 * set, or -1 with *err and no texture made (GV_EINVAL: a parent_job not
 * earlier than its job). */
int gv_gpu_height_decode_batch(struct gv_gpu_height *h, struct gv_gpu_tile_job *jobs,
                               size_t n, struct gv_error *err);

/* Read a tile back as 513x513 pixels of C interleaved codes.  0 or -1. */
int gv_gpu_height_read(struct gv_gpu_height *h, uint32_t handle,
                       uint16_t *codes, struct gv_error *err);

/* Delete a texture made by this decoder. */
void gv_gpu_height_release(struct gv_gpu_height *h, uint32_t handle);

#endif
