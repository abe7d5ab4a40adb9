/*
 * tile_dct_pixels_avx2.c - gv_dct_add_row in AVX2
 * (tile_dct_pixels_avx2.h): the first pass of the inverse transform by
 * VPMADDWD, two coefficients of a row per 32-bit lane against two matrix
 * rows, eight outputs at once; the second pass the same way on the first
 * pass's results, packed to 16 bits in pairs of rows.  Blocks with four
 * coded rows or more take even-odd butterflies instead (half the
 * multiplies).  Those results fit in 16 bits for every block an encoder
 * writes but not for every block a buffer can hold (steps of 4095), so a
 * block whose first pass leaves the 16-bit range is left to the portable
 * block (tile_dct_pixels_int.h), as are the tile's last row and column of
 * blocks.  The same integers as the portable path (tile_dct_pixels.c).
 *
 * Compiled with -mavx2 (Makefile.am, lib/codec/x86/libgvcodec_avx2.a):
 * nothing here may run before tile_dct_pixels.c has checked GV_CPU_AVX2.
 */
#include "base/cpu.h"
#include "codec/tile_dct_pixels_int.h"
#include "codec/x86/tile_dct_pixels_avx2.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* Blocks with at least this many coded rows go through the butterfly. */
#define BUTTERFLY_ROWS 4

/* Two 16-bit numbers in one 32-bit lane, a in the low half. */
static inline uint32_t pair16(int32_t a, int32_t b)
{
    return (uint32_t)(uint16_t)a | (uint32_t)(uint16_t)b << 16;
}

/* The matrix as VPMADDWD operands: k1[p] lane i = (K[2p][i], K[2p+1][i]);
 * k2[q][j] = (K[2q][j], K[2q+1][j]). */
struct avx2_matrix {
    __m256i k1[4];
    uint32_t k2[4][8];
    /* The butterfly's (inverse_butterfly): b1[p] lane i (0..3, both
     * halves) = (K[r][i], K[s][i]) for the pairs (r, s) = (0, 4), (2, 6),
     * (1, 3), (5, 7); b2[j][p] the same pairs at column j, broadcast. */
    __m256i b1[4];
    uint32_t b2[4][4];
};

/* The coefficient pairs of the butterfly, in the order of b1 and b2. */
static const int butterfly_pair[4][2] = {{0, 4}, {2, 6}, {1, 3}, {5, 7}};

static void avx2_matrix_init(struct avx2_matrix *m)
{
    for (int p = 0; p < 4; p++) {
        uint32_t lane[8];
        for (int i = 0; i < 8; i++) {
            lane[i] = pair16(gv_dct_matrix[2 * p][i], gv_dct_matrix[2 * p + 1][i]);
            m->k2[p][i] = lane[i];
        }
        m->k1[p] = _mm256_loadu_si256((const __m256i *)lane);
    }
    for (int p = 0; p < 4; p++) {
        const int r = butterfly_pair[p][0], s = butterfly_pair[p][1];
        uint32_t lane[8];
        for (int i = 0; i < 8; i++)
            lane[i] = pair16(gv_dct_matrix[r][i & 3], gv_dct_matrix[s][i & 3]);
        m->b1[p] = _mm256_loadu_si256((const __m256i *)lane);
        for (int j = 0; j < 4; j++)
            m->b2[j][p] = pair16(gv_dct_matrix[r][j], gv_dct_matrix[s][j]);
    }
}

/*
 * inverse_avx2 by even-odd butterflies, for blocks with many rows: the
 * even rows of K are symmetric (K[u][7-i] = K[u][i]) and the odd ones
 * antisymmetric, so with E = the sum over even u and O over odd u,
 * output i and 7 - i are E + O and E - O.  The same exact integers, half
 * the multiplies.  Pass 1 takes two coefficient rows a, b per register
 * (rows (0, 4), (2, 6), (1, 3), (5, 7)), lanes i = 0..3 of each: TE holds
 * t[a][0..3] | t[b][0..3] and TO t[a][7..4] | t[b][7..4].  Pass 2 pairs
 * the rows' t as 16-bit values, lanes [i = 0..3 | 7..4], and gives
 * output rows j and 7 - j the same way; a last permute puts the lanes
 * in order.  Returns 0 where t leaves the 16-bit range (as inverse_avx2).
 */
static int inverse_butterfly(const struct avx2_matrix *m,
                                  const int16_t *d, __m256i out[8])
{
    const __m256i order = _mm256_setr_epi8(
        0, 1, 8, 9, 4, 5, 12, 13, 2, 3, 6, 7, 10, 11, 14, 15,
        0, 1, 8, 9, 4, 5, 12, 13, 2, 3, 6, 7, 10, 11, 14, 15);
    const __m256i r64 = _mm256_set1_epi32(64);
    __m256i P[4], lo = _mm256_setzero_si256(), hi = lo;
    for (int p = 0; p < 4; p++) {
        const int a = butterfly_pair[p][0], b = butterfly_pair[p][1];
        const __m256i x = _mm256_shuffle_epi8(_mm256_inserti128_si256(
            _mm256_castsi128_si256(_mm_loadu_si128(
                (const __m128i *)(d + (size_t)a * GV_DCT_PLANE))),
            _mm_loadu_si128((const __m128i *)(d + (size_t)b * GV_DCT_PLANE)), 1),
            order);
        /* x's dwords per half: (D0,D4), (D2,D6), (D1,D3), (D5,D7). */
        const __m256i e = _mm256_add_epi32(_mm256_add_epi32(
            _mm256_madd_epi16(_mm256_shuffle_epi32(x, 0x00), m->b1[0]),
            _mm256_madd_epi16(_mm256_shuffle_epi32(x, 0x55), m->b1[1])), r64);
        const __m256i o = _mm256_add_epi32(
            _mm256_madd_epi16(_mm256_shuffle_epi32(x, 0xaa), m->b1[2]),
            _mm256_madd_epi16(_mm256_shuffle_epi32(x, 0xff), m->b1[3]));
        const __m256i te = _mm256_srai_epi32(_mm256_add_epi32(e, o), 7);
        const __m256i to = _mm256_srai_epi32(_mm256_sub_epi32(e, o), 7);
        lo = _mm256_min_epi32(lo, _mm256_min_epi32(te, to));
        hi = _mm256_max_epi32(hi, _mm256_max_epi32(te, to));
        const __m256i ta = _mm256_permute2x128_si256(te, to, 0x20);
        const __m256i tb = _mm256_permute2x128_si256(te, to, 0x31);
        P[p] = _mm256_blend_epi16(ta, _mm256_slli_epi32(tb, 16), 0xaa);
    }
    const __m256i out16 = _mm256_or_si256(
        _mm256_cmpgt_epi32(_mm256_set1_epi32(-32768), lo),
        _mm256_cmpgt_epi32(hi, _mm256_set1_epi32(32767)));
    if (!_mm256_testz_si256(out16, out16))
        return 0;
    const __m256i r1024 = _mm256_set1_epi32(1024);
    const __m256i natural = _mm256_setr_epi32(0, 1, 2, 3, 7, 6, 5, 4);
    for (int j = 0; j < 4; j++) {
        const __m256i e = _mm256_add_epi32(_mm256_add_epi32(
            _mm256_madd_epi16(P[0], _mm256_set1_epi32((int32_t)m->b2[j][0])),
            _mm256_madd_epi16(P[1], _mm256_set1_epi32((int32_t)m->b2[j][1]))), r1024);
        const __m256i o = _mm256_add_epi32(
            _mm256_madd_epi16(P[2], _mm256_set1_epi32((int32_t)m->b2[j][2])),
            _mm256_madd_epi16(P[3], _mm256_set1_epi32((int32_t)m->b2[j][3])));
        out[j] = _mm256_permutevar8x32_epi32(
            _mm256_srai_epi32(_mm256_add_epi32(e, o), 11), natural);
        out[7 - j] = _mm256_permutevar8x32_epi32(
            _mm256_srai_epi32(_mm256_sub_epi32(e, o), 11), natural);
    }
    return 1;
}

/* The inverse transform of one channel's block (n >= 1 coded
 * coefficients at d, stride GV_DCT_PLANE) into out[j] = row j's eight
 * residuals.  Returns 0 (and leaves the block to the portable path) when
 * the first pass leaves the 16-bit range. */
static int inverse_avx2(const struct avx2_matrix *m, const int16_t *d,
                             int n, __m256i out[8])
{
    const int rows = gv_dct_zz_rows[n], cols = gv_dct_zz_cols[n];
    if (n == 1) {
        const int32_t t = asr(64 * d[0] + 64, 7), v = asr(64 * t + 1024, 11);
        for (int j = 0; j < 8; j++)
            out[j] = _mm256_set1_epi32(v);
        return 1;
    }
    if (rows >= BUTTERFLY_ROWS)
        return inverse_butterfly(m, d, out);
    const int pairs_u = (cols + 1) / 2, pairs_v = (rows + 1) / 2;
    __m256i t[8], lo = _mm256_setzero_si256(), hi = lo;
    for (int v = 0; v < rows; v++) {
        const int16_t *dv = d + (size_t)v * GV_DCT_PLANE;
        __m256i acc = _mm256_set1_epi32(64);
        for (int p = 0; p < pairs_u; p++) {
            uint32_t two;
            memcpy(&two, dv + 2 * p, sizeof two);
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(
                _mm256_set1_epi32((int32_t)two), m->k1[p]));
        }
        t[v] = _mm256_srai_epi32(acc, 7);
        lo = _mm256_min_epi32(lo, t[v]);
        hi = _mm256_max_epi32(hi, t[v]);
    }
    const __m256i out16 = _mm256_or_si256(
        _mm256_cmpgt_epi32(_mm256_set1_epi32(-32768), lo),
        _mm256_cmpgt_epi32(hi, _mm256_set1_epi32(32767)));
    if (!_mm256_testz_si256(out16, out16))
        return 0;
    if (rows & 1)
        t[rows] = _mm256_setzero_si256();
    __m256i tp[4];
    const __m256i low16 = _mm256_set1_epi32(0xffff);
    for (int q = 0; q < pairs_v; q++)
        tp[q] = _mm256_or_si256(_mm256_and_si256(t[2 * q], low16),
                                _mm256_slli_epi32(t[2 * q + 1], 16));
    for (int j = 0; j < 8; j++) {
        __m256i acc = _mm256_set1_epi32(1024);
        for (int q = 0; q < pairs_v; q++)
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(
                tp[q], _mm256_set1_epi32((int32_t)m->k2[q][j])));
        out[j] = _mm256_srai_epi32(acc, 11);
    }
    return 1;
}

/* Eight 32-bit lanes saturated to 16 bits. */
static inline __m128i pack16(__m256i v)
{
    return _mm_packs_epi32(_mm256_castsi256_si128(v),
                           _mm256_extracti128_si256(v, 1));
}

/* px[k] = clamp(px[k] + r[k]) for 8 bytes, r saturated to 16 bits. */
static inline void add8(uint8_t *px, __m128i r)
{
    const __m128i p = _mm_cvtepu8_epi16(_mm_loadl_epi64((const __m128i *)px));
    const __m128i s = _mm_adds_epi16(p, r);
    _mm_storel_epi64((__m128i *)px, _mm_packus_epi16(s, s));
}

/* PSHUFB masks that interleave three rows of eight 16-bit values (R, G,
 * B) into 24: rgb_interleave[k][c] moves channel c's values into output
 * values 8k .. 8k+7 (value o is channel o mod 3 of pixel o / 3), zeros
 * elsewhere (-1). */
static const int8_t rgb_interleave[3][3][16] = {
    {{0, 1, -1, -1, -1, -1, 2, 3, -1, -1, -1, -1, 4, 5, -1, -1},
     {-1, -1, 0, 1, -1, -1, -1, -1, 2, 3, -1, -1, -1, -1, 4, 5},
     {-1, -1, -1, -1, 0, 1, -1, -1, -1, -1, 2, 3, -1, -1, -1, -1}},
    {{-1, -1, 6, 7, -1, -1, -1, -1, 8, 9, -1, -1, -1, -1, 10, 11},
     {-1, -1, -1, -1, 6, 7, -1, -1, -1, -1, 8, 9, -1, -1, -1, -1},
     {4, 5, -1, -1, -1, -1, 6, 7, -1, -1, -1, -1, 8, 9, -1, -1}},
    {{-1, -1, -1, -1, 12, 13, -1, -1, -1, -1, 14, 15, -1, -1, -1, -1},
     {10, 11, -1, -1, -1, -1, 12, 13, -1, -1, -1, -1, 14, 15, -1, -1},
     {-1, -1, 10, 11, -1, -1, -1, -1, 12, 13, -1, -1, -1, -1, 14, 15}},
};

/* A full 8 x 8 block of a 1- or 3-channel tile by the AVX2 path.
 * Returns 0 when a channel needs the portable path (nothing written). */
static int block_avx2(const struct avx2_matrix *m, int16_t *const d[3],
                           const int n[3], int channels, uint8_t *px,
                           size_t stride)
{
    __m256i e[3][8];
    for (int c = 0; c < channels; c++) {
        if (!n[c]) {
            for (int j = 0; j < 8; j++)
                e[c][j] = _mm256_setzero_si256();
        } else if (!inverse_avx2(m, d[c], n[c], e[c])) {
            return 0;
        }
    }
    for (int c = 0; c < channels; c++)
        if (n[c])
            clear_block(d[c], n[c]);
    if (channels == 1) {
        for (int j = 0; j < 8; j++, px += stride)
            add8(px, pack16(e[0][j]));
    } else if (!(n[1] | n[2])) {
        /* R = G = B = Y: each residual three times, 24 bytes a row. */
        const __m128i x0 = _mm_setr_epi8(0, 1, 0, 1, 0, 1, 2, 3, 2, 3, 2, 3,
                                         4, 5, 4, 5);
        const __m128i x1 = _mm_setr_epi8(4, 5, 6, 7, 6, 7, 6, 7, 8, 9, 8, 9,
                                         8, 9, 10, 11);
        const __m128i x2 = _mm_setr_epi8(10, 11, 10, 11, 12, 13, 12, 13, 12,
                                         13, 14, 15, 14, 15, 14, 15);
        for (int j = 0; j < 8; j++, px += stride) {
            const __m128i y = pack16(e[0][j]);
            add8(px, _mm_shuffle_epi8(y, x0));
            add8(px + 8, _mm_shuffle_epi8(y, x1));
            add8(px + 16, _mm_shuffle_epi8(y, x2));
        }
    } else {
        for (int j = 0; j < 8; j++, px += stride) {
            const __m256i y = e[0][j], co = e[1][j], cg = e[2][j];
            const __m256i t = _mm256_sub_epi32(y, _mm256_srai_epi32(cg, 1));
            const __m256i g = _mm256_add_epi32(cg, t);
            const __m256i b = _mm256_sub_epi32(t, _mm256_srai_epi32(co, 1));
            const __m256i r = _mm256_add_epi32(b, co);
            const __m128i rgb[3] = {pack16(r), pack16(g), pack16(b)};
            for (int k = 0; k < 3; k++) {
                __m128i v = _mm_setzero_si128();
                for (int c = 0; c < 3; c++)
                    v = _mm_or_si128(v, _mm_shuffle_epi8(rgb[c], _mm_loadu_si128(
                        (const __m128i *)rgb_interleave[k][c])));
                add8(px + 8 * k, v);
            }
        }
    }
    return 1;
}

static int block_simd(const void *ctx, int16_t *const d[3], const int n[3],
                      int channels, uint8_t *px, size_t stride)
{
    return block_avx2(ctx, d, n, channels, px, stride);
}

void gv_dct_add_row_avx2(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                         int channels, int by, uint8_t *out)
{
    struct avx2_matrix m;
    avx2_matrix_init(&m);
    gv_dct_add_row_blocks(co, eobs, channels, by, out, block_simd, &m);
}
#endif
