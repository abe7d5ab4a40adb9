/*
 * tile_cache.h - one cache of decoded tiles, shared by every thread and
 * every store, bounded in bytes, with single-flight filling.
 *
 * An entry is a decoded tile of one store, keyed by (store, level, tx, ty);
 * `store` is a number the caller picks, unique per opened store (the
 * server's image serial; a private cache uses 0).  The first thread that
 * asks for a missing tile claims it and fills it (decodes it); every other
 * thread that asks meanwhile waits for that fill instead of decoding the
 * tile again, and then shares the result, or the failure.  So one tile is
 * decoded once however many requests want it at the same time.
 *
 * Entries in use are pinned (a reference count) and never evicted; the
 * others sit on an LRU list and are evicted, least recently used first,
 * whenever the bytes held exceed the budget.  The budget can thus be
 * exceeded only by pinned tiles: at most, per thread, the tile it decodes
 * and that tile's chain of ancestors.  The pixels live in slots of a
 * slab (base/slab.h): what the cache maps (`mapped`) exceeds `bytes` by
 * the slots' rounding to 4 KiB, by chunks not yet full and by one empty
 * chunk kept.  The cache is split into up to 16
 * shards (each with its own lock, hash and LRU, and an equal part of the
 * budget) so that threads seldom contend; a small budget gets fewer shards
 * so that each still holds a useful number of tiles.
 *
 * Claims only ever wait for tiles of higher levels (a parent is claimed
 * while its child's claim is held, never the reverse), so waiting cannot
 * deadlock.  Every function is thread-safe.
 */
#ifndef GV_TILE_CACHE_H
#define GV_TILE_CACHE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_tile_cache;
struct gv_tile_entry;

struct gv_tile_key {
    uint64_t store;
    int level;
    uint32_t tx, ty;
};

struct gv_tile_cache_stats {
    uint64_t hits;       /* acquires that found the tile filled */
    uint64_t misses;     /* acquires that claimed it: one fill (decode) each */
    uint64_t waits;      /* acquires that waited for another thread's fill */
    uint64_t evictions;
    uint64_t bytes;      /* held now, pinned entries included */
    uint64_t limit;      /* the budget */
    uint64_t entries;
    uint64_t waiting;    /* threads waiting for a fill right now */
    uint64_t mapped;     /* bytes of pixel memory mapped now */
    uint64_t lent;       /* buffers lent (gv_tile_cache_lend) */
};

/* A cache of at most budget bytes (0: nothing is kept once unpinned).
 * NULL on allocation failure. */
struct gv_tile_cache *gv_tile_cache_new(size_t budget);

/* Free every entry.  Nothing may be pinned.  NULL does nothing. */
void gv_tile_cache_free(struct gv_tile_cache *c);

/*
 * Find or claim tile *k, whose pixels take `bytes` bytes; *e is pinned.
 * Returns
 *   1  the tile is filled: read gv_tile_entry_pixels(*e);
 *   0  the caller claimed it: fill gv_tile_entry_pixels(*e) (`bytes`
 *      bytes, uninitialised), then call gv_tile_cache_publish, or
 *      gv_tile_cache_fail if the fill failed;
 *  -1  with *err: out of memory, or the fill this call waited for failed
 *      (its error); *e is NULL and nothing is pinned.
 * Each 1 or 0 is matched by one gv_tile_cache_release (after publishing).
 */
int gv_tile_cache_acquire(struct gv_tile_cache *c, const struct gv_tile_key *k,
                          size_t bytes, struct gv_tile_entry **e,
                          struct gv_error *err);

/* The entry's pixel buffer. */
uint8_t *gv_tile_entry_pixels(struct gv_tile_entry *e);

/* A claimed entry is filled: wake the threads waiting for it.  It stays
 * pinned by the caller. */
void gv_tile_cache_publish(struct gv_tile_cache *c, struct gv_tile_entry *e);

/* A claimed entry could not be filled: the waiting threads get *err, the
 * entry leaves the cache (a later acquire claims the tile again), and the
 * caller's pin is dropped (no release follows). */
void gv_tile_cache_fail(struct gv_tile_cache *c, struct gv_tile_entry *e,
                        const struct gv_error *err);

/* Drop one pin of e (from acquire).  NULL does nothing. */
void gv_tile_cache_release(struct gv_tile_cache *c, struct gv_tile_entry *e);

/* Evict every unpinned entry of `store` (a store being closed). */
/* A buffer of `bytes` from the memory the cache's tiles live in, for a
 * tile decoded outside the cache because nothing will ask for it again
 * soon; it is not counted in the budget, so give it back
 * (gv_tile_cache_give_back) as soon as it has been read.  A slot given
 * back is lent again without a page fault.  NULL when out of memory. */
uint8_t *gv_tile_cache_lend(struct gv_tile_cache *c, size_t bytes);

/* Give back p, lent for the same `bytes`.  NULL does nothing. */
void gv_tile_cache_give_back(struct gv_tile_cache *c, uint8_t *p, size_t bytes);

void gv_tile_cache_forget(struct gv_tile_cache *c, uint64_t store);

/* A snapshot of the counters (summed over the shards). */
void gv_tile_cache_stats(struct gv_tile_cache *c, struct gv_tile_cache_stats *s);

#endif
