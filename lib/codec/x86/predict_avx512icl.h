/*
 * predict_avx512icl.h - the prediction's level 3, AVX-512 with VBMI and
 * VNNI (Ice Lake, Zen 4 and later), for predict.c's table only.
 */
#ifndef GV_PREDICT_AVX512ICL_H
#define GV_PREDICT_AVX512ICL_H

#include <stddef.h>
#include <stdint.h>

/* The kernels below: the same integers as predict.c's portable C, and
 * only where gv_cpu_flags() has GV_CPU_AVX512, GV_CPU_AVX512VBMI and
 * GV_CPU_AVX512VNNI. */

/* gv_predict_filter_row_avx2 (x86/predict_avx2.h) by VPERMB and
 * VPMADDUBSW. */
void gv_predict_filter_row_vbmi(const uint8_t *src, int C, int qx,
                                int16_t *dst);

/* Rows a and b (n samples each) interleaved in 16-bit pairs, 32 samples
 * of each per 64 values, whole groups of 64 samples (the padding zero):
 * what gv_predict_vertical_pairs_vnni reads.  dst 64-byte aligned. */
void gv_predict_interleave_pair_avx512(const int16_t *a, const int16_t *b,
                                       size_t n, int16_t *dst);

/* gv_predict_vertical_pairs_avx2 (x86/predict_avx2.h) on the pairs of
 * gv_predict_interleave_pair_avx512, by VPDPWSSD. */
void gv_predict_vertical_pairs_vnni(const int16_t *p0, const int16_t *p1,
                                    const int *w, size_t n, uint8_t *out);

#endif
