/*
 * gpu_decode.h - decoding tiles on the GPU with the shared decode shader
 * (shaders/tile_decode.frag.glsl), bit for bit what lib/codec/tile_decode.c does.
 *
 * Decoded tiles live on the GPU as RGBA8UI textures named by handles:
 * mip 0 is 514x514 of which the 513x513 tile is used (so that GL's halving
 * leaves 257 texels), mip 1 the 257x257 parent quarter (section 7.5).  A
 * tile is decoded from its tile buffer and its parent's handle; the root
 * tile is uploaded.  Tiles are decoded one per call or many per call
 * (gv_gpu_decode_batch, which saves a round trip to the GL thread per
 * tile).  Every function may be called from any thread but the GPU's own
 * (the work runs there, through gv_gpu_call).
 */
#ifndef GV_GPU_DECODE_H
#define GV_GPU_DECODE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"

struct gv_gpu_decoder;

/* How a decoder is made (gv_gpu_decoder_new). */
struct gv_gpu_decoder_opts {
    int channels;            /* of the store's tiles: 1 or 3 */
    /* How the shader reads a tile buffer: GV_GPU_PATH_COMPUTE (0), from a
     * shader storage buffer, with rANS streams (indices, or layout D's
     * coefficients) decoded by a compute pass; or GV_GPU_PATH_WEBGL2, as
     * the browser does: the buffer as an R32UI texture and rANS streams
     * decoded on the CPU into an R16UI index texture or a 520x520 RGBA16I
     * coefficient texture (needs an ES context, else GV_EFORMAT). */
    enum gv_gpu_path path;
    /* NULL, or #define lines (read only during gv_gpu_decoder_new) put
     * before the decode shader's source: tests use them to change the
     * transform's rounding (GV_DCT_ROUND_ROWS, GV_DCT_ROUND_COLS in
     * shaders/tile_decode.frag.glsl) and see the comparison fail. */
    const char *defines;
};

/* Compile the decode programs described by *o (read during the call).
 * Returns the decoder (g is borrowed: close it after gv_gpu_decoder_free),
 * or NULL with *err; a shader that does not compile is also listed on
 * stderr. */
struct gv_gpu_decoder *gv_gpu_decoder_new(struct gv_gpu *g,
                                          const struct gv_gpu_decoder_opts *o,
                                          struct gv_error *err);

/* Free every texture and program.  NULL does nothing. */
void gv_gpu_decoder_free(struct gv_gpu_decoder *d);

/* Upload 513x513xC decoded pixels (the root tile) as a new texture, with
 * its own 2x2 box reduction as mip 1.  Returns 0 with *handle, or -1. */
int gv_gpu_upload_tile(struct gv_gpu_decoder *d, const uint8_t *pixels,
                       uint32_t *handle, struct gv_error *err);

/* Decode tile buffer buf (len bytes, checked with gv_tilebuf_check first)
 * against the decoded parent `parent` and quadrant (qx,qy) into a new
 * texture.  Returns 0 with *handle, or -1 with *err (the buffer failed
 * gv_tilebuf_check, or GL failed: GV_EIO). */
int gv_gpu_decode_tile(struct gv_gpu_decoder *d, const uint8_t *buf,
                       size_t len, uint32_t parent, int qx, int qy,
                       uint32_t *handle, struct gv_error *err);

/* One tile of a batch: its buffer (len bytes, borrowed for the call), its
 * parent (a handle, or, when parent_job >= 0, the tile of that earlier
 * job in the same batch), its quadrant, and, after the call, its handle. */
struct gv_gpu_tile_job {
    const uint8_t *buf;
    size_t len;
    uint32_t parent;
    long parent_job;      /* -1: `parent` is the parent's handle */
    int qx, qy;
    uint32_t handle;      /* out: the new texture */
};

/*
 * Decode n tiles in one call to the GL thread, as gv_gpu_decode_tile would
 * one by one, in order (a tile may name an earlier job as its parent, so a
 * pyramid can be decoded level by level in one batch).  On the compute path
 * tiles go in groups: every rANS pass of a group runs before one barrier,
 * and nothing waits for the GPU but a group for the one before the
 * previous (whose buffers it reuses).  Every buffer is checked with
 * gv_tilebuf_check first.  Returns
 * 0 with every jobs[i].handle set, or -1 with *err and no texture made
 * (GV_EINVAL: a parent_job not earlier than its job).
 */
int gv_gpu_decode_batch(struct gv_gpu_decoder *d, struct gv_gpu_tile_job *jobs,
                        size_t n, struct gv_error *err);

/* Read mip 0 (513x513) or mip 1 (257x257) of `handle` back into pixels
 * (that many C-channel pixels, rows packed).  Returns 0 or -1. */
int gv_gpu_read_tile(struct gv_gpu_decoder *d, uint32_t handle, int mip,
                     uint8_t *pixels, struct gv_error *err);

/* Delete a texture made by this decoder; the handle is then invalid.  The
 * decoder keeps up to 32 released textures (or as many as reserved) for
 * its next decodes instead of deleting them. */
void gv_gpu_release(struct gv_gpu_decoder *d, uint32_t handle);

/* Allocate textures for `tiles` tiles up front and keep that many released
 * ones from now on, so that decoding them allocates nothing (on an H100 a
 * fifth to a third of a batch's time went to allocating textures).  A
 * client that knows its cache's size in tiles may reserve it; only
 * bench/decode_bench and tests/test_gpu_decode call it so far.  Returns 0,
 * or -1 with *err. */
int gv_gpu_reserve(struct gv_gpu_decoder *d, size_t tiles, struct gv_error *err);

#endif
