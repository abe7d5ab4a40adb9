/*
 * tile_dct_lanes.h - layout D's rANS streams (docs/FORMAT.md section 4.3)
 * decoded sixteen rows at a time in the lanes of AVX-512 registers, for
 * tile_dct.c's CPU decoder, bit for bit what its scalar decode_row gives.
 * Internal to lib/codec; tile_dct.h is the codec's interface.
 */
#ifndef GV_TILE_DCT_LANES_H
#define GV_TILE_DCT_LANES_H

#include <stdint.h>

#include "codec/tile_dct.h"
#include "codec/tile_dct_pixels.h"
#include "codec/x86/tile_dct_lanes_avx512.h"   /* GV_DCT_LANES */

/* A thread's scratch: the rows of a group, the eobs of its rows as the
 * lanes write them. */
struct gv_dct_lanes_arena {
    gv_dct_row rows[GV_DCT_LANES];
    int16_t eobs[GV_DCT_LANES][3 * GV_DCT_BLOCKS];
};

/*
 * Whether gv_dct_lanes_rows may run: gv_cpu_flags() (base/cpu.h) has
 * AVX-512 (F, BW), VBMI and POPCNT.  GIGAVIEW_SIMD=avx2 or c, or
 * gv_cpu_set_mask, turns the lanes off (tile_dct.c then decodes every row
 * with its scalar code); both give the same bytes.  Thread-safe.
 */
int gv_dct_lanes_usable(void);

/*
 * For tests: how many groups of rows this thread has given
 * gv_dct_lanes_rows (*tried) and how many it refused (*refused).
 */
void gv_dct_lanes_counts(unsigned long *tried, unsigned long *refused);

/*
 * This thread's arena for gv_dct_lanes_rows, all zero (and to be left
 * all zero by its user), made on its first call (396 KiB) and freed when
 * the thread ends; NULL when out of memory.
 */
struct gv_dct_lanes_arena *gv_dct_lanes_arena(void);

/*
 * Decode the n <= 16 streams of a checked layout D or D2 buffer whose
 * words lie at buf + at[i] up to buf + end[i] (end[i] - at[i] >= 4, even)
 * into a->rows[i] and eobs[i], as tile_dct.c's decode_row does: slot is
 * its table of model entries (GV_DCT_MODELS_D2 x 256, see load_models),
 * last 1 for layout D2 (a block's last value in model 30 + cc), steps the
 * channels' quantizer steps.  a must be all zero and are
 * written only at coded coefficients.  Returns 0, or -1 when any stream
 * is damaged, with a all zero again and no message (the caller
 * decodes the rows again by the scalar code for its message).
 */
int gv_dct_lanes_rows(const uint8_t *buf, const uint32_t at[GV_DCT_LANES],
                      const uint32_t end[GV_DCT_LANES], int n, int channels,
                      const uint32_t *slot, int last, const int32_t steps[3],
                      struct gv_dct_lanes_arena *a,
                      uint8_t eobs[][3][GV_DCT_BLOCKS]);

#endif
