/*
 * tile_rans.h - entropy-coded index streams of a tile buffer (internal to
 * the tile codec; docs/FORMAT.md section 4.1 is the normative layout).
 */
#ifndef GV_TILE_RANS_H
#define GV_TILE_RANS_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* Flag in byte 0 of a tile buffer: indices are rANS-coded (low 4 bits: r). */
#define GV_TILE_ENTROPY 0x80

/* Byte offset of the cumulative-frequency table: after the codebook,
 * rounded up to 4. */
size_t gv_rans_tables_offset(int rate, int channels);

/* Write the entropy-coded buffer for 257^2 indices at `rate` with codebook
 * `book` into buf.  Returns its length, or 0 if it would not fit in cap
 * bytes (then the fixed-width layout is the smaller one).  Thread-safe. */
size_t gv_rans_pack(const uint16_t *idx, int rate, int channels,
                    const int8_t *book, uint8_t *buf, size_t cap);

/* Check the layout of an entropy-coded buffer (tables and stream lengths);
 * the streams themselves are checked while decoding. */
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
    int k, row;               /* 2^r; the next block row */
};

/* Start at block row 0 of a buffer that passed gv_rans_check. */
void gv_rans_rows_begin(struct gv_rans_rows *it, const uint8_t *buf,
                        int rate, int channels);

/* Decode the 257 indices of the next block row into idx, validating its
 * stream as gv_rans_unpack does.  At most 257 calls.  Returns 0 or -1. */
int gv_rans_rows_next(struct gv_rans_rows *it, uint16_t *idx,
                      struct gv_error *err);

#endif
