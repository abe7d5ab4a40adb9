/*
 * tile_dct_pixels_avx2.h - the AVX2 kernel of gv_dct_add_row
 * (codec/tile_dct_pixels.h), for tile_dct_pixels.c's table only.
 */
#ifndef GV_TILE_DCT_PIXELS_AVX2_H
#define GV_TILE_DCT_PIXELS_AVX2_H

#include <stdint.h>

#include "codec/tile_dct_row.h"

/* gv_dct_add_row, the same bytes; only where gv_cpu_flags() has
 * GV_CPU_AVX2. */
void gv_dct_add_row_avx2(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                         int channels, int by, uint8_t *out);

#endif
