/*
 * predict_avx512.c - the prediction's horizontal sums at level 2
 * (predict_avx512.h): predict_int.h's interior filter compiled for
 * AVX-512, and the even and odd sums interleaved by two-source word
 * permutes.
 *
 * Compiled with -mavx512f -mavx512bw (Makefile.am,
 * lib/codec/x86/libgvcodec_avx512.a): nothing here may run before
 * predict.c has checked GV_CPU_AVX512.
 */
#include "base/cpu.h"
#include "codec/predict_int.h"
#include "codec/x86/predict_avx512.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* Interleave three-sample pixels: dst = even pixel 0, odd pixel 0, even
 * pixel 1, ... for 256 pairs, then even pixel 256.  Eight pairs (48
 * samples) per step, as two-source word permutes; the loads read up to 8
 * samples past the 24 they use (the arrays have room). */
static void
interleave3_avx512(const uint16_t *even, const uint16_t *odd, int16_t *dst)
{
    /* Output sample j of the 48: pair j/6, its r = j%6: r < 3 from even
     * lane 3*(j/6) + r, else odd (index | 32) lane 3*(j/6) + r - 3. */
    static const uint16_t lanes[48] = {
        0, 1, 2, 32, 33, 34, 3, 4, 5, 35, 36, 37, 6, 7, 8, 38, 39, 40,
        9, 10, 11, 41, 42, 43, 12, 13, 14, 44, 45, 46, 15, 16, 17, 47,
        48, 49, 18, 19, 20, 50, 51, 52, 21, 22, 23, 53, 54, 55};
    const __m512i idx0 = _mm512_loadu_si512((const void *)lanes);
    const __m512i idx1 = _mm512_castsi256_si512(
        _mm256_loadu_si256((const __m256i *)(lanes + 32)));
    for (int k = 0; k < 256; k += 8) {
        const __m512i a = _mm512_loadu_si512((const void *)(even + 3 * k));
        const __m512i b = _mm512_loadu_si512((const void *)(odd + 3 * k));
        _mm512_storeu_si512((void *)(dst + 6 * k), _mm512_permutex2var_epi16(a, idx0, b));
        _mm256_storeu_si256((__m256i *)(dst + 6 * k + 32),
                            _mm512_castsi512_si256(_mm512_permutex2var_epi16(a, idx1, b)));
    }
    memcpy(dst + 6 * 256, even + 3 * 256, 3 * sizeof *dst);
}

static void filter_interior_avx512(const uint8_t *restrict src, int C,
                                   uint16_t *restrict even,
                                   uint16_t *restrict odd, int n)
{
    filter_interior(src, C, even, odd, n);
}

void gv_predict_filter_row_avx512(const uint8_t *src, int C, int qx,
                                  int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_avx512, interleave3_avx512);
}
#endif
