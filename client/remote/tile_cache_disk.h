/*
 * tile_cache_disk.h - compressed tile buffers kept on disk between runs of
 * the native client, with the ETag the server gave them.
 *
 * Location: DIR/<server>/<image>/ where DIR is --cache-dir, else
 * $XDG_CACHE_HOME/gigaview, else ~/.cache/gigaview; <server> is the base
 * URL with every character outside [A-Za-z0-9.-] replaced by '_'.  One file
 * per entry, named L-X-Y (tiles), root-M (root mips) or root-webp (the
 * root level as the store's lossless WebP):
 *
 *   "GVC1"  u32 etag length  etag  u64 data length  data  u32 CRC32 of all before
 *
 * Files are published atomically (base/atomic_file.h, without fsync), so
 * a reader sees a whole entry or none; an entry that fails
 * its checks is ignored (and overwritten by the next fetch).  Every failure
 * to write is silent: the cache is an optimisation only.
 */
#ifndef GV_TILE_CACHE_DISK_H
#define GV_TILE_CACHE_DISK_H

#include <stddef.h>
#include <stdint.h>

struct gv_disk_cache;

/* Open (creating directories) the cache for one image of one server.
 * dir NULL: the default location.  Returns NULL when no cache can be
 * used (no writable location); callers go on without one. */
struct gv_disk_cache *gv_disk_cache_open(const char *dir, const char *server,
                                         const char *image);

void gv_disk_cache_free(struct gv_disk_cache *dc);

/* Look up entry `name`.  On a hit returns 0 with *data (malloc'ed), *len
 * and etag (NUL-terminated, at most etag_cap - 1 bytes); -1 on a miss,
 * which a damaged entry, a longer etag or dc NULL also is. */
int gv_disk_cache_get(struct gv_disk_cache *dc, const char *name,
                      uint8_t **data, size_t *len, char *etag, size_t etag_cap);

/* Store (replacing) entry `name` atomically.  Errors are ignored. */
void gv_disk_cache_put(struct gv_disk_cache *dc, const char *name,
                       const uint8_t *data, size_t len, const char *etag);

/* The directory of this image's entries. */
const char *gv_disk_cache_dir(const struct gv_disk_cache *dc);

#endif
