/*
 * store_read.h - reading a gigaview store file.
 *
 * gv_store_open validates everything it reads up front: header CRC, the
 * geometry, the root section (with its CRC; it is at most ~1 MiB and kept
 * in memory), the metadata section if any (store_meta.h) and the page index (CRC, every extent inside the file).
 * Pages are read on demand with pread and checked against their CRC before
 * any byte of them is used, so a damaged page fails alone and clearly.
 * A store is immutable; an open store may be shared by threads, since
 * reads are pread and the in-memory parts are read-only after open.
 */
#ifndef GV_STORE_READ_H
#define GV_STORE_READ_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "store/geometry.h"
#include "store/store_format.h"

struct gv_store;

struct gv_store_info {
    struct gv_header header;
    struct gv_geometry geometry;
};

/* Open and validate `path`.  Returns NULL with *err filled: GV_ENOTFOUND
 * for a missing file, GV_EFORMAT for a foreign file or version, GV_ECORRUPT
 * for a damaged or truncated store, GV_EIO or GV_ENOMEM. */
struct gv_store *gv_store_open(const char *path, struct gv_error *err);

/* Close.  gv_store_close(NULL) does nothing. */
void gv_store_close(struct gv_store *s);

const struct gv_store_info *gv_store_info(const struct gv_store *s);

/* The store's metadata (store_meta.h: a JSON object of at most
 * GV_META_MAX_JSON bytes, checked at open), NUL-terminated and valid
 * until close; NULL when the store has none (or one of a newer section
 * version).  Any thread. */
const char *gv_store_meta(const struct gv_store *s);

/*
 * The store's identity: a 64-bit hash, computed at open, of the header,
 * the root section's CRC and the whole page index (each page's offset,
 * size and CRC, and the index's own CRC), so every byte that can change a
 * pixel or a field of the header changes it (up to the CRCs' and the
 * hash's collisions).  It depends on the file's bytes alone: equal files
 * (a sharded encode merged and the unsharded one, a copy, the same file
 * opened twice) have equal identities, on any host and in any format
 * version the reader accepts.  What gigaviewd derives its ETags from
 * (docs/FORMAT.md section 6).  Any thread.
 */
uint64_t gv_store_identity(const struct gv_store *s);

/* Root mip `mip` (0 = the root level itself): its pixels (read-only, valid
 * until close) and size.  NULL if mip is out of range.  In a height store
 * (header.kind GV_KIND_HEIGHT) the pixels are w*h host-order uint16_t
 * codes (2-byte aligned), not bytes. */
const uint8_t *gv_store_root(const struct gv_store *s, int mip, uint32_t *w,
                             uint32_t *h);

/*
 * The root section's WebP bytes as stored (docs/FORMAT.md section 6: a
 * lossless WebP whose decode is the root level; a gray root has three
 * equal channels), read from the file again and checked against the
 * section's CRC, into a new malloc'ed buffer (*data, caller frees): what a
 * client can decode itself instead of fetching raw samples.  Returns 0, or
 * -1 with GV_EFORMAT for a height store (its root is zlib of 16-bit
 * codes, section 12), GV_ECORRUPT (CRC), GV_EIO or GV_ENOMEM.
 */
int gv_store_read_root_webp(const struct gv_store *s, uint8_t **data,
                            size_t *len, struct gv_error *err);

/* Extent of page number `page` in the file, from the page index (checked
 * at open to lie inside the file).  Returns 0, or -1 past the last page. */
int gv_store_page_extent(const struct gv_store *s, uint64_t page,
                         uint64_t *offset, uint32_t *size, uint32_t *crc);

/* Total bytes of the pages of `level` (for bits-per-pixel figures); 0 for
 * the root level and past it. */
uint64_t gv_store_level_bytes(const struct gv_store *s, int level);

/*
 * Read page (px,py) of `level` into a new malloc'ed buffer (*data, caller
 * frees) after checking its CRC and its tile table (gv_page_check).
 * Returns 0, or -1 with GV_ENOTFOUND (no such page), GV_ECORRUPT, GV_EIO
 * or GV_ENOMEM.
 */
int gv_store_read_page(const struct gv_store *s, int level, uint32_t px,
                       uint32_t py, uint8_t **data, size_t *len,
                       struct gv_error *err);

/*
 * Locate tile (i,j) (0..7 within the page) in a page buffer that
 * gv_store_read_page returned.  *tile points into page.  Returns 0, or -1
 * with GV_ENOTFOUND for an empty slot (outside the level's grid),
 * GV_EINVAL for a bad (i,j), GV_ECORRUPT for a slot outside the page.
 * `channels` is unused.
 */
int gv_page_tile(const uint8_t *page, size_t len, int channels, int i, int j,
                 const uint8_t **tile, size_t *tile_len, struct gv_error *err);

/* Check a page buffer's header and tile table against (level, px, py) of
 * a tiled level (the caller checks that the page exists) and the channel
 * count: every slot inside the page, 4-byte aligned and a well-formed tile
 * buffer (gv_tilebuf_check), empty slots exactly those outside the grid.
 * Returns 0, or -1 with GV_ECORRUPT. */
int gv_page_check(const struct gv_store *s, const uint8_t *page, size_t len,
                  int level, uint32_t px, uint32_t py, struct gv_error *err);

#endif
