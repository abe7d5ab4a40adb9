/*
 * gpu_cache.h - decoded tiles on the GPU, pulled recursively and kept in an
 * LRU cache bounded in bytes (section 7.5).
 *
 * Asking for tile T of level k decodes it on the GPU from its tile buffer
 * and its parent's texture (an image tile, or a tile of 16-bit codes:
 * struct gv_gpu_tiles); a parent that is not cached is obtained the
 * same way first, up to the root tile, which is uploaded from the root
 * image.  Tile buffers come from a callback the caller supplies, so the
 * cache works the same over HTTP and over a local store.  Every texture
 * (an image tile's 514x514 RGBA8UI plus its 257x257 mip,
 * GV_GPU_TILE_BYTES) counts against the budget; the least recently used ones are deleted first, and the tile
 * just decoded is always kept, so any budget works (a small one merely
 * re-pulls ancestors more often).  Not thread-safe: one cache per thread.
 */
#ifndef GV_GPU_CACHE_H
#define GV_GPU_CACHE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "store/geometry.h"
#include "gpu/gpu_decode.h"
#include "gpu/gpu_height.h"

/* GPU memory of one decoded tile: 514^2 + 257^2 texels of 4 bytes. */
#define GV_GPU_TILE_BYTES ((size_t)(514 * 514 + 257 * 257) * 4)

/*
 * Fetch the tile buffer of tile (tx,ty) of `level` (0 <= level < root).
 * On success set *buf (malloc'ed; the cache frees it) and *len and return
 * 0; otherwise return -1 with *err filled.  The buffer is checked with
 * gv_tilebuf_check before it reaches the GPU.
 */
typedef int (*gv_tile_fetch_fn)(void *ctx, int level, uint32_t tx, uint32_t ty,
                                uint8_t **buf, size_t *len,
                                struct gv_error *err);

struct gv_gpu_cache;

struct gv_gpu_cache_stats {
    uint64_t hits;        /* requests answered from the cache */
    uint64_t decodes;     /* tiles decoded on the GPU (the root upload included) */
    uint64_t fetches;     /* calls to the fetch callback */
    uint64_t evictions;   /* textures deleted to stay within the budget */
    size_t bytes, peak_bytes;
    size_t tiles;         /* textures held now */
};

/*
 * What the cache decodes tiles with: the image decoder (gpu_decode.h) or
 * the decoder of 16-bit codes (gpu_height.h), behind one table.  Made by
 * gv_gpu_tiles_image and gv_gpu_tiles_codes; the decoder is borrowed.
 */
struct gv_gpu_tiles {
    void *dec;
    size_t gpu_bytes;     /* GPU memory one decoded tile counts */
    size_t pixel_bytes;   /* bytes of a pixel of the root and of a read-back tile */
    int (*upload)(void *dec, const void *tile, uint32_t *handle,
                  struct gv_error *err);
    int (*decode)(void *dec, const uint8_t *buf, size_t len, uint32_t parent,
                  int qx, int qy, uint32_t *handle, struct gv_error *err);
    /* Many tiles in one call (gv_gpu_decode_batch), or NULL: one by one. */
    int (*batch)(void *dec, struct gv_gpu_tile_job *jobs, size_t n,
                 struct gv_error *err);
    int (*read)(void *dec, uint32_t handle, void *pixels, struct gv_error *err);
    void (*release)(void *dec, uint32_t handle);
};

/* Tiles of an image store of `channels` (1 or 3) bytes a pixel, decoded by
 * d (GV_GPU_TILE_BYTES each). */
struct gv_gpu_tiles gv_gpu_tiles_image(struct gv_gpu_decoder *d, int channels);

/* Tiles of 16-bit codes, `channels` (as h was made with) a pixel, decoded
 * by h: 513x513 x channels x 2 bytes each. */
struct gv_gpu_tiles gv_gpu_tiles_codes(struct gv_gpu_height *h, int channels);

/*
 * New cache over the decoder of *t (the table copied, its decoder
 * borrowed) for an image of geometry g (copied).  root: the root level
 * (root_w x root_h pixels of t->pixel_bytes, copied into the padded root
 * tile).  budget: bytes of textures to keep.  fetch(ctx, ...) supplies
 * tile buffers.  Returns the cache, or NULL with *err (GV_EINVAL: a root
 * empty or larger than a tile; GV_ENOMEM).
 */
struct gv_gpu_cache *gv_gpu_cache_new(const struct gv_gpu_tiles *t,
                                      const struct gv_geometry *g,
                                      const void *root, uint32_t root_w,
                                      uint32_t root_h, size_t budget,
                                      gv_tile_fetch_fn fetch, void *ctx,
                                      struct gv_error *err);

/* Delete every texture and free.  NULL does nothing. */
void gv_gpu_cache_free(struct gv_gpu_cache *c);

/*
 * The texture of tile (tx,ty) of `level` (the root level: tile (0,0)),
 * decoding it and its missing ancestors as needed.  *handle stays valid
 * until the next call on c.  Returns 0, or -1 (no such tile, fetch or
 * decode failure; the cache stays usable).
 */
int gv_gpu_cache_get(struct gv_gpu_cache *c, int level, uint32_t tx,
                     uint32_t ty, uint32_t *handle, struct gv_error *err);

/*
 * Decode in one batch (gv_gpu_decode_batch) every tile of `level` in
 * [t0x..t1x] x [t0y..t1y] (clipped to the grid) that is not cached, with
 * its missing ancestors, parents before children, so that the following
 * gv_gpu_cache_get / _read calls on them are hits.  Does nothing when they
 * would not all fit in the budget (the calls then decode tile by tile).
 * Returns 0, or -1 with *err (a fetch or a decode failed; the tiles
 * decoded so far are not kept, and the cache stays usable).
 */
int gv_gpu_cache_prepare(struct gv_gpu_cache *c, int level, uint32_t t0x,
                         uint32_t t0y, uint32_t t1x, uint32_t t1y,
                         struct gv_error *err);

/* gv_gpu_cache_get, then read the tile back into pixels (513x513 pixels
 * of the table's pixel_bytes; an image tile's mip 0). */
int gv_gpu_cache_read(struct gv_gpu_cache *c, int level, uint32_t tx,
                      uint32_t ty, void *pixels, struct gv_error *err);

/* Copy the counters so far into *st. */
void gv_gpu_cache_stats(const struct gv_gpu_cache *c,
                        struct gv_gpu_cache_stats *st);

#endif
