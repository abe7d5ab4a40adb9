/*
 * tile_dct_row.h - the data of layout D's pixel side (docs/FORMAT.md
 * section 4.3) that tile_dct_pixels.c shares with its SIMD kernels
 * (x86/tile_dct_pixels_*.c): a row of blocks' coefficients and the
 * zigzag reach tables.  Types and tables only, no function, so that a
 * kernel needs nothing of the file whose table calls it.  Internal to
 * lib/codec.
 */
#ifndef GV_TILE_DCT_ROW_H
#define GV_TILE_DCT_ROW_H

#include <stdint.h>

#include "codec/tile_dct.h"

/* A row of blocks' coefficients: co[c][v][X] is coefficient (v, u) of
 * channel c of block X / 8, u = X mod 8. */
typedef int16_t gv_dct_row[3][8][GV_DCT_PLANE];

/* The rows and columns that the first n coefficients in zigzag order
 * reach: 1 + the largest v, 1 + the largest u (0 for n = 0). */
extern const uint8_t gv_dct_zz_rows[65], gv_dct_zz_cols[65];

#endif
