/*
 * store_decoder.h - the CPU reference decoder over a store: tiles at any level,
 * with their ancestors pulled recursively (section 7.5), and regions.
 *
 * Decoded tiles live in a gv_tile_cache (render/tile_cache.h), bounded in
 * bytes, so decoding the tiles of a region in order touches each ancestor
 * once.  The cache is either the decoder's own (gv_decoder_new) or one
 * shared by many decoders over many stores (gv_decoder_new_shared: a
 * server's threads then decode each tile once between them).  A decoder
 * is not thread-safe: use one per thread (they may share the store and
 * the cache).
 */
#ifndef GV_STORE_DECODER_H
#define GV_STORE_DECODER_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "render/tile_cache.h"
#include "store/store_read.h"

struct gv_decoder;
struct gv_window;
struct gv_colours;

/* New decoder over s (borrowed; it must outlive the decoder) with a
 * private tile cache of at most cache_bytes (beyond the tiles in use: the
 * one returned last and, while decoding, its chain of ancestors).
 * Returns NULL on allocation failure. */
struct gv_decoder *gv_decoder_new(const struct gv_store *s, size_t cache_bytes);

/* New decoder over s keeping its tiles in `cache` (borrowed, shared, it
 * must outlive the decoder) under the store number `store_key`, unique to
 * s among the stores that use the cache.  NULL on allocation failure. */
struct gv_decoder *gv_decoder_new_shared(const struct gv_store *s,
                                         struct gv_tile_cache *cache,
                                         uint64_t store_key);

/* Free.  NULL does nothing. */
void gv_decoder_free(struct gv_decoder *d);

/* Unpin the tile gv_decoder_tile returned last (its pixels are no longer
 * valid), so that an idle decoder holds nothing the cache could evict. */
void gv_decoder_idle(struct gv_decoder *d);

/* The store d reads (as given to gv_decoder_new). */
const struct gv_store *gv_decoder_store(const struct gv_decoder *d);

/*
 * Decode tile (tx,ty) of `level` (0 <= level <= root; level root is the
 * single tile (0,0), the root image clamp-padded to 513x513).  *pixels
 * points at 513x513xC bytes owned by the cache (for a height store
 * 513x513 host-order uint16_t codes, 2-byte aligned), pinned by the decoder
 * until its next call (or gv_decoder_free).  Returns 0, or -1 with *err filled (GV_ENOTFOUND for a tile
 * outside the level; a corrupt page or tile, or I/O, as the store reports
 * it).
 */
int gv_decoder_tile(struct gv_decoder *d, int level, uint32_t tx, uint32_t ty,
                    const uint8_t **pixels, struct gv_error *err);

/*
 * Decode the region [x, x+w) x [y, y+h) of `level` into out (w*h*C bytes,
 * rows packed, C = gv_display_channels; a height store gives one 8-bit
 * gray channel, its codes mapped by gv_height_gray, and gv_height_region
 * gives the codes; a sample store gives gray or RGB through its default
 * window, samples_region.h).
 * Levels root..root+root_mips-1 read the stored root mips.  Defined in
 * decode_region.c, above both this decoder and height_region.c.
 * Pixel (x,y) of a tiled level comes from tile min(x/512, tiles_x-1) (same
 * for y), so each pixel has exactly one source.  Returns 0 or -1 (region
 * outside the level, or a decoding failure).
 */
int gv_decode_region(struct gv_decoder *d, int level, uint32_t x, uint32_t y,
                     uint32_t w, uint32_t h, uint8_t *out,
                     struct gv_error *err);

/* gv_decode_region through display window `win` (window.h; NULL or count
 * 0: none; for a sample store, NULL is its default window and count 0 its
 * range, and `col` its colours, NULL the store's: samples_region.h;
 * ignored for other stores): applied to a
 * sample store's codes before they become 8-bit, to the 8-bit pixels of
 * any other store.  0 or -1 (also GV_EINVAL for a window of another
 * channel count). */
int gv_decode_region_window(struct gv_decoder *d, int level, uint32_t x,
                            uint32_t y, uint32_t w, uint32_t h,
                            const struct gv_window *win,
                            const struct gv_colours *col, uint8_t *out,
                            struct gv_error *err);

/*
 * The region reader under gv_decode_region and gv_height_region: check
 * that [x, x+w) x [y, y+h) is a non-empty region inside `level` (0 ..
 * root + root_mips - 1, as gv_level_size counts them), then copy it into
 * dst in pixel units (C bytes for an image, one host-order uint16_t code
 * for a height store), rows packed, from the tiles as gv_decode_region
 * describes or from the root mips.  Returns 0, or -1 with *err: GV_EINVAL
 * for a level or region outside the store, its message prefixed with
 * `module` ("decode: no level 9 (levels 0..4)"), or a decoding failure.
 */
int gv_decoder_copy_region(struct gv_decoder *d, const char *module,
                           int level, uint32_t x, uint32_t y, uint32_t w,
                           uint32_t h, void *dst, struct gv_error *err);

/*
 * Decode the coarsest levels of d's store and keep them pinned in its
 * cache: the root tile, then each finer tiled level whole, as long as the
 * level's tiles fit in what is left of `budget` bytes (a level that does
 * not fit ends the descent).  *pins (malloc'ed; free it) receives *npins
 * pinned entries, each to be let go with gv_tile_cache_release before
 * the store is forgotten; *bytes their pixel bytes.  Returns 0, or -1
 * with *err (a decoding failure: nothing stays pinned).
 */
int gv_decoder_pin_levels(struct gv_decoder *d, uint64_t budget,
                          struct gv_tile_entry ***pins, int *npins,
                          uint64_t *bytes, struct gv_error *err);

/* Where a decoder's time went, in nanoseconds, summed over its calls
 * since it was made or last reset: reading (and checking) pages, decoding
 * tiles (each tile's own decode, the missing ancestors included as they
 * are decoded, and the root tile's padding), and finding tiles in the
 * cache (mostly the waits for another thread's decode of a tile it
 * needed). */
struct gv_decode_times {
    uint64_t page_ns, decode_ns, wait_ns;
};

/* d's times into *t; reset: zero them afterwards. */
void gv_decoder_times(struct gv_decoder *d, struct gv_decode_times *t,
                      int reset);

/* Build the padded root tile (513x513xC) from a w x h root image. */
void gv_root_tile(const uint8_t *root, uint32_t w, uint32_t h, int channels,
                  uint8_t *tile);

#endif
