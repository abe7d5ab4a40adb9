/*
 * page_cache.h - an LRU cache of whole store pages, bounded in bytes.
 *
 * Pages (8x8 tiles, lib/store/store_read.h) are the unit of disk I/O: a miss reads
 * the page with gv_store_read_page (pread, CRC and tile table checked) and
 * keeps it.  Entries are reference counted, so that a tile response can
 * point straight into a cached page (no copy): the response holds a
 * reference and drops it with page_release when libmicrohttpd is done.
 * An evicted page that is still referenced stays alive until released.
 * Keys are (image serial, level, px, py): a replaced store has a new
 * serial, so it never sees its predecessor's pages.  A page that fails its
 * check is never cached.  Thread-safe.
 */
#ifndef GV_SERVER_PAGE_CACHE_H
#define GV_SERVER_PAGE_CACHE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "store/store_read.h"

struct page_cache;

struct page {
    const uint8_t *data;  /* the page as read, checked */
    size_t len;
    /* private fields follow in page_cache.c */
};

/* A cache holding at most max_bytes of pages (0: no caching, every
 * request reads).  NULL on allocation failure. */
struct page_cache *page_cache_new(uint64_t max_bytes);

/* Free (every page must have been released).  NULL does nothing. */
void page_cache_free(struct page_cache *pc);

/* Page (px,py) of `level` of store s, known by `serial`: a new reference,
 * or NULL with *err (GV_ENOTFOUND, GV_ECORRUPT, GV_EIO, GV_ENOMEM). */
struct page *page_get(struct page_cache *pc, const struct gv_store *s,
                      uint64_t serial, int level, uint32_t px, uint32_t py,
                      struct gv_error *err);

/* Drop a reference.  NULL does nothing.  Any thread. */
void page_release(struct page *p);

/* Forget every page of `serial` (the store was closed). */
void page_cache_forget(struct page_cache *pc, uint64_t serial);

struct page_cache_stats {
    uint64_t hits, misses, evictions, errors, bytes, pages, max_bytes;
};

/* The counters since start (errors: pages that failed their check or
 * could not be read) and the present size, read together under the
 * lock. */
void page_cache_stats(struct page_cache *pc, struct page_cache_stats *st);

#endif
