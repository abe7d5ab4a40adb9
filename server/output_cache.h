/*
 * output_cache.h - encoded IIIF images and regions, kept by their
 * canonical request, so a hot tile is rendered once.
 *
 * A key is a request in canonical form (route_iiif.c and route_region.c
 * build it: the image instance, then the parsed and normalised region,
 * size, rotation, quality, format and encoder quality), so two spellings
 * of the same request share one entry.  An entry keeps the encoded bytes
 * and their media type; the cache keeps at most output_cache_bytes of
 * bodies (LRU; a body above the budget is not kept; 0 keeps nothing).
 * The routes give each answer a strong ETag (output_cache_etag: the same
 * bytes for the same store contents and canonical request) and answer 304
 * to a matching If-None-Match without rendering.
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_OUTPUT_CACHE_H
#define GV_SERVER_OUTPUT_CACHE_H

#include <stddef.h>
#include <stdint.h>

struct output_cache;
struct prom;

struct output_cache_stats {
    uint64_t hits, misses, evictions;
    uint64_t bytes, limit, entries;
};

/* A cache of at most budget bytes of bodies.  NULL on allocation failure. */
struct output_cache *output_cache_new(size_t budget);

/* Free.  NULL does nothing. */
void output_cache_free(struct output_cache *c);

/* The body cached under key: 1 with a malloc'ed copy in *body (*len
 * bytes, the caller frees it) and its media type in *mime (a static
 * string), or 0 (a miss, counted; also on allocation failure). */
int output_cache_get(struct output_cache *c, const char *key, uint8_t **body,
                     size_t *len, const char **mime);

/* Keep a copy of body (len bytes, media type mime: a static string) under
 * key, evicting the least recently used bodies to stay within the budget.
 * A key already there is left alone.  Allocation failure keeps nothing. */
void output_cache_put(struct output_cache *c, const char *key,
                      const uint8_t *body, size_t len, const char *mime);

void output_cache_stats(struct output_cache *c, struct output_cache_stats *s);

/* The cache's counters for /metrics (docs/API.md). */
void output_cache_metrics(struct output_cache *c, struct prom *out);

/* The strong ETag of the answer to canonical request `canon` of a store
 * whose identity (gv_store_identity) is `identity`:
 * "\"IIIIIIIIIIIIIIII-HHHHHHHHHHHHHHHH\"" (the identity, then a 64-bit
 * FNV-1a hash of canon, in hex), into buf (OUTPUT_ETAG_SIZE bytes or
 * more; a smaller buf gets a truncated, useless string).  A client
 * revalidates it with If-None-Match (http_etag_listed). */
#define OUTPUT_ETAG_SIZE 36
void output_cache_etag(uint64_t identity, const char *canon, char *buf,
                       size_t size);

#endif
