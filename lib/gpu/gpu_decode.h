/*
 * gpu_decode.h - decoding tiles on the GPU with the shared decode shader
 * (shaders/tile_decode.frag.glsl), bit for bit what lib/codec/tile_decode.c does.
 *
 * Decoded tiles live on the GPU as RGBA8UI textures of 513x513 with a
 * second mip level of 257x257 (the parent quarter, section 7.5), named by
 * handles.  A tile is decoded from its tile buffer and its parent's
 * handle; the root tile is uploaded.  Every function may be called from
 * any thread (the work runs on the GPU's thread).
 */
#ifndef GV_GPU_DECODE_H
#define GV_GPU_DECODE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"

struct gv_gpu_decoder;

/* How the shader reads a tile buffer: from a shader storage buffer, with
 * rANS streams decoded by a compute pass (GLSL ES 3.10 / GL 4.30), or as
 * WebGL2 does (GLSL ES 3.00): the buffer as an R32UI texture and rANS
 * streams decoded on the CPU into an R16UI index texture. */
enum gv_gpu_path { GV_GPU_PATH_SSBO, GV_GPU_PATH_WEBGL2 };

/* Compile the decode programs for tiles of `channels` channels (the SSBO
 * path). */
struct gv_gpu_decoder *gv_gpu_decoder_new(struct gv_gpu *g, int channels,
                                          struct gv_error *err);

/* The same for a chosen path; GV_GPU_PATH_WEBGL2 needs an ES context. */
struct gv_gpu_decoder *gv_gpu_decoder_new_path(struct gv_gpu *g, int channels,
                                               enum gv_gpu_path path,
                                               struct gv_error *err);

/* Free every texture and program.  NULL does nothing. */
void gv_gpu_decoder_free(struct gv_gpu_decoder *d);

/* Upload 513x513xC decoded pixels (the root tile) as a new texture. */
int gv_gpu_upload_tile(struct gv_gpu_decoder *d, const uint8_t *pixels,
                       uint32_t *handle, struct gv_error *err);

/* Decode tile buffer buf (len bytes, checked first) against the decoded
 * parent `parent` and quadrant (qx,qy) into a new texture. */
int gv_gpu_decode_tile(struct gv_gpu_decoder *d, const uint8_t *buf,
                       size_t len, uint32_t parent, int qx, int qy,
                       uint32_t *handle, struct gv_error *err);

/* Read mip 0 (513x513) or mip 1 (257x257) back as C-channel pixels. */
int gv_gpu_read_tile(struct gv_gpu_decoder *d, uint32_t handle, int mip,
                     uint8_t *pixels, struct gv_error *err);

/* Delete a texture. */
void gv_gpu_release(struct gv_gpu_decoder *d, uint32_t handle);

#endif
