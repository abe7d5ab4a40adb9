/*
 * tile_dct_pixels.h - the pixel side of layout D's CPU decoder (docs/
 * FORMAT.md section 4.3), used by tile_dct.c: a row of 8x8 blocks'
 * dequantized coefficients turned into residuals (the inverse transform
 * and YCoCg-R) and added to the predicted pixel rows.  Internal to
 * lib/codec; tile_dct.h is the codec's interface.
 */
#ifndef GV_TILE_DCT_PIXELS_H
#define GV_TILE_DCT_PIXELS_H

#include <stdint.h>

#include "codec/tile_dct_row.h"

/*
 * Add the residual of block row `by` (0..64) to its predicted pixel rows
 * in out (the 513 x 513 x channels tile): for each block with coded
 * coefficients (eobs[c][bx] of them for channel c, in zigzag order; the
 * rest zero in co), the inverse transform of each channel, YCoCg-R when
 * channels is 3, and the clamped sum.  The coefficients used are set back
 * to zero, so that co is all zero again afterwards.
 */
void gv_dct_add_row(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                    int channels, int by, uint8_t *out);

#endif
