/*
 * tile_rans.h - entropy-coded index streams of a tile buffer (internal to
 * the tile codec; docs/FORMAT.md sections 4.1 and 4.2 are the normative
 * layouts).
 *
 * Two layouts code the 257x257 indices as 257 rANS streams, one per block
 * row, so that a GPU decodes a tile with one thread per row:
 *   E  (byte 0 = 0x80 | r): one static model over the 2^r indices;
 *   EX (byte 0 = 0xC0 | r, format version 2): an explicit count N of
 *      codevectors, sorted by use, and up to 8 small models of 8 symbols
 *      (indices 0..6 and an escape to a model over all N), the model of a
 *      block chosen by the classes of the two blocks before it in its row.
 */
#ifndef GV_TILE_RANS_H
#define GV_TILE_RANS_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* Flags in byte 0 of a tile buffer (low 4 bits: r). */
#define GV_TILE_ENTROPY 0x80   /* indices are rANS-coded */
#define GV_TILE_CONTEXT 0x40   /* ... with context models (only with 0x80) */

#define GV_RANS_SYMBOLS 8      /* symbols of a context model: 0..6, escape */
#define GV_RANS_ESCAPE 7       /* the escape symbol */
#define GV_RANS_CONTEXTS 8     /* most context models in a buffer */
#define GV_RANS_BUCKET_SHIFT 5 /* slots per search bucket: 32 */
#define GV_RANS_BUCKETS (32768 >> GV_RANS_BUCKET_SHIFT)
#define GV_RANS_MIN_ENTRIES 8  /* fewest codevectors of an EX buffer */

/* Byte offset of the codebook in a buffer whose byte 0 is b0: 4 for EX,
 * else 1. */
static inline size_t gv_tilebuf_book_offset(uint8_t b0)
{
    return (b0 & GV_TILE_CONTEXT) ? 4 : 1;
}

/* One rANS encoding step (a symbol of frequency f at cumulative c, in
 * prob_bits precision, 32-bit state, 16-bit words); may emit one word into
 * words[*n].  Shared by the index streams (15 bits) and layout D's
 * coefficients (8 bits).  gv_rans_renorm is its first half: the state
 * brought under the bound for f, computed in 64 bits (for a certain
 * symbol, f = 2^prob_bits, it is 2^32 and the state passes unchanged). */
static inline uint32_t gv_rans_renorm(uint32_t x, uint32_t f, int prob_bits,
                                      uint16_t *words, int *n)
{
    const uint64_t x_max = (uint64_t)(((1u << 16) >> prob_bits) << 16) * f;
    if (x >= x_max) {
        words[(*n)++] = (uint16_t)x;
        x >>= 16;
    }
    return x;
}

static inline uint32_t gv_rans_put(uint32_t x, uint32_t f, uint32_t c,
                                   int prob_bits, uint16_t *words, int *n)
{
    x = gv_rans_renorm(x, f, prob_bits, words, n);
    return ((x / f) << prob_bits) + (x % f) + c;
}

/* The reciprocal of a frequency f >= 1 for gv_rans_put_rcp:
 * floor((2^64 - 1) / f) + 1 for f >= 2 (it lies in [2^64 / f, 2^64 / f + 1),
 * so x * rcp / 2^64 exceeds x / f by less than x / 2^64 < 2^-32, too little
 * to carry floor(x / f) past an integer when f < 2^32), 0 for f = 1. */
static inline uint64_t gv_rans_rcp(uint32_t f)
{
    return f > 1 ? UINT64_MAX / f + 1 : 0;
}

/* gv_rans_put, the same state for every input, with the division by f
 * taken as a multiplication by rcp = gv_rans_rcp(f), computed once per
 * frequency: a 32-bit division costs several times a 64-bit multiply, and
 * it was a quarter of the samples in gv_dct_encode itself (perf;
 * bench/README.md, "2026-11-26, encoding"). */
static inline uint32_t gv_rans_put_rcp(uint32_t x, uint32_t f, uint64_t rcp,
                                       uint32_t c, int prob_bits,
                                       uint16_t *words, int *n)
{
    x = gv_rans_renorm(x, f, prob_bits, words, n);
#ifdef __SIZEOF_INT128__
    const uint32_t q = f > 1 ? (uint32_t)(((unsigned __int128)x * rcp) >> 64) : x;
#else
    (void)rcp;
    const uint32_t q = x / f;
#endif
    return (q << prob_bits) + (x - q * f) + c;
}

/* Store a finished stream (state x, n words in encoding order) at byte
 * `at` of buf, its length in 16-bit words in slot `row` of the u16 table at
 * `lengths`.  Returns the offset after it, or 0 if it would pass cap or
 * its length would not fit in 16 bits. */
size_t gv_rans_put_stream(uint8_t *buf, size_t lengths, int row, size_t at,
                          uint32_t x, const uint16_t *words, int n, size_t cap);

/* Zero padding from `at` to a multiple of 4; the total length, or 0 past
 * cap. */
size_t gv_rans_finish(uint8_t *buf, size_t at, size_t cap);

/* Byte offset of the cumulative-frequency table of the E layout: after
 * the codebook, rounded up to 4. */
size_t gv_rans_tables_offset(int rate, int channels);

/* Byte offset of the model over all codevectors (cum[], the escape model
 * of EX) of an entropy-coded buffer of either layout that passed
 * gv_rans_check. */
size_t gv_rans_tables_at(const uint8_t *buf, int channels);

/* Write the E buffer for 257^2 indices at `rate` with codebook `book`
 * into buf.  Returns its length, or 0 if it would not fit in cap bytes.
 * Thread-safe. */
size_t gv_rans_pack(const uint16_t *idx, int rate, int channels,
                    const int8_t *book, uint8_t *buf, size_t cap);

/* Write the EX buffer for the same (the codebook reordered by use, unused
 * codevectors past the first GV_RANS_MIN_ENTRIES dropped, the context map
 * that the indices' statistics favour).  Returns its length, or 0 if rate
 * is below 3 or it would not fit in cap bytes.  Thread-safe. */
size_t gv_rans_pack_ctx(const uint16_t *idx, int rate, int channels,
                        const int8_t *book, uint8_t *buf, size_t cap);

/* Check the layout of an entropy-coded buffer of either kind (tables and
 * stream lengths); the streams themselves are checked while decoding. */
int gv_rans_check(const uint8_t *buf, size_t len, int rate, int channels,
                  struct gv_error *err);

/* Decode every index, validating each stream (no read past its end, clean
 * final state).  Returns 0 or -1. */
int gv_rans_unpack(const uint8_t *buf, size_t len, int rate, int channels,
                   uint16_t *idx, struct gv_error *err);

/* The streams one block row at a time, in order, for a decoder that needs
 * no index array (gv_tile_decode).  Fields are private. */
struct gv_rans_rows {
    const uint8_t *buf;
    size_t tables, lengths;   /* offsets of cum[] and n[] */
    size_t at;                /* offset of the next stream */
    int k, row;               /* symbols of cum[]; the next block row */
    int context;              /* EX layout: the fields below are used */
    uint8_t map[16];          /* context of class pair 4a + b */
    uint32_t cum[GV_RANS_CONTEXTS][GV_RANS_SYMBOLS + 1];
    /* first[j]: the last symbol of the k-symbol model at `tables` whose
     * cumulative frequency is <= j << GV_RANS_BUCKET_SHIFT, where the
     * search for a slot in bucket j starts (a few steps, not a binary
     * search over k). */
    uint16_t first[GV_RANS_BUCKETS];
};

/* Start at block row 0 of a buffer that passed gv_rans_check. */
void gv_rans_rows_begin(struct gv_rans_rows *it, const uint8_t *buf,
                        int rate, int channels);

/* Decode the 257 indices of the next block row into idx, validating its
 * stream as gv_rans_unpack does.  At most 257 calls.  Returns 0 or -1. */
int gv_rans_rows_next(struct gv_rans_rows *it, uint16_t *idx,
                      struct gv_error *err);

#endif
