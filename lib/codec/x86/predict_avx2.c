/*
 * predict_avx2.c - the prediction's level 1 and the residual addition in
 * AVX2 (predict_avx2.h; predict.c's design comment has the arithmetic):
 * the interior filter is predict_int.h's plain C compiled for AVX2, the
 * even and odd sums interleaved by PSHUFB, the vertical sum on pairs of
 * rows by VPMADDWD, and the clamped addition by saturating bytes.
 *
 * Compiled with -mavx2 -mfma (Makefile.am, lib/codec/x86/libgvcodec_avx2.a):
 * nothing here may run before predict.c has checked GV_CPU_AVX2.
 */
#include "base/cpu.h"
#include "codec/predict_int.h"
#include "codec/x86/predict_avx2.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* interleave3_c with PSHUFB on 128-bit vectors: four pairs (24 samples,
 * 48 bytes) a step from two overlapping loads of each of even[] and
 * odd[] (samples 0-7 and 4-11 of the four pixels), each output vector the
 * OR of two shuffles; the loads read up to the 12 samples they use. */
static void interleave3_ssse3(const uint16_t *even, const uint16_t *odd,
                              int16_t *dst)
{
    /* Output samples, in 16-bit units: vector 0 = e0 e1 e2 o0 o1 o2 e3 e4
     * (of the loads E0, O0), vector 1 = e5 o3 o4 o5 e6 e7 e8 o6 (E1: e4..,
     * O0), vector 2 = o7 o8 e9 e10 e11 o9 o10 o11 (O1: o4.., E1). */
    const __m128i m0e = _mm_setr_epi8(0, 1, 2, 3, 4, 5, -1, -1, -1, -1, -1, -1, 6, 7, 8, 9);
    const __m128i m0o = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, 0, 1, 2, 3, 4, 5, -1, -1, -1, -1);
    const __m128i m1e = _mm_setr_epi8(2, 3, -1, -1, -1, -1, -1, -1, 4, 5, 6, 7, 8, 9, -1, -1);
    const __m128i m1o = _mm_setr_epi8(-1, -1, 6, 7, 8, 9, 10, 11, -1, -1, -1, -1, -1, -1, 12, 13);
    const __m128i m2o = _mm_setr_epi8(6, 7, 8, 9, -1, -1, -1, -1, -1, -1, 10, 11, 12, 13, 14, 15);
    const __m128i m2e = _mm_setr_epi8(-1, -1, -1, -1, 10, 11, 12, 13, 14, 15, -1, -1, -1, -1, -1, -1);
    for (int k = 0; k < 256; k += 4) {
        const uint16_t *e = even + 3 * k, *o = odd + 3 * k;
        const __m128i e0 = _mm_loadu_si128((const __m128i *)e);
        const __m128i e1 = _mm_loadu_si128((const __m128i *)(e + 4));
        const __m128i o0 = _mm_loadu_si128((const __m128i *)o);
        const __m128i o1 = _mm_loadu_si128((const __m128i *)(o + 4));
        int16_t *d = dst + 6 * k;
        _mm_storeu_si128((__m128i *)d, _mm_or_si128(_mm_shuffle_epi8(e0, m0e),
                                                    _mm_shuffle_epi8(o0, m0o)));
        _mm_storeu_si128((__m128i *)(d + 8), _mm_or_si128(_mm_shuffle_epi8(e1, m1e),
                                                          _mm_shuffle_epi8(o0, m1o)));
        _mm_storeu_si128((__m128i *)(d + 16), _mm_or_si128(_mm_shuffle_epi8(o1, m2o),
                                                           _mm_shuffle_epi8(e1, m2e)));
    }
    memcpy(dst + 6 * 256, even + 3 * 256, 3 * sizeof *dst);
}

static void filter_interior_avx2(const uint8_t *restrict src, int C,
                                 uint16_t *restrict even,
                                 uint16_t *restrict odd, int n)
{
    filter_interior(src, C, even, odd, n);
}

void gv_predict_filter_row_avx2(const uint8_t *src, int C, int qx,
                                int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_avx2, interleave3_ssse3);
}

/* A child row is w0 h[t] + w1 h[t+1] + w2 h[t+2] + w3 h[t+3]; the pairs
 * (h[t], h[t+1]) are interleaved once and kept, since each serves four
 * child rows: 16 samples of each row per 32 values, as VPUNPCKLWD /
 * VPUNPCKHWD give them; whole groups of 32 samples, the padding zero. */
void gv_predict_interleave_pair_avx2(const int16_t *a, const int16_t *b,
                                     size_t n, int16_t *dst)
{
    const size_t groups = (n + 31) / 32;
    for (size_t c = 0; c < 2 * groups; c++) {
        const size_t i = 16 * c;
        __m256i x, y;
        if (i + 16 <= n) {
            x = _mm256_loadu_si256((const __m256i *)(a + i));
            y = _mm256_loadu_si256((const __m256i *)(b + i));
        } else {
            int16_t ta[16] = {0}, tb[16] = {0};
            if (i < n) {
                memcpy(ta, a + i, (n - i) * sizeof *ta);
                memcpy(tb, b + i, (n - i) * sizeof *tb);
            }
            x = _mm256_loadu_si256((const __m256i *)ta);
            y = _mm256_loadu_si256((const __m256i *)tb);
        }
        _mm256_store_si256((__m256i *)(dst + 32 * c), _mm256_unpacklo_epi16(x, y));
        _mm256_store_si256((__m256i *)(dst + 32 * c + 16), _mm256_unpackhi_epi16(x, y));
    }
}

/* 16 samples (chunk c) of a child row from its two AVX2 pairs, before
 * the final pack. */
__attribute__((always_inline)) static inline __m256i
vertical_pairs16(const int16_t *p0, const int16_t *p1, size_t c, __m256i w01,
                 __m256i w23, __m256i rnd)
{
    const int16_t *a = p0 + 32 * c, *b = p1 + 32 * c;
    __m256i lo = _mm256_add_epi32(
        _mm256_madd_epi16(_mm256_load_si256((const __m256i *)a), w01),
        _mm256_madd_epi16(_mm256_load_si256((const __m256i *)b), w23));
    __m256i hi = _mm256_add_epi32(
        _mm256_madd_epi16(_mm256_load_si256((const __m256i *)(a + 16)), w01),
        _mm256_madd_epi16(_mm256_load_si256((const __m256i *)(b + 16)), w23));
    lo = _mm256_srai_epi32(_mm256_add_epi32(lo, rnd), 14);
    hi = _mm256_srai_epi32(_mm256_add_epi32(hi, rnd), 14);
    return _mm256_packs_epi32(lo, hi);
}

/* The child row from the pairs, 32 samples at a time. */
void gv_predict_vertical_pairs_avx2(const int16_t *p0, const int16_t *p1,
                                    const int *w, size_t n, uint8_t *out)
{
    const __m256i w01 = _mm256_set1_epi32(weight_pair(w, 0));
    const __m256i w23 = _mm256_set1_epi32(weight_pair(w, 2));
    const __m256i rnd = _mm256_set1_epi32(ROUND);
    for (size_t i = 0, c = 0; i < n; i += 32, c += 2) {
        const __m256i a = vertical_pairs16(p0, p1, c, w01, w23, rnd);
        const __m256i b = vertical_pairs16(p0, p1, c + 1, w01, w23, rnd);
        const __m256i v = _mm256_permute4x64_epi64(_mm256_packus_epi16(a, b), 0xd8);
        if (i + 32 <= n) {
            _mm256_storeu_si256((__m256i *)(out + i), v);
        } else {
            uint8_t tail[32];
            _mm256_storeu_si256((__m256i *)tail, v);
            memcpy(out + i, tail, n - i);
        }
    }
}

/* add_clamped_c with unsigned saturating byte arithmetic: add
 * max(res, 0), then subtract max(-res, 0) (computed as max(res, 0) - res,
 * which is 128 for -128); at most one of the two is non-zero. */
void gv_predict_add_clamped_avx2(uint8_t *row, const int8_t *res, size_t n)
{
    const __m256i zero = _mm256_setzero_si256();
    size_t i = 0;
    for (; i + 32 <= n; i += 32) {
        __m256i r = _mm256_loadu_si256((const __m256i *)(res + i));
        __m256i x = _mm256_loadu_si256((const __m256i *)(row + i));
        __m256i pos = _mm256_max_epi8(r, zero);
        __m256i neg = _mm256_sub_epi8(pos, r);
        x = _mm256_subs_epu8(_mm256_adds_epu8(x, pos), neg);
        _mm256_storeu_si256((__m256i *)(row + i), x);
    }
    if (i < n)
        add_clamped_c(row + i, res + i, n - i);
}

#endif
