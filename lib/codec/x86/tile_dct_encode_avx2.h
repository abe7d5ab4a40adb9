/*
 * tile_dct_encode_avx2.h - the AVX2 kernels of layout D's encoder
 * (tile_dct_encode.c), for its table only.
 */
#ifndef GV_TILE_DCT_ENCODE_AVX2_H
#define GV_TILE_DCT_ENCODE_AVX2_H

#include <stdint.h>

struct gv_dct_workspace;
struct candidate;

/* The kernels below give the same floats, in the same order, as
 * tile_dct_encode.c's baseline; only where gv_cpu_flags() has both
 * GV_CPU_AVX2 and GV_CPU_FMA. */

/* The transform of a tile into ws: every block's residual (YCoCg for 3
 * channels) of orig against pred, clamped to the valid area vw x vh, its
 * forward transform in zigzag order, its largest coefficient and its
 * energy. */
void gv_dct_transform_tile_avx2(struct gv_dct_workspace *ws,
                                const uint8_t *orig, const uint8_t *pred,
                                int channels, uint32_t vw, uint32_t vh);

/* Quantize every block of ws at steps[] into cd and count its symbols;
 * returns the estimated weighted squared error (tile_dct_encode_int.h,
 * quantize_count_body). */
double gv_dct_quantize_count_avx2(const struct gv_dct_workspace *ws,
                                  struct candidate *cd, int channels,
                                  const int *steps);

#endif
