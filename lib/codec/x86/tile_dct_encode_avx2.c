/*
 * tile_dct_encode_avx2.c - layout D's transform and quantization in AVX2
 * with FMA (tile_dct_encode_avx2.h): tile_dct_encode_int.h's transform
 * and quantize-and-count loops instantiated with an 8-lane forward
 * transform (its first pass fused where every product and sum is exact),
 * a residual of eight RGB pixels at once and an 8-lane quantizer, the
 * same floats in the same order as the baseline.
 *
 * Compiled with -mavx2 -mfma (Makefile.am, lib/codec/x86/libgvcodec_avx2.a):
 * nothing here may run before tile_dct_encode.c has checked GV_CPU_AVX2
 * and GV_CPU_FMA.
 */
#include "base/cpu.h"
#include "codec/tile_dct_encode_int.h"
#include "codec/x86/tile_dct_encode_avx2.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* forward() in 8 lanes: the same operations in the same order, but for
 * the first pass's fused multiply-adds.  They give the same floats: the
 * residual is a multiple of 1/4 below 2^9 in magnitude (YCoCg of 8-bit
 * differences), so each product K e and each partial sum (at most 464 x
 * 510 < 2^18, in quarters) is exact in single precision, and a rounding
 * of an exact value changes nothing.  The second pass's sums are not
 * exact, so it keeps a multiply and an add. */
__attribute__((always_inline)) static inline void
forward_avx2(const float *e, float *d)
{
    __m256 t[8];
    for (int j = 0; j < 8; j++) {
        __m256 s = _mm256_setzero_ps();
        for (int i = 0; i < 8; i++)
            s = _mm256_fmadd_ps(_mm256_loadu_ps(gv_dct_enc_kt[i]),
                                _mm256_set1_ps(e[8 * j + i]), s);
        t[j] = s;
    }
    /* The second pass straight into zigzag order: lane p of group g is
     * coefficient zz = gv_dct_zigzag[8 g + p], (v, u) = (zz / 8, zz % 8),
     * the sum over j of K[v][j] t[j][u] in increasing j as before, with
     * t[j][u] brought to the lane by a permute and K[v][j] from a table
     * (no store of the rows and 64 scalar moves after it). */
    const __m256 scale = _mm256_set1_ps(1.0f / 4096.0f);
    for (int g = 0; g < 8; g++) {
        const __m256i ui = _mm256_load_si256((const __m256i *)gv_dct_enc_zz_col[g]);
        __m256 s = _mm256_setzero_ps();
        for (int j = 0; j < 8; j++)
            s = _mm256_add_ps(s, _mm256_mul_ps(_mm256_load_ps(gv_dct_enc_zz_k[g][j]),
                                               _mm256_permutevar8x32_ps(t[j], ui)));
        _mm256_storeu_ps(d + 8 * g, _mm256_mul_ps(s, scale));
    }
}

/* residual_block, an RGB block inside the valid area eight pixels at a
 * time.  The same floats: with r, g, b the differences (integers), the
 * plain code's exact steps give Y = (r + 2g + b) / 4, Co = r - b and
 * Cg = (2g - r - b) / 2, each an integer scaled by a power of two, and
 * neither way makes a negative zero.  Loads exactly the block's 24 bytes
 * of each row (16 + 8), never past the tile. */
__attribute__((always_inline)) static inline void
residual_block_avx2(const uint8_t *orig, const uint8_t *pred, int channels,
                    int bx, int by, uint32_t vw, uint32_t vh, float out[3][64])
{
    if (channels != 3 || (uint32_t)(8 * bx + 8) > vw ||
        (uint32_t)(8 * by + 8) > vh) {
        residual_block(orig, pred, channels, bx, by, vw, vh, out);
        return;
    }
    /* From bytes 0-15 (lo) and 16-23 (hi): each channel's eight samples. */
    const __m128i rlo = _mm_setr_epi8(0, 3, 6, 9, 12, 15, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i rhi = _mm_setr_epi8(-1, -1, -1, -1, -1, -1, 2, 5, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i glo = _mm_setr_epi8(1, 4, 7, 10, 13, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i ghi = _mm_setr_epi8(-1, -1, -1, -1, -1, 0, 3, 6, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i blo = _mm_setr_epi8(2, 5, 8, 11, 14, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m128i bhi = _mm_setr_epi8(-1, -1, -1, -1, -1, 1, 4, 7, -1, -1, -1, -1, -1, -1, -1, -1);
    const __m256 quarter = _mm256_set1_ps(0.25f), half = _mm256_set1_ps(0.5f);
    for (int j = 0; j < 8; j++) {
        const size_t at = ((size_t)(8 * by + j) * GV_TILE + 8 * bx) * 3;
        const __m128i olo = _mm_loadu_si128((const __m128i *)(orig + at));
        const __m128i ohi = _mm_loadl_epi64((const __m128i *)(orig + at + 16));
        const __m128i plo = _mm_loadu_si128((const __m128i *)(pred + at));
        const __m128i phi = _mm_loadl_epi64((const __m128i *)(pred + at + 16));
#define CHANNEL(lo, hi)                                                       \
    _mm256_sub_epi32(                                                         \
        _mm256_cvtepu8_epi32(_mm_or_si128(_mm_shuffle_epi8(olo, lo),          \
                                          _mm_shuffle_epi8(ohi, hi))),        \
        _mm256_cvtepu8_epi32(_mm_or_si128(_mm_shuffle_epi8(plo, lo),          \
                                          _mm_shuffle_epi8(phi, hi))))
        const __m256i r = CHANNEL(rlo, rhi), g = CHANNEL(glo, ghi),
                      b = CHANNEL(blo, bhi);
#undef CHANNEL
        const __m256i rb = _mm256_add_epi32(r, b), g2 = _mm256_add_epi32(g, g);
        _mm256_storeu_ps(out[0] + 8 * j, _mm256_mul_ps(
            _mm256_cvtepi32_ps(_mm256_add_epi32(rb, g2)), quarter));
        _mm256_storeu_ps(out[1] + 8 * j, _mm256_cvtepi32_ps(_mm256_sub_epi32(r, b)));
        _mm256_storeu_ps(out[2] + 8 * j, _mm256_mul_ps(
            _mm256_cvtepi32_ps(_mm256_sub_epi32(g2, rb)), half));
    }
}

/* quantize_block in eight lanes: the same operations in the same order
 * (a multiply and an add, never fused: ISO C mode), so the same q, the
 * same return and the same acc[l], lane l summing k = l, l + 8, ... */
__attribute__((always_inline)) static inline uint64_t
quantize_block_avx2(const float *x, float inv, float s, int16_t *q,
                    float *acc)
{
    const __m256 vinv = _mm256_set1_ps(inv), vs = _mm256_set1_ps(s);
    const __m256 off = _mm256_set1_ps(ROUND_OFFSET), cap = _mm256_set1_ps(2047.5f);
    const __m256 absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const __m256i zero = _mm256_setzero_si256();
    __m256 sum = _mm256_setzero_ps();
    uint64_t nz = 0;
    for (int k = 0; k < 64; k += 16) {
        __m256i sm[2];
        unsigned z = 0;
        for (int h = 0; h < 2; h++) {
            const __m256 v = _mm256_loadu_ps(x + k + 8 * h);
            const __m256 a = _mm256_and_ps(v, absmask);
            __m256 f = _mm256_add_ps(_mm256_mul_ps(a, vinv), off);
            f = _mm256_min_ps(f, cap);
            const __m256i m = _mm256_cvttps_epi32(f);
            const __m256 err =
                _mm256_sub_ps(a, _mm256_mul_ps(_mm256_cvtepi32_ps(m), vs));
            sum = _mm256_add_ps(sum, _mm256_mul_ps(err, err));
            /* m with the sign of x (sign_epi32 reads x's bits as an
             * integer: negative for x < 0, -0 included, where m = 0). */
            sm[h] = _mm256_sign_epi32(m, _mm256_castps_si256(v));
            z |= (unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(
                     _mm256_cmpeq_epi32(m, zero))) << 8 * h;
        }
        /* Sixteen int16: packs works within each 128-bit half, giving
         * the quadwords 0-3, 8-11, 4-7, 12-15, put back in order. */
        _mm256_storeu_si256((__m256i *)(q + k), _mm256_permute4x64_epi64(
            _mm256_packs_epi32(sm[0], sm[1]), 0xd8));
        nz |= (uint64_t)(~z & 0xffff) << k;
    }
    _mm256_storeu_ps(acc, sum);
    return nz;
}

void gv_dct_transform_tile_avx2(struct gv_dct_workspace *ws,
                                const uint8_t *orig, const uint8_t *pred,
                                int channels, uint32_t vw, uint32_t vh)
{
    transform_body(ws, orig, pred, channels, vw, vh, forward_avx2,
                   residual_block_avx2);
}

double gv_dct_quantize_count_avx2(const struct gv_dct_workspace *ws,
                                  struct candidate *cd, int channels,
                                  const int *steps)
{
    return quantize_count_body(ws, cd, channels, steps, quantize_block_avx2);
}
#endif
