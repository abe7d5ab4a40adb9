/*
 * lambda_split_ssse3.c - the lambda model's split of RGB rows into even
 * and odd pixels by PSHUFB (lambda_split_ssse3.h).
 *
 * Compiled with -mssse3 (Makefile.am, lib/encode/x86/libgvencode_ssse3.a):
 * nothing here may run before lambda_model.c has checked GV_CPU_SSSE3.
 */
#include "base/cpu.h"
#include "encode/x86/lambda_split_ssse3.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* Blocks [0, 4 * (bw / 4)) of an RGB row by PSHUFB, four blocks (24
 * bytes, read as 16 at 0 and 16 at 8) into 12 even and 12 odd bytes,
 * stored as 16 (the buffers have 4 bytes to spare); returns the blocks
 * done. */
uint32_t gv_lambda_split_rgb_ssse3(const uint8_t *row, uint32_t bw,
                                   uint8_t *even, uint8_t *odd)
{
    const __m128i elo = _mm_setr_epi8(0, 1, 2, 6, 7, 8, 12, 13, 14, -1, -1, -1, -1, -1, -1, -1);
    const __m128i ehi = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, 10, 11, 12, -1, -1, -1, -1);
    const __m128i olo = _mm_setr_epi8(3, 4, 5, 9, 10, 11, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i ohi = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, -1, 8, 9, 13, 14, 15, -1, -1, -1, -1);
    uint32_t bx = 0;
    for (; bx + 4 <= bw; bx += 4) {
        const __m128i lo = _mm_loadu_si128((const __m128i *)(row + 6 * bx));
        const __m128i hi = _mm_loadu_si128((const __m128i *)(row + 6 * bx + 8));
        _mm_storeu_si128((__m128i *)(even + 3 * bx),
                         _mm_or_si128(_mm_shuffle_epi8(lo, elo), _mm_shuffle_epi8(hi, ehi)));
        _mm_storeu_si128((__m128i *)(odd + 3 * bx),
                         _mm_or_si128(_mm_shuffle_epi8(lo, olo), _mm_shuffle_epi8(hi, ohi)));
    }
    return bx;
}
#endif
