/*
 * predict_avx2.h - the AVX2 kernels of the prediction (level 1) and of
 * the residual addition (codec/predict.h), for predict.c's table only.
 */
#ifndef GV_PREDICT_AVX2_H
#define GV_PREDICT_AVX2_H

#include <stddef.h>
#include <stdint.h>

/* The kernels below: the same integers as predict.c's portable C, and
 * only where gv_cpu_flags() has GV_CPU_AVX2. */

/* One parent row's horizontal sums (minus OFFSET) in child order:
 * dst[u * C + c], u = 0 .. 512, of quadrant qx of the tile row src. */
void gv_predict_filter_row_avx2(const uint8_t *src, int C, int qx,
                                int16_t *dst);

/* Rows a and b (n samples each) interleaved in 16-bit pairs, 16 samples
 * of each per 32 values, whole groups of 32 samples (the padding zero):
 * what gv_predict_vertical_pairs_avx2 reads.  dst 32-byte aligned. */
void gv_predict_interleave_pair_avx2(const int16_t *a, const int16_t *b,
                                     size_t n, int16_t *dst);

/* The child row of n samples, w[0] h[t] + ... + w[3] h[t+3] rounded and
 * clamped, from the pairs p0 (rows t, t+1) and p1 (t+2, t+3). */
void gv_predict_vertical_pairs_avx2(const int16_t *p0, const int16_t *p1,
                                    const int *w, size_t n, uint8_t *out);

/* row[i] = clamp(row[i] + res[i], 0, 255), i < n. */
void gv_predict_add_clamped_avx2(uint8_t *row, const int8_t *res, size_t n);

#endif
