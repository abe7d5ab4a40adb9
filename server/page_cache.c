/*
 * page_cache.c - byte-bounded LRU of store pages (see page_cache.h).
 *
 * A chained hash table finds entries, a doubly linked list orders them
 * from most to least recently used, and one mutex guards both.  Reading a
 * page from disk happens outside the mutex; if two threads miss on the
 * same page at once, both read it and the second one's copy is dropped
 * (cheaper than making the first one's waiters sleep, and rare).
 * The cache itself holds one reference to every linked entry; eviction
 * unlinks an entry and drops that reference, so a page still being sent
 * is freed by whoever releases it last.
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "page_cache.h"

struct entry {
    struct page pub;         /* first: page_release casts back */
    uint8_t *buf;
    atomic_int refs;
    uint64_t serial;
    uint32_t px, py;
    int level;
    int linked;
    struct entry *hnext;     /* hash chain */
    struct entry *prev, *next; /* LRU: head is the most recent */
};

#define NBUCKETS 4096 /* power of two; a 256 MiB cache holds ~100 pages
                         of a typical 2 bpp store, so chains stay short */

struct page_cache {
    pthread_mutex_t lock;
    struct entry *bucket[NBUCKETS];
    struct entry *head, *tail;
    uint64_t bytes, max_bytes, pages;
    uint64_t hits, misses, evictions, errors;
};

static unsigned hash(uint64_t serial, int level, uint32_t px, uint32_t py)
{
    uint64_t h = serial * 0x9e3779b97f4a7c15ull;
    h ^= (uint64_t)level * 0xc2b2ae3d27d4eb4full;
    h ^= ((uint64_t)px << 32 | py) * 0x165667b19e3779f9ull;
    h ^= h >> 29;
    return (unsigned)(h & (NBUCKETS - 1));
}

struct page_cache *page_cache_new(uint64_t max_bytes)
{
    struct page_cache *pc = calloc(1, sizeof *pc);
    if (!pc)
        return NULL;
    pthread_mutex_init(&pc->lock, NULL);
    pc->max_bytes = max_bytes;
    return pc;
}

static void entry_unref(struct entry *e)
{
    if (atomic_fetch_sub(&e->refs, 1) == 1) {
        free(e->buf);
        free(e);
    }
}

void page_release(struct page *p)
{
    if (p)
        entry_unref((struct entry *)p);
}

/* Unlink e from the hash and the list.  Caller holds the lock. */
/* Same shape as conn_watch_close in conn_watch.c: deliberately separate, each
 * unlinks its own list. */
static void unlink_entry(struct page_cache *pc, struct entry *e)
{
    struct entry **pp = &pc->bucket[hash(e->serial, e->level, e->px, e->py)];
    while (*pp != e)
        pp = &(*pp)->hnext;
    *pp = e->hnext;
    if (e->prev)
        e->prev->next = e->next;
    else
        pc->head = e->next;
    if (e->next)
        e->next->prev = e->prev;
    else
        pc->tail = e->prev;
    pc->bytes -= e->pub.len;
    pc->pages--;
    e->linked = 0;
}

static void push_front(struct page_cache *pc, struct entry *e)
{
    e->prev = NULL;
    e->next = pc->head;
    if (pc->head)
        pc->head->prev = e;
    pc->head = e;
    if (!pc->tail)
        pc->tail = e;
}

void page_cache_free(struct page_cache *pc)
{
    if (!pc)
        return;
    while (pc->head) {
        struct entry *e = pc->head;
        unlink_entry(pc, e);
        entry_unref(e);
    }
    pthread_mutex_destroy(&pc->lock);
    free(pc);
}

static struct entry *lookup(struct page_cache *pc, uint64_t serial, int level,
                            uint32_t px, uint32_t py)
{
    for (struct entry *e = pc->bucket[hash(serial, level, px, py)]; e; e = e->hnext)
        if (e->serial == serial && e->level == level && e->px == px && e->py == py)
            return e;
    return NULL;
}

/* Drop the references of a chain of unlinked entries (through hnext). */
static void unref_chain(struct entry *victims)
{
    while (victims) {
        struct entry *v = victims;
        victims = v->hnext;
        entry_unref(v);
    }
}

/* Cache the new entry e (which holds the caller's reference), evicting
 * from the tail down to max_bytes; if another thread cached the same page
 * meanwhile, drop e and return that one instead, referenced. */
static struct entry *insert(struct page_cache *pc, struct entry *e)
{
    pthread_mutex_lock(&pc->lock);
    struct entry *other = lookup(pc, e->serial, e->level, e->px, e->py);
    if (other) { /* lost a race: use the cached copy */
        atomic_fetch_add(&other->refs, 1);
        pthread_mutex_unlock(&pc->lock);
        entry_unref(e);
        return other;
    }
    atomic_fetch_add(&e->refs, 1); /* the cache's */
    unsigned b = hash(e->serial, e->level, e->px, e->py);
    e->hnext = pc->bucket[b];
    pc->bucket[b] = e;
    push_front(pc, e);
    e->linked = 1;
    pc->bytes += e->pub.len;
    pc->pages++;
    struct entry *victims = NULL;
    while (pc->bytes > pc->max_bytes && pc->tail && pc->tail != e) {
        struct entry *v = pc->tail;
        unlink_entry(pc, v);
        pc->evictions++;
        v->hnext = victims;
        victims = v;
    }
    pthread_mutex_unlock(&pc->lock);
    unref_chain(victims);
    return e;
}

struct page *page_get(struct page_cache *pc, const struct gv_store *s,
                      uint64_t serial, int level, uint32_t px, uint32_t py,
                      struct gv_error *err)
{
    pthread_mutex_lock(&pc->lock);
    struct entry *e = lookup(pc, serial, level, px, py);
    if (e) {
        atomic_fetch_add(&e->refs, 1);
        /* move to the front */
        if (e != pc->head) {
            e->prev->next = e->next;
            if (e->next)
                e->next->prev = e->prev;
            else
                pc->tail = e->prev;
            push_front(pc, e);
        }
        pc->hits++;
        pthread_mutex_unlock(&pc->lock);
        return &e->pub;
    }
    pc->misses++;
    pthread_mutex_unlock(&pc->lock);

    uint8_t *buf;
    size_t len;
    if (gv_store_read_page(s, level, px, py, &buf, &len, err) < 0) {
        pthread_mutex_lock(&pc->lock);
        if (err->code == GV_ECORRUPT || err->code == GV_EIO)
            pc->errors++;
        pthread_mutex_unlock(&pc->lock);
        return NULL;
    }
    e = calloc(1, sizeof *e);
    if (!e) {
        free(buf);
        gv_fail(err, GV_ENOMEM, "page cache: out of memory");
        return NULL;
    }
    e->buf = buf;
    e->pub.data = buf;
    e->pub.len = len;
    e->serial = serial;
    e->level = level;
    e->px = px;
    e->py = py;
    atomic_init(&e->refs, 1); /* the caller's */
    if (pc->max_bytes == 0 || len > pc->max_bytes)
        return &e->pub; /* uncached: freed on release */
    return &insert(pc, e)->pub;
}

void page_cache_forget(struct page_cache *pc, uint64_t serial)
{
    struct entry *victims = NULL;
    pthread_mutex_lock(&pc->lock);
    for (struct entry *e = pc->head, *next; e; e = next) {
        next = e->next;
        if (e->serial == serial) {
            unlink_entry(pc, e);
            e->hnext = victims;
            victims = e;
        }
    }
    pthread_mutex_unlock(&pc->lock);
    unref_chain(victims);
}

/* Same shape as output_cache_stats in output_cache.c: deliberately separate,
 * each copies its own counters under its own lock. */
void page_cache_stats(struct page_cache *pc, struct page_cache_stats *st)
{
    pthread_mutex_lock(&pc->lock);
    st->hits = pc->hits;
    st->misses = pc->misses;
    st->evictions = pc->evictions;
    st->errors = pc->errors;
    st->bytes = pc->bytes;
    st->pages = pc->pages;
    st->max_bytes = pc->max_bytes;
    pthread_mutex_unlock(&pc->lock);
}
