/*
 * predict_avx512.h - the prediction's horizontal sums in AVX-512 F and BW
 * (level 2), for predict.c's table only.
 */
#ifndef GV_PREDICT_AVX512_H
#define GV_PREDICT_AVX512_H

#include <stdint.h>

/* gv_predict_filter_row_avx2 (x86/predict_avx2.h), the same integers;
 * only where gv_cpu_flags() has GV_CPU_AVX512. */
void gv_predict_filter_row_avx512(const uint8_t *src, int C, int qx,
                                  int16_t *dst);

#endif
