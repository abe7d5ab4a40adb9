/*
 * sse_avx2.c - gv_sse_u8 in AVX2 (sse_avx2.h): the differences widened
 * to 16 bits, squared and summed in pairs by VPMADDWD, a row's sums in
 * 32-bit lanes (each adds at most n / 16 pairs of 2 x 255^2, under 2^31
 * for n <= 2^15) and the rows' in 64.
 *
 * Compiled with -mavx2 (Makefile.am, lib/codec/x86/libgvcodec_avx2.a):
 * nothing here may run before sse.c has checked GV_CPU_AVX2.
 */
#include "base/cpu.h"
#include "codec/x86/sse_avx2.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

uint64_t gv_sse_u8_avx2(const uint8_t *a, const uint8_t *b, uint32_t n,
                        uint32_t rows, size_t stride)
{
    uint64_t e = 0;
    for (uint32_t y = 0; y < rows; y++) {
        const uint8_t *ra = a + (size_t)y * stride, *rb = b + (size_t)y * stride;
        __m256i acc = _mm256_setzero_si256();
        uint32_t i = 0;
        for (; i + 16 <= n; i += 16) {
            const __m256i d = _mm256_sub_epi16(
                _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(ra + i))),
                _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(rb + i))));
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(d, d));
        }
        uint32_t lanes[8];
        _mm256_storeu_si256((__m256i *)lanes, acc);
        uint64_t row = 0;
        for (int l = 0; l < 8; l++)
            row += lanes[l];
        for (; i < n; i++) {
            const int d = (int)ra[i] - rb[i];
            row += (uint64_t)(d * d);
        }
        e += row;
    }
    return e;
}
#endif
