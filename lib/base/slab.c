/*
 * slab.c - large buffers cut from huge-page chunks (see slab.h).
 *
 * Each class keeps a doubly linked list of its chunks, those with a free
 * slot before those without, so a get takes the head's slot or maps a
 * chunk.  A chunk's free slots are a stack of their indices.  A put finds
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
#define MIN_SHIFT 16              /* 64 KiB: smaller buffers go to malloc */
#define MAX_SHIFT 23              /* 8 MiB: larger buffers go to malloc */
#define CLASSES ((MAX_SHIFT - MIN_SHIFT) * 4 + 1)
#define MAX_UNITS 16

struct chunk {
    uint8_t *base;                /* UNIT-aligned, `bytes` long */
    size_t bytes;
    size_t slot;
    int cls;
    int nslots, nfree;
    struct chunk *prev, *next;    /* in its class's list */
    uint16_t free[];              /* free slots' indices, nfree of them */
};

struct gv_slab {
    pthread_mutex_t lock;
    struct chunk *head[CLASSES], *tail[CLASSES];
    struct chunk *empty;          /* one empty chunk kept, on no list */
    uint64_t mapped, used, chunks, maps;
};

/* The class of a size in [64 KiB, 8 MiB] and its slot size. */
static size_t class_of(size_t bytes, int *cls)
{
    int k = 63 - __builtin_clzll((unsigned long long)bytes);
    size_t quarter = ((size_t)1 << k) / 4;
    size_t steps = (bytes + quarter - 1) / quarter;   /* 4 to 8 */
    if (steps == 8) {
        k++;
        steps = 4;
        quarter *= 2;
    }
    *cls = (k - MIN_SHIFT) * 4 + (int)(steps - 4);
    return steps * quarter;
}

static int in_range(size_t bytes)
{
    return bytes >= ((size_t)1 << MIN_SHIFT) && bytes <= ((size_t)1 << MAX_SHIFT);
}

size_t gv_slab_slot_bytes(size_t bytes)
{
    int cls;
    return in_range(bytes) ? class_of(bytes, &cls) : bytes;
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
    c->slot = slot;
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
    size_t max_slots = bytes / ((size_t)1 << MIN_SHIFT);
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
    for (int k = 0; k < CLASSES; k++)
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
    if (!in_range(bytes))
        return aligned_alloc(64, (bytes + 63) & ~(size_t)63);
    int cls;
    size_t slot = class_of(bytes, &cls);
    pthread_mutex_lock(&s->lock);
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
    if (!in_range(bytes)) {
        free(p);
        return;
    }
    int cls;
    size_t slot = class_of(bytes, &cls);
    uint8_t *q = p;
    pthread_mutex_lock(&s->lock);
    struct chunk *c = s->head[cls];
    while (c && !(q >= c->base && q < c->base + c->bytes))
        c = c->next;
    if (!c)
        abort();   /* not a buffer of this class: a programmer's error */
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
