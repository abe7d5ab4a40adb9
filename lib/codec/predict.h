/*
 * predict.h - the prediction of docs/FORMAT.md section 3 row by row, and
 * the residual addition of section 4, for decoders that reconstruct a tile
 * one pixel row at a time so that the row stays in the CPU's L1 cache.
 *
 * gv_predict (tile.h) is this predictor run over all 513 rows.  The rows
 * are bit for bit those of the double sum of FORMAT.md section 3; where the
 * CPU has AVX2 or AVX-512BW the hot loops use them (chosen at run time),
 * with a portable C path that gives the same bytes (tests/test_predict.c
 * compares every path with a direct implementation of the formulas).
 */
#ifndef GV_PREDICT_H
#define GV_PREDICT_H

#include <stddef.h>
#include <stdint.h>

#include "codec/tile_layout.h"

#define GV_PREDICT_RING 8   /* filtered parent rows kept (a child row needs 4) */
#define GV_PREDICT_PAIR_ROW (50 * 64)   /* two rows' sums interleaved, padded */

/* The state of one tile's prediction: which parent quadrant it reads, and
 * the horizontal sums of the parent rows in use (a ring of rows, tagged
 * with their row number); on the widest SIMD path also pairs of
 * successive rows' sums interleaved for the vertical multiply-adds (a
 * ring tagged with the pair's first tap).  About 76 KiB; put it on the
 * stack. */
struct gv_predictor {
    const uint8_t *parent;
    int channels, qx, qy;
    int tag[GV_PREDICT_RING];
    int pair_tag[GV_PREDICT_RING];
    int16_t ring[GV_PREDICT_RING][GV_TILE * 3];
    _Alignas(64) int16_t pair[GV_PREDICT_RING][GV_PREDICT_PAIR_ROW];
};

/* Start predicting from quadrant (qx,qy) in {0,1}^2 of the decoded
 * 513x513xC parent (borrowed until the last row). */
void gv_predictor_init(struct gv_predictor *p, const uint8_t *parent,
                       int channels, int qx, int qy);

/* Write predicted row v (0..512) of the tile: 513*C bytes.  Rows may come
 * in any order; in increasing order each parent row is filtered once. */
void gv_predictor_row(struct gv_predictor *p, int v, uint8_t *row);

/* Add the residual of one pixel row to a predicted row, FORMAT.md section
 * 4: row[x*C + c] = clamp(row[x*C + c] + book[ids[x/2]][(x%2) + 2*half][c])
 * for the 513 pixels x of the row, where book holds 4*C signed bytes per
 * codevector, ids the 257 indices of the block row (each < the number of
 * codevectors) and half (0 or 1) says which pixel row of the blocks this
 * is. */
void gv_add_residual_row(uint8_t *row, const int8_t *book,
                         const uint16_t *ids, int channels, int half);

#endif
