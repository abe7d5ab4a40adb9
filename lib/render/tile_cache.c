/*
 * tile_cache.c - the shared decoded-tile cache (see tile_cache.h).
 *
 * Each shard is a mutex, a condition variable for the threads waiting on
 * a fill, a chained hash of its entries and a doubly linked LRU list of
 * its unpinned filled entries (most recent at the head).  An entry is
 * PENDING from its claim to its publish (or failure), then FILLED.  A
 * failed entry leaves the hash at once and is freed by its last holder.
 * Evicted entries are unlinked under the lock and freed after it.  The
 * pixel buffers come from one slab (base/slab.h): a tile decoded into a
 * slot that an evicted tile gave back, or into fresh huge pages, takes no
 * page fault per 4 KiB, which a fresh 770 KiB mapping a decode took
 * (bench/README.md, 2026-12-02 and 2026-12-03).
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "base/slab.h"
#include "render/tile_cache.h"

#define MAX_SHARDS 16
#define MIN_SHARD_BYTES (16u << 20) /* about 20 RGB tiles per shard */
#define BUCKETS 1024                /* per shard; chains stay short */

enum entry_state { PENDING, FILLED, FAILED };

struct gv_tile_entry {
    struct gv_tile_key key;
    enum entry_state state;
    int refs;
    int on_lru;
    size_t bytes;
    struct gv_tile_entry *hnext;           /* hash chain */
    struct gv_tile_entry *prev, *next;     /* LRU list */
    struct gv_error err;                   /* FAILED: why */
    uint8_t *pixels;
};

struct shard {
    pthread_mutex_t lock;
    pthread_cond_t filled;
    struct gv_tile_entry *bucket[BUCKETS];
    struct gv_tile_entry *head, *tail;     /* LRU: head most recent */
    size_t bytes, budget;
    uint64_t hits, misses, waits, evictions, entries, waiting;
};

struct gv_tile_cache {
    size_t budget;
    _Atomic uint64_t lent;
    struct gv_slab *pixels;                /* every entry's pixels */
    int nshards;
    struct shard shard[];
};

static uint64_t key_hash(const struct gv_tile_key *k)
{
    uint64_t h = k->store * 0x9E3779B97F4A7C15ull;
    h ^= ((uint64_t)(uint32_t)k->level << 48) ^ ((uint64_t)k->tx << 24) ^ k->ty;
    h *= 0xBF58476D1CE4E5B9ull;
    return h ^ (h >> 31);
}

static int key_equal(const struct gv_tile_key *a, const struct gv_tile_key *b)
{
    return a->store == b->store && a->level == b->level && a->tx == b->tx &&
           a->ty == b->ty;
}

/* The largest power of two <= 16 that leaves each shard MIN_SHARD_BYTES. */
static int shard_count(size_t budget)
{
    int n = 1;
    while (n < MAX_SHARDS && budget / (size_t)(2 * n) >= MIN_SHARD_BYTES)
        n *= 2;
    return n;
}

struct gv_tile_cache *gv_tile_cache_new(size_t budget)
{
    int n = shard_count(budget);
    struct gv_tile_cache *c = calloc(1, sizeof *c + (size_t)n * sizeof c->shard[0]);
    if (!c)
        return NULL;
    c->pixels = gv_slab_new();
    if (!c->pixels) {
        free(c);
        return NULL;
    }
    c->budget = budget;
    c->nshards = n;
    for (int i = 0; i < n; i++) {
        struct shard *s = &c->shard[i];
        pthread_mutex_init(&s->lock, NULL);
        pthread_cond_init(&s->filled, NULL);
        s->budget = budget / (size_t)n;
    }
    return c;
}

static void entry_free(struct gv_tile_cache *c, struct gv_tile_entry *e)
{
    gv_slab_put(c->pixels, e->pixels, e->bytes);
    free(e);
}

void gv_tile_cache_free(struct gv_tile_cache *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->nshards; i++) {
        struct shard *s = &c->shard[i];
        for (int b = 0; b < BUCKETS; b++)
            for (struct gv_tile_entry *e = s->bucket[b], *n; e; e = n) {
                n = e->hnext;
                entry_free(c, e);
            }
        pthread_mutex_destroy(&s->lock);
        pthread_cond_destroy(&s->filled);
    }
    gv_slab_free(c->pixels);
    free(c);
}

static struct shard *shard_of(struct gv_tile_cache *c, uint64_t h)
{
    return &c->shard[(h >> 40) & (uint64_t)(c->nshards - 1)];
}

static struct gv_tile_entry **slot_of(struct shard *s, uint64_t h,
                                      const struct gv_tile_key *k)
{
    struct gv_tile_entry **p = &s->bucket[h % BUCKETS];
    while (*p && !key_equal(&(*p)->key, k))
        p = &(*p)->hnext;
    return p;
}

static void lru_unlink(struct shard *s, struct gv_tile_entry *e)
{
    if (!e->on_lru)
        return;
    if (e->prev) e->prev->next = e->next; else s->head = e->next;
    if (e->next) e->next->prev = e->prev; else s->tail = e->prev;
    e->prev = e->next = NULL;
    e->on_lru = 0;
}

static void lru_push(struct shard *s, struct gv_tile_entry *e)
{
    e->prev = NULL;
    e->next = s->head;
    if (s->head) s->head->prev = e; else s->tail = e;
    s->head = e;
    e->on_lru = 1;
}

/* Remove e from the hash and the accounting (it is not on the LRU). */
static void hash_unlink(struct shard *s, struct gv_tile_entry *e)
{
    struct gv_tile_entry **p = slot_of(s, key_hash(&e->key), &e->key);
    if (*p == e)
        *p = e->hnext;
    e->hnext = NULL;
    s->bytes -= e->bytes;
    s->entries--;
}

/* Unlink least recently used entries until s is within its budget; they
 * are chained on *freed (through hnext) for the caller to free unlocked. */
static void evict_over_budget(struct shard *s, struct gv_tile_entry **freed)
{
    while (s->bytes > s->budget && s->tail) {
        struct gv_tile_entry *e = s->tail;
        lru_unlink(s, e);
        hash_unlink(s, e);
        e->hnext = *freed;
        *freed = e;
        s->evictions++;
    }
}

static void free_chain(struct gv_tile_cache *c, struct gv_tile_entry *e)
{
    for (struct gv_tile_entry *n; e; e = n) {
        n = e->hnext;
        entry_free(c, e);
    }
}

/* Wait for e (pinned) to leave PENDING.  Returns 1 filled, or -1 (failed:
 * *err, pin dropped).  Called with s locked. */
static int wait_fill(struct shard *s, struct gv_tile_entry *e,
                     struct gv_error *err)
{
    if (e->state == PENDING) {
        s->waits++;
        s->waiting++;
        while (e->state == PENDING)
            pthread_cond_wait(&s->filled, &s->lock);
        s->waiting--;
    }
    if (e->state == FILLED) {
        s->hits++;
        return 1;
    }
    *err = e->err;
    return -1;
}

/* A new PENDING entry for k with a `bytes` buffer, or NULL. */
static struct gv_tile_entry *entry_new(struct gv_tile_cache *c,
                                       const struct gv_tile_key *k,
                                       size_t bytes)
{
    struct gv_tile_entry *e = calloc(1, sizeof *e);
    if (!e)
        return NULL;
    e->pixels = gv_slab_get(c->pixels, bytes);
    if (!e->pixels) {
        free(e);
        return NULL;
    }
    e->key = *k;
    e->bytes = bytes;
    e->state = PENDING;
    e->refs = 1;
    return e;
}

int gv_tile_cache_acquire(struct gv_tile_cache *c, const struct gv_tile_key *k,
                          size_t bytes, struct gv_tile_entry **out,
                          struct gv_error *err)
{
    *out = NULL;
    uint64_t h = key_hash(k);
    struct shard *s = shard_of(c, h);
    struct gv_tile_entry *freed = NULL, *fresh = NULL;
    pthread_mutex_lock(&s->lock);
    for (;;) {
        struct gv_tile_entry **p = slot_of(s, h, k);
        struct gv_tile_entry *e = *p;
        if (e) {
            e->refs++;
            lru_unlink(s, e);
            int rc = wait_fill(s, e, err);
            if (rc < 0 && --e->refs == 0)
                freed = e; /* failed and already out of the hash */
            pthread_mutex_unlock(&s->lock);
            if (fresh)
                entry_free(c, fresh);
            free_chain(c, freed);
            if (rc > 0)
                *out = e;
            return rc;
        }
        if (fresh) {
            *p = fresh;
            s->bytes += bytes;
            s->entries++;
            s->misses++;
            evict_over_budget(s, &freed);
            pthread_mutex_unlock(&s->lock);
            free_chain(c, freed);
            *out = fresh;
            return 0;
        }
        /* Allocate without the lock, then look again: another thread may
         * have claimed the tile meanwhile. */
        pthread_mutex_unlock(&s->lock);
        fresh = entry_new(c, k, bytes);
        if (!fresh)
            return gv_fail(err, GV_ENOMEM, "tile cache: out of memory");
        pthread_mutex_lock(&s->lock);
    }
}

uint8_t *gv_tile_entry_pixels(struct gv_tile_entry *e)
{
    return e->pixels;
}

void gv_tile_cache_publish(struct gv_tile_cache *c, struct gv_tile_entry *e)
{
    struct shard *s = shard_of(c, key_hash(&e->key));
    pthread_mutex_lock(&s->lock);
    e->state = FILLED;
    pthread_cond_broadcast(&s->filled);
    pthread_mutex_unlock(&s->lock);
}

void gv_tile_cache_fail(struct gv_tile_cache *c, struct gv_tile_entry *e,
                        const struct gv_error *err)
{
    struct shard *s = shard_of(c, key_hash(&e->key));
    pthread_mutex_lock(&s->lock);
    e->state = FAILED;
    e->err = *err;
    hash_unlink(s, e);
    pthread_cond_broadcast(&s->filled);
    int last = --e->refs == 0;
    pthread_mutex_unlock(&s->lock);
    if (last)
        entry_free(c, e);
}

void gv_tile_cache_release(struct gv_tile_cache *c, struct gv_tile_entry *e)
{
    if (!e)
        return;
    struct shard *s = shard_of(c, key_hash(&e->key));
    struct gv_tile_entry *freed = NULL;
    pthread_mutex_lock(&s->lock);
    if (--e->refs == 0) {
        if (e->state == FAILED)
            freed = e;
        else
            lru_push(s, e);
    }
    evict_over_budget(s, &freed);
    pthread_mutex_unlock(&s->lock);
    free_chain(c, freed);
}

uint8_t *gv_tile_cache_lend(struct gv_tile_cache *c, size_t bytes)
{
    atomic_fetch_add_explicit(&c->lent, 1, memory_order_relaxed);
    return gv_slab_get(c->pixels, bytes);
}

void gv_tile_cache_give_back(struct gv_tile_cache *c, uint8_t *p, size_t bytes)
{
    gv_slab_put(c->pixels, p, bytes);
}

void gv_tile_cache_forget(struct gv_tile_cache *c, uint64_t store)
{
    for (int i = 0; i < c->nshards; i++) {
        struct shard *s = &c->shard[i];
        struct gv_tile_entry *freed = NULL;
        pthread_mutex_lock(&s->lock);
        for (struct gv_tile_entry *e = s->tail, *prev; e; e = prev) {
            prev = e->prev;
            if (e->key.store != store)
                continue;
            lru_unlink(s, e);
            hash_unlink(s, e);
            e->hnext = freed;
            freed = e;
            s->evictions++;
        }
        pthread_mutex_unlock(&s->lock);
        free_chain(c, freed);
    }
}

void gv_tile_cache_stats(struct gv_tile_cache *c, struct gv_tile_cache_stats *st)
{
    memset(st, 0, sizeof *st);
    st->limit = c->budget;
    for (int i = 0; i < c->nshards; i++) {
        struct shard *s = &c->shard[i];
        pthread_mutex_lock(&s->lock);
        st->hits += s->hits;
        st->misses += s->misses;
        st->waits += s->waits;
        st->evictions += s->evictions;
        st->bytes += s->bytes;
        st->entries += s->entries;
        st->waiting += s->waiting;
        pthread_mutex_unlock(&s->lock);
    }
    struct gv_slab_stats slab;
    gv_slab_stats(c->pixels, &slab);
    st->mapped = slab.mapped;
    st->lent = atomic_load_explicit(&c->lent, memory_order_relaxed);
}
