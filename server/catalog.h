/*
 * catalog.h - the store directory: which images gigaviewd serves.
 *
 * An image is one open store (lib/store/store_read.h) under an id, the file name
 * without ".gv".  Ids follow the one rule of lib/base/ids.h ([A-Za-z0-9._-],
 * 1..128 bytes, no leading dot and no ".."), so an id can never name a
 * path outside the directory.  Images are reference counted: catalog_get hands out a
 * reference that a request holds while it uses the store, and a rescan
 * (SIGHUP) that drops or replaces a store only drops the catalog's own
 * reference, so the store is closed when the last request lets go.
 *
 * Each image also keeps a small pool of CPU decoders (lib/render/store_decoder.h;
 * a decoder is single-threaded and borrows the store): a request takes
 * one with image_decoder_get and returns it with image_decoder_put before
 * it drops its image reference, so every decoder is freed before its
 * store is closed.  Every decoder of every image keeps its decoded tiles
 * in the catalog's one tile cache (lib/render/tile_cache.h), under the
 * image's serial; an image's tiles are forgotten when it is closed.  Its
 * coarsest levels are decoded when it opens and stay (catalog_new).
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_CATALOG_H
#define GV_SERVER_CATALOG_H

#include <stddef.h>
#include <stdint.h>

#include "base/ids.h"
#include "render/store_decoder.h"
#include "render/samples_region.h"
#include "render/window.h"
#include "store/store_read.h"

#define CATALOG_ID_MAX GV_IMAGE_ID_MAX   /* base/ids.h */

struct image {
    char id[CATALOG_ID_MAX + 1];
    struct gv_store *store;            /* read-only after open */
    const struct gv_store_info *info;
    uint64_t serial;                   /* unique per opened instance */
    uint64_t identity;                 /* gv_store_identity: ETag seed */
    uint64_t bytes;                    /* file size */
    struct gv_window window;           /* the store's default display window
                                        * (its metadata's display.window;
                                        * count 0: none) */
    struct gv_colours colours;         /* a sample store's channel colours
                                        * (display.colours; count 0: the
                                        * palette) */
    /* private */
    int refs;
    uint64_t dev, ino, mtime_ns;
    struct catalog *cat;
    struct gv_decoder **pool;
    int npool;
    struct gv_tile_entry **pins;       /* the resident levels' tiles */
    int npins;
    uint64_t pinned;                   /* their bytes */
};

struct catalog;

/* A catalog over `dir` whose decoders share `tiles` (borrowed: it must
 * outlive the catalog), with at most pool_max idle decoders per image.
 * Each store opened keeps its coarsest levels decoded and pinned in
 * `tiles` until it closes (gv_decoder_pin_levels: the root, then whole
 * finer levels), all stores together within resident_bytes, taken in
 * the order the stores open; a store closed gives its share back.  So no
 * request to a store waits for the decodes near its root.  Does not scan
 * yet. */
struct catalog *catalog_new(const char *dir, struct gv_tile_cache *tiles,
                            int pool_max, uint64_t resident_bytes);

/* Free (every image must have been put back).  NULL does nothing. */
void catalog_free(struct catalog *c);

/* (Re)scan the directory: open new or changed stores, drop missing ones.
 * Stores that fail to open are logged and skipped.  Returns the number of
 * images served afterwards, or -1 if the directory cannot be read (the
 * old list is kept). */
int catalog_scan(struct catalog *c);


/* A new reference to image `id`, or NULL if there is none. */
struct image *catalog_get(struct catalog *c, const char *id);

/* Drop a reference from catalog_get or catalog_list.  NULL does nothing. */
void image_put(struct image *img);

/* References to every image, sorted by id: *out is malloc'ed (free it
 * after putting each image).  Returns the count, or -1. */
int catalog_list(struct catalog *c, struct image ***out);

/* Number of images. */
int catalog_count(struct catalog *c);

/* A decoder for img (from its pool, or new): NULL on allocation failure.
 * Return it with image_decoder_put while still holding img. */
struct gv_decoder *image_decoder_get(struct image *img);
void image_decoder_put(struct image *img, struct gv_decoder *d);

/* Called with the serial of each image when it is finally closed (the
 * page cache forgets its pages).  Set once before scanning. */
void catalog_on_close(struct catalog *c, void (*fn)(uint64_t serial, void *),
                      void *arg);

#endif
