/*
 * output_cache.c - the encoded-output cache (see output_cache.h): one
 * mutex over a chained hash of keys and an LRU list of entries (most
 * recent at the head).  Bodies are copied in and out, so no entry is ever
 * in use outside the lock and eviction is always possible.
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "metrics.h"
#include "output_cache.h"

#define BUCKETS 4096

struct entry {
    char *key;
    uint8_t *body;
    size_t len;
    const char *mime;
    uint64_t hash;
    struct entry *hnext, *prev, *next;
};

struct output_cache {
    pthread_mutex_t lock;
    struct entry *bucket[BUCKETS];
    struct entry *head, *tail;
    size_t budget, bytes;
    uint64_t hits, misses, evictions, entries;
};

static uint64_t fnv1a(const char *s)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (; *s; s++) {
        h ^= (unsigned char)*s;
        h *= 0x100000001b3ull;
    }
    return h;
}

struct output_cache *output_cache_new(size_t budget)
{
    struct output_cache *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    pthread_mutex_init(&c->lock, NULL);
    c->budget = budget;
    return c;
}

static void entry_free(struct entry *e)
{
    free(e->key);
    free(e->body);
    free(e);
}

void output_cache_free(struct output_cache *c)
{
    if (!c)
        return;
    for (struct entry *e = c->head, *n; e; e = n) {
        n = e->next;
        entry_free(e);
    }
    pthread_mutex_destroy(&c->lock);
    free(c);
}

static struct entry **slot_of(struct output_cache *c, uint64_t h, const char *key)
{
    struct entry **p = &c->bucket[h % BUCKETS];
    while (*p && ((*p)->hash != h || strcmp((*p)->key, key)))
        p = &(*p)->hnext;
    return p;
}

static void lru_unlink(struct output_cache *c, struct entry *e)
{
    if (e->prev) e->prev->next = e->next; else c->head = e->next;
    if (e->next) e->next->prev = e->prev; else c->tail = e->prev;
    e->prev = e->next = NULL;
}

static void lru_push(struct output_cache *c, struct entry *e)
{
    e->prev = NULL;
    e->next = c->head;
    if (c->head) c->head->prev = e; else c->tail = e;
    c->head = e;
}

int output_cache_get(struct output_cache *c, const char *key, uint8_t **body,
                     size_t *len, const char **mime)
{
    uint64_t h = fnv1a(key);
    pthread_mutex_lock(&c->lock);
    struct entry *e = *slot_of(c, h, key);
    uint8_t *copy = e ? malloc(e->len ? e->len : 1) : NULL;
    if (copy) {
        memcpy(copy, e->body, e->len);
        *body = copy;
        *len = e->len;
        *mime = e->mime;
        lru_unlink(c, e);
        lru_push(c, e);
        c->hits++;
    } else {
        c->misses++;
    }
    pthread_mutex_unlock(&c->lock);
    return copy != NULL;
}

/* Evict from the tail until `room` more bytes fit; the victims are chained
 * on *freed (through hnext).  Caller holds the lock. */
static void make_room(struct output_cache *c, size_t room, struct entry **freed)
{
    while (c->tail && c->bytes + room > c->budget) {
        struct entry *e = c->tail;
        lru_unlink(c, e);
        struct entry **p = slot_of(c, e->hash, e->key);
        *p = e->hnext;
        c->bytes -= e->len;
        c->entries--;
        c->evictions++;
        e->hnext = *freed;
        *freed = e;
    }
}

void output_cache_put(struct output_cache *c, const char *key,
                      const uint8_t *body, size_t len, const char *mime)
{
    if (len > c->budget)
        return;
    struct entry *e = calloc(1, sizeof *e);
    if (!e || !(e->key = strdup(key)) || !(e->body = malloc(len ? len : 1))) {
        if (e)
            free(e->key);
        free(e);
        return;
    }
    memcpy(e->body, body, len);
    e->len = len;
    e->mime = mime;
    e->hash = fnv1a(key);
    struct entry *freed = NULL;
    pthread_mutex_lock(&c->lock);
    struct entry **p = slot_of(c, e->hash, key);
    if (*p) {
        freed = e; /* another thread put it first */
    } else {
        make_room(c, len, &freed);
        p = slot_of(c, e->hash, key);
        *p = e;
        lru_push(c, e);
        c->bytes += len;
        c->entries++;
    }
    pthread_mutex_unlock(&c->lock);
    for (struct entry *n; freed; freed = n) {
        n = freed->hnext;
        entry_free(freed);
    }
}

/* Same shape as page_cache_stats in page_cache.c: deliberately separate, each
 * copies its own counters under its own lock. */
void output_cache_stats(struct output_cache *c, struct output_cache_stats *s)
{
    pthread_mutex_lock(&c->lock);
    s->hits = c->hits;
    s->misses = c->misses;
    s->evictions = c->evictions;
    s->bytes = c->bytes;
    s->limit = c->budget;
    s->entries = c->entries;
    pthread_mutex_unlock(&c->lock);
}

void output_cache_metrics(struct output_cache *c, struct prom *out)
{
    struct output_cache_stats s;
    output_cache_stats(c, &s);
    prom_metric(out, "gigaview_output_cache_hits_total", "counter",
                "IIIF images and regions answered from the output cache.",
                "%llu", (unsigned long long)s.hits);
    prom_metric(out, "gigaview_output_cache_misses_total", "counter",
                "IIIF images and regions rendered (not in the output cache).",
                "%llu", (unsigned long long)s.misses);
    prom_metric(out, "gigaview_output_cache_evictions_total", "counter",
                "Encoded outputs evicted.", "%llu",
                (unsigned long long)s.evictions);
    prom_metric(out, "gigaview_output_cache_bytes", "gauge",
                "Bytes of encoded outputs cached.", "%llu",
                (unsigned long long)s.bytes);
    prom_metric(out, "gigaview_output_cache_limit_bytes", "gauge",
                "The output cache bound (output_cache_bytes).", "%llu",
                (unsigned long long)s.limit);
    prom_metric(out, "gigaview_output_cache_entries", "gauge",
                "Encoded outputs cached.", "%llu", (unsigned long long)s.entries);
}

void output_cache_etag(uint64_t identity, const char *canon, char *buf,
                       size_t size)
{
    snprintf(buf, size, "\"%016llx-%016llx\"", (unsigned long long)identity,
             (unsigned long long)fnv1a(canon));
}
