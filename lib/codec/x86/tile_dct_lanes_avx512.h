/*
 * tile_dct_lanes_avx512.h - the AVX-512 VBMI kernel of gv_dct_lanes_rows
 * (codec/tile_dct_lanes.h), for tile_dct_lanes.c only.
 */
#ifndef GV_TILE_DCT_LANES_AVX512_H
#define GV_TILE_DCT_LANES_AVX512_H

#include <stdint.h>

/* Rows decoded at once: the kernel's sixteen 32-bit lanes.  Defined
 * here, not in tile_dct_lanes.h, so that the kernel needs nothing of the
 * file that calls it. */
#define GV_DCT_LANES 16

/* Decode n <= GV_DCT_LANES rows, stream i from buf[at[i]] to end[i], into
 * the arena's rows and eobs (base16: its first int16), last 1 for layout
 * D2's last-value models (gv_dct_lanes_rows); 0, or -1 when some
 * row is damaged (the arena is then partly written).  Only where
 * gv_dct_lanes_usable(). */
int gv_dct_lanes_run_avx512(const uint8_t *buf,
                            const uint32_t at[GV_DCT_LANES],
                            const uint32_t end[GV_DCT_LANES], int n,
                            int channels, const uint32_t *slot, int last,
                            const int32_t steps[3], int16_t *base16);

#endif
