/*
 * slab.c - large buffers cut from huge-page chunks (see slab.h).
 *
 * The classes are a small table of slot sizes, found by a linear search
 * (a cache has one or two).  Each class keeps a doubly linked list of its
 * chunks, those with a free slot before those without, so a get takes the
 * head's slot or maps a chunk.  A chunk's free slots are a stack of their indices.  A put finds
 * its chunk by address in the class's list (a few dozen chunks at most
 * for a cache of a few hundred MiB; the cost is nothing beside a decode).
 */
#include <pthread.h>
#include <stdlib.h>
#include <sys/mman.h>

#include "base/slab.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/asan_interface.h>
#define POISON(p, n) ASAN_POISON_MEMORY_REGION((p), (n))
#define UNPOISON(p, n) ASAN_UNPOISON_MEMORY_REGION((p), (n))
#else
#define POISON(p, n) ((void)(p), (void)(n))
#define UNPOISON(p, n) ((void)(p), (void)(n))
#endif

#define UNIT ((size_t)2 << 20)   /* a huge page on x86-64 and most arm64 */
#define PAGE ((size_t)4096)
#define MIN_BYTES ((size_t)64 << 10)  /* smaller buffers go to malloc */
#define MAX_BYTES ((size_t)16 << 20)  /* larger buffers go to malloc */
#define CLASSES 32
#define MAX_UNITS 16

struct chunk {
    uint8_t *base;                /* UNIT-aligned, `bytes` long */
    size_t bytes;
    int cls;                      /* its slots' size is the class's */
    int nslots, nfree;
    struct chunk *prev, *next;    /* in its class's list */
    uint16_t free[];              /* free slots' indices, nfree of them */
};

struct gv_slab {
    pthread_mutex_t lock;
    int nclasses;
    size_t slot[CLASSES];         /* each class's slot size */
    struct chunk *head[CLASSES], *tail[CLASSES];
    struct chunk *empty;          /* one empty chunk kept, on no list */
    uint64_t mapped, used, chunks, maps;
};

static int in_range(size_t bytes)
{
    return bytes >= MIN_BYTES && bytes <= MAX_BYTES;
}

static size_t page_round(size_t bytes)
{
    return (bytes + PAGE - 1) & ~(PAGE - 1);
}

size_t gv_slab_slot_bytes(size_t bytes)
{
    return in_range(bytes) ? page_round(bytes) : bytes;
}

/* The class of slots of `slot` bytes: found, else added when `add` and
 * the table has room; -1 otherwise.  Called with s locked. */
static int class_of(struct gv_slab *s, size_t slot, int add)
{
    for (int i = 0; i < s->nclasses; i++)
        if (s->slot[i] == slot)
            return i;
    if (!add || s->nclasses == CLASSES)
        return -1;
    s->slot[s->nclasses] = slot;
    return s->nclasses++;
}

/* The bytes of a chunk for slots of `slot` bytes: the fewest units whose
 * unused tail is at most an eighth of them (else the least tail). */
static size_t chunk_bytes(size_t slot)
{
    size_t best = 0, best_tail = (size_t)-1;
    for (size_t u = 1; u <= MAX_UNITS; u++) {
        size_t bytes = u * UNIT;
        if (bytes < slot)
            continue;
        size_t tail = bytes % slot;
        if (tail * 8 <= bytes)
            return bytes;
        if (tail < best_tail) {
            best_tail = tail;
            best = bytes;
        }
    }
    return best;
}

/* A UNIT-aligned anonymous mapping of `bytes`, huge pages asked for. */
static uint8_t *map_aligned(size_t bytes)
{
    size_t len = bytes + UNIT;
    uint8_t *p = mmap(NULL, len, PROT_READ | PROT_WRITE,
                      MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED)
        return NULL;
    uintptr_t at = ((uintptr_t)p + UNIT - 1) & ~(uintptr_t)(UNIT - 1);
    uint8_t *base = (uint8_t *)at;
    if (base > p)
        munmap(p, (size_t)(base - p));
    size_t after = (size_t)(p + len - (base + bytes));
    if (after)
        munmap(base + bytes, after);
    (void)madvise(base, bytes, MADV_HUGEPAGE);   /* a hint: may be refused */
    return base;
}

/* Cut chunk c into slots of class cls, every one free and poisoned. */
static void carve(struct chunk *c, int cls, size_t slot)
{
    c->cls = cls;
    c->nslots = (int)(c->bytes / slot);
    c->nfree = c->nslots;
    for (int i = 0; i < c->nslots; i++)
        c->free[i] = (uint16_t)(c->nslots - 1 - i);   /* slot 0 on top */
    c->prev = c->next = NULL;
    POISON(c->base, c->bytes);
}

static void unmap_chunk(struct gv_slab *s, struct chunk *c)
{
    UNPOISON(c->base, c->bytes);
    munmap(c->base, c->bytes);
    s->mapped -= c->bytes;
    s->chunks--;
    free(c);
}

/* A chunk for class cls: the empty one kept where its size fits, else a
 * new mapping.  NULL when out of memory. */
static struct chunk *chunk_for(struct gv_slab *s, int cls, size_t slot)
{
    size_t bytes = chunk_bytes(slot);
    struct chunk *c = s->empty;
    if (c && c->bytes == bytes) {
        s->empty = NULL;
        carve(c, cls, slot);
        return c;
    }
    size_t max_slots = bytes / MIN_BYTES;
    c = malloc(sizeof *c + max_slots * sizeof c->free[0]);
    if (!c)
        return NULL;
    c->bytes = bytes;
    c->base = map_aligned(bytes);
    if (!c->base) {
        free(c);
        return NULL;
    }
    s->mapped += bytes;
    s->chunks++;
    s->maps++;
    carve(c, cls, slot);
    return c;
}

static void list_unlink(struct gv_slab *s, struct chunk *c)
{
    if (c->prev) c->prev->next = c->next; else s->head[c->cls] = c->next;
    if (c->next) c->next->prev = c->prev; else s->tail[c->cls] = c->prev;
    c->prev = c->next = NULL;
}

static void list_push_head(struct gv_slab *s, struct chunk *c)
{
    c->prev = NULL;
    c->next = s->head[c->cls];
    if (c->next) c->next->prev = c; else s->tail[c->cls] = c;
    s->head[c->cls] = c;
}

static void list_push_tail(struct gv_slab *s, struct chunk *c)
{
    c->next = NULL;
    c->prev = s->tail[c->cls];
    if (c->prev) c->prev->next = c; else s->head[c->cls] = c;
    s->tail[c->cls] = c;
}

struct gv_slab *gv_slab_new(void)
{
    struct gv_slab *s = calloc(1, sizeof *s);
    if (s)
        pthread_mutex_init(&s->lock, NULL);
    return s;
}

void gv_slab_free(struct gv_slab *s)
{
    if (!s)
        return;
    for (int k = 0; k < s->nclasses; k++)
        for (struct chunk *c = s->head[k], *n; c; c = n) {
            n = c->next;
            unmap_chunk(s, c);
        }
    if (s->empty)
        unmap_chunk(s, s->empty);
    pthread_mutex_destroy(&s->lock);
    free(s);
}

void *gv_slab_get(struct gv_slab *s, size_t bytes)
{
    if (bytes == 0)
        bytes = 1;
    const size_t slot = page_round(bytes);
    int cls = -1;
    if (in_range(bytes)) {
        pthread_mutex_lock(&s->lock);
        cls = class_of(s, slot, 1);
        if (cls < 0)
            pthread_mutex_unlock(&s->lock);
    }
    if (cls < 0)   /* outside the range, or a size past the table's room */
        return aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    struct chunk *c = s->head[cls];
    if (!c || c->nfree == 0) {
        c = chunk_for(s, cls, slot);
        if (!c) {
            pthread_mutex_unlock(&s->lock);
            return NULL;
        }
        list_push_head(s, c);
    }
    uint8_t *p = c->base + (size_t)c->free[--c->nfree] * slot;
    if (c->nfree == 0 && c->next) {   /* full chunks after those with room */
        list_unlink(s, c);
        list_push_tail(s, c);
    }
    s->used += slot;
    pthread_mutex_unlock(&s->lock);
    UNPOISON(p, bytes);
    return p;
}

void gv_slab_put(struct gv_slab *s, void *p, size_t bytes)
{
    if (!p)
        return;
    if (bytes == 0)
        bytes = 1;
    const size_t slot = page_round(bytes);
    uint8_t *q = p;
    int cls = -1;
    struct chunk *c = NULL;
    if (in_range(bytes)) {
        pthread_mutex_lock(&s->lock);
        cls = class_of(s, slot, 0);
        for (c = cls < 0 ? NULL : s->head[cls]; c; c = c->next)
            if (q >= c->base && q < c->base + c->bytes)
                break;
        if (!c)
            pthread_mutex_unlock(&s->lock);
    }
    if (!c) {   /* from aligned_alloc: no chunk of the class holds it */
        free(p);
        return;
    }
    POISON(q, slot);
    c->free[c->nfree++] = (uint16_t)((size_t)(q - c->base) / slot);
    s->used -= slot;
    if (c->nfree == c->nslots) {
        list_unlink(s, c);
        if (s->empty)
            unmap_chunk(s, s->empty);
        s->empty = c;
    } else if (c->nfree == 1 && c->prev) {   /* it has room again */
        list_unlink(s, c);
        list_push_head(s, c);
    }
    pthread_mutex_unlock(&s->lock);
}

void gv_slab_stats(struct gv_slab *s, struct gv_slab_stats *out)
{
    pthread_mutex_lock(&s->lock);
    out->mapped = s->mapped;
    out->used = s->used;
    out->chunks = s->chunks;
    out->maps = s->maps;
    pthread_mutex_unlock(&s->lock);
}
