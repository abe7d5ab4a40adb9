/*
 * slab.h - large buffers of a few sizes, cut from mappings that the
 * system may back with huge pages.
 *
 * The decoded-tile cache takes and gives back a tile's pixels (256 KiB
 * to a few MiB, nearly all of one size per image) for every decode.
 * From malloc each was a fresh mapping (the server's mmap threshold,
 * server/main.c), whose first writes took a page fault for every 4 KiB:
 * a fifth of gigaviewd's CPU in a cold IIIF pass (bench/README.md,
 * 2026-12-03).  A slab maps chunks of whole 2 MiB units, asks for
 * transparent huge pages on them (madvise MADV_HUGEPAGE; where the
 * system refuses, it still works with small pages) and cuts each chunk
 * into slots of one size class.  A slot given back is taken again by the
 * next buffer of its class without a fault; a chunk whose slots are all
 * back is unmapped, but for one empty chunk kept for the next chunk of
 * its size, so memory returns to the system as the cache shrinks.
 *
 * Size classes: a buffer of 64 KiB to 16 MiB takes a slot of its size
 * rounded up to 4 KiB, in the class of slots of that size; a slab has room
 * for 32 classes (a tile cache uses one a channel count: every tile of a
 * store takes the same bytes).  A chunk is the fewest 2 MiB units whose
 * unused tail is at most an eighth of them.  Smaller and larger buffers,
 * and sizes past the 32nd, go to malloc.
 *
 * In an AddressSanitizer build a slot that was given back is poisoned
 * until it is taken again.  Every function is thread-safe (one mutex).
 */
#ifndef GV_SLAB_H
#define GV_SLAB_H

#include <stddef.h>
#include <stdint.h>

struct gv_slab;

struct gv_slab_stats {
    uint64_t mapped;     /* bytes of chunks mapped now, the empty one kept included */
    uint64_t used;       /* bytes of slots taken now (whole slots) */
    uint64_t chunks;     /* chunks mapped now */
    uint64_t maps;       /* chunks ever mapped */
};

/* A slab with nothing mapped.  NULL on allocation failure. */
struct gv_slab *gv_slab_new(void);

/* Unmap every chunk.  Every buffer must have been given back.  NULL does
 * nothing. */
void gv_slab_free(struct gv_slab *s);

/* A buffer of `bytes` bytes (0 is taken as 1), aligned to 64 bytes at
 * least; its contents are undefined.  NULL when out of memory. */
void *gv_slab_get(struct gv_slab *s, size_t bytes);

/* Give back p, which gv_slab_get returned for the same `bytes`.  NULL
 * does nothing. */
void gv_slab_put(struct gv_slab *s, void *p, size_t bytes);

/* The slab's figures now. */
void gv_slab_stats(struct gv_slab *s, struct gv_slab_stats *out);

/* The bytes a buffer of `bytes` takes: its slot's size, or `bytes`
 * itself for a size the slab leaves to malloc. */
size_t gv_slab_slot_bytes(size_t bytes);

#endif
