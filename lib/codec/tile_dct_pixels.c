/*
 * tile_dct_pixels.c - layout D's pixel side (docs/FORMAT.md section 4.3):
 * the 8x8 integer inverse transform, YCoCg-R and the residual's addition
 * to the prediction, a row of blocks at a time (tile_dct_pixels.h).
 *
 * The transform is two passes of 32-bit integer sums, each rounded by an
 * arithmetic shift; sums of exact integers do not depend on their order,
 * so every way of computing them below gives the same bytes:
 * - The portable path multiplies only the rows and columns that the coded
 *   coefficients reach (most blocks end well before coefficient 64), and
 *   fills DC-only blocks at once.
 * - The AVX2 path (chosen at run time where the CPU has it) computes the
 *   first pass with VPMADDWD, two coefficients of a row per 32-bit lane
 *   against two matrix rows, eight outputs at once; the second pass the
 *   same way on the first pass's results, packed to 16 bits in pairs of
 *   rows.  Blocks with four coded rows or more take even-odd butterflies
 *   instead (half the multiplies; 1.03 times the tile decoding speed on
 *   Picos de Europa, bench/README.md session 9).  Those results fit in 16 bits for every block an encoder writes
 *   but not for every block a buffer can hold (steps of 4095), so a block
 *   whose first pass leaves the 16-bit range is done by the portable
 *   path.  The sum with the prediction saturates to 16 bits and then
 *   clamps to 0..255, the same as clamping the exact sum, since a
 *   prediction lies in 0..255.
 * Blocks without chroma (most of a photograph's: the prediction carries
 * the colour) add Y to R, G and B, which is what YCoCg-R gives for
 * Co = Cg = 0.  Arithmetic shifts of negative numbers go through asr(), a
 * floor division, so that the result does not depend on the compiler.
 * The row function is picked from gv_cpu_flags() (base/cpu.h) into a
 * one-entry table, add_row.
 */
#include <string.h>

#include "base/cpu.h"
#include "codec/tile_dct_pixels.h"
#include "codec/tile_layout.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#endif

const int32_t gv_dct_matrix[8][8] = {
    {64, 64, 64, 64, 64, 64, 64, 64},
    {89, 75, 50, 18, -18, -50, -75, -89},
    {83, 36, -36, -83, -83, -36, 36, 83},
    {75, -18, -89, -50, 50, 89, 18, -75},
    {64, -64, -64, 64, 64, -64, -64, 64},
    {50, -89, 18, 75, -75, -18, 89, -50},
    {36, -83, 83, -36, -36, 83, -83, 36},
    {18, -50, 75, -89, 89, -75, 50, -18},
};

const uint8_t gv_dct_zz_rows[65] = {
    0, 1, 1, 2, 3, 3, 3, 3, 3, 3, 4, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 6,
    7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 8, 8, 8, 8, 8, 8, 8, 8,
    8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
};
const uint8_t gv_dct_zz_cols[65] = {
    0, 1, 2, 2, 2, 2, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 6, 6, 6, 6, 6, 6,
    6, 6, 6, 6, 6, 6, 7, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
    8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
};

/* floor(a / 2^s).  GCC and Clang define >> of a negative number as the
 * arithmetic shift (and vectorize it); anything else gets the portable
 * form. */
static inline int32_t asr(int32_t a, int s)
{
#if defined(__GNUC__)
    return a >> s;
#else
    return a >= 0 ? a >> s : ~(~a >> s);
#endif
}

static inline uint8_t clamp_u8(int32_t v)
{
    return (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
}

void gv_dct_inverse(const int16_t *d, int32_t *e)
{
    int32_t t[8][8];   /* t[v][i] */
    for (int v = 0; v < 8; v++) {
        const int16_t *dv = d + 8 * v;
        int any = 0;
        for (int u = 0; u < 8; u++)
            any |= dv[u];
        for (int i = 0; i < 8; i++) {
            int32_t s = 64;
            if (any)
                for (int u = 0; u < 8; u++)
                    s += gv_dct_matrix[u][i] * dv[u];
            t[v][i] = asr(s, 7);
        }
    }
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 8; i++) {
            int32_t s = 1024;
            for (int v = 0; v < 8; v++)
                s += gv_dct_matrix[v][j] * t[v][i];
            e[8 * j + i] = asr(s, 11);
        }
}

/* gv_dct_inverse of a block whose coefficients past the first n in
 * zigzag order are zero (n >= 1), read from row-major storage with
 * `stride` between rows: the terms left out are zero, so the integers are
 * the same. */
static inline void inverse_sparse(const int16_t *d, size_t stride, int n,
                                  int32_t *e)
{
    const int rows = gv_dct_zz_rows[n], cols = gv_dct_zz_cols[n];
    if (n == 1) {
        const int32_t t = asr(64 * d[0] + 64, 7), v = asr(64 * t + 1024, 11);
        for (int k = 0; k < 64; k++)
            e[k] = v;
        return;
    }
    int32_t t[8][8];   /* t[v][i], rows v < `rows` */
    /* Loops over i innermost, eight lanes, so that they vectorize. */
    for (int v = 0; v < rows; v++) {
        const int16_t *dv = d + (size_t)v * stride;
        int32_t acc[8] = {64, 64, 64, 64, 64, 64, 64, 64};
        for (int u = 0; u < cols; u++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[u][i] * dv[u];
        for (int i = 0; i < 8; i++)
            t[v][i] = asr(acc[i], 7);
    }
    for (int j = 0; j < 8; j++) {
        int32_t acc[8] = {1024, 1024, 1024, 1024, 1024, 1024, 1024, 1024};
        for (int v = 0; v < rows; v++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[v][j] * t[v][i];
        for (int i = 0; i < 8; i++)
            e[8 * j + i] = asr(acc[i], 11);
    }
}

/* Set the first `rows` rows of a block's coefficients back to zero. */
static inline void clear_block(int16_t *d, int n)
{
    for (int v = 0; v < gv_dct_zz_rows[n]; v++)
        memset(d + (size_t)v * GV_DCT_PLANE, 0, 8 * sizeof *d);
}

/* Add residuals e (per channel, 8 x 8, row-major) to the pixels of a
 * block: `rows` x `cols` pixels from px, `stride` bytes between rows.
 * gray_residual: channels is 3 but e[1] and e[2] are zero (not read). */
static inline void add_block(uint8_t *px, size_t stride, int channels,
                             int rows, int cols, int gray_residual,
                             const int32_t e[3][64])
{
    for (int j = 0; j < rows; j++, px += stride) {
        const int32_t *ey = e[0] + 8 * j;
        uint8_t *p = px;
        if (channels == 1) {
            for (int i = 0; i < cols; i++)
                p[i] = clamp_u8(p[i] + ey[i]);
        } else if (gray_residual) {
            /* Co = Cg = 0: YCoCg-R gives R = G = B = Y. */
            for (int i = 0; i < 3 * cols; i++)
                p[i] = clamp_u8(p[i] + ey[i / 3]);
        } else {
            for (int i = 0; i < cols; i++, p += 3) {
                const int k = 8 * j + i;
                const int32_t y = e[0][k], co = e[1][k], cg = e[2][k];
                const int32_t t = y - asr(cg, 1);
                const int32_t g = cg + t, b = t - asr(co, 1), r = b + co;
                p[0] = clamp_u8(p[0] + r);
                p[1] = clamp_u8(p[1] + g);
                p[2] = clamp_u8(p[2] + b);
            }
        }
    }
}

/* One block by the portable path: n[c] coded coefficients of channel c
 * at d[c] (stride GV_DCT_PLANE), not all zero. */
static inline void block_portable(int16_t *const d[3], const int n[3],
                                  int channels, uint8_t *px, size_t stride,
                                  int rows, int cols)
{
    int32_t e[3][64];
    for (int c = 0; c < channels; c++) {
        if (!n[c]) {
            /* Zeros only where another channel needs them. */
            if (c > 0 || n[1] | n[2])
                memset(e[c], 0, sizeof e[c]);
            continue;
        }
        inverse_sparse(d[c], GV_DCT_PLANE, n[c], e[c]);
        clear_block(d[c], n[c]);
    }
    add_block(px, stride, channels, rows, cols,
              channels == 1 || !(n[1] | n[2]), e);
}

#if GV_HAVE_X86_SIMD

#define AVX2 __attribute__((target("avx2")))

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

AVX2 static void avx2_matrix_init(struct avx2_matrix *m)
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
AVX2 static int inverse_butterfly(const struct avx2_matrix *m,
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
AVX2 static int inverse_avx2(const struct avx2_matrix *m, const int16_t *d,
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
AVX2 static inline __m128i pack16(__m256i v)
{
    return _mm_packs_epi32(_mm256_castsi256_si128(v),
                           _mm256_extracti128_si256(v, 1));
}

/* px[k] = clamp(px[k] + r[k]) for 8 bytes, r saturated to 16 bits. */
AVX2 static inline void add8(uint8_t *px, __m128i r)
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
AVX2 static int block_avx2(const struct avx2_matrix *m, int16_t *const d[3],
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

#endif

/* A row of blocks; with m, whole blocks by AVX2 where it may (the tile's
 * last row and column of blocks, one pixel wide, and blocks out of its
 * 16-bit range by the portable path). */
static inline void add_row(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                           int channels, int by, uint8_t *out, void *m)
{
    (void)m;   /* unused where there are no x86 kernels */
    const size_t stride = (size_t)GV_TILE * channels;
    const int y0 = 8 * by, rows = y0 + 8 <= GV_TILE ? 8 : GV_TILE - y0;
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
        const int n[3] = {eobs[0][bx], channels == 3 ? eobs[1][bx] : 0,
                          channels == 3 ? eobs[2][bx] : 0};
        if (!(n[0] | n[1] | n[2]))
            continue;
        int16_t *const d[3] = {&co[0][0][8 * bx], &co[1][0][8 * bx],
                               &co[2][0][8 * bx]};
        const int x0 = 8 * bx, cols = x0 + 8 <= GV_TILE ? 8 : GV_TILE - x0;
        uint8_t *px = out + (size_t)y0 * stride + (size_t)x0 * channels;
#if GV_HAVE_X86_SIMD
        if (m && rows == 8 && cols == 8 &&
            block_avx2(m, d, n, channels, px, stride))
            continue;
#endif
        block_portable(d, n, channels, px, stride, rows, cols);
    }
}

typedef void add_row_fn(gv_dct_row, const uint8_t[3][GV_DCT_BLOCKS], int, int,
                        uint8_t *);

static void add_row_c(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                      int channels, int by, uint8_t *out)
{
    add_row(co, eobs, channels, by, out, NULL);
}

#if GV_HAVE_X86_SIMD
static void add_row_avx2(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                         int channels, int by, uint8_t *out)
{
    struct avx2_matrix m;
    avx2_matrix_init(&m);
    add_row(co, eobs, channels, by, out, &m);
}
#endif

static add_row_fn *add_row_kernel = add_row_c;
static struct gv_cpu_once add_row_once = GV_CPU_ONCE_INIT;

static void pixels_dsp_init(unsigned flags)
{
    add_row_kernel = add_row_c;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_AVX2)
        add_row_kernel = add_row_avx2;
#else
    (void)flags;
#endif
}

void gv_dct_add_row(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                    int channels, int by, uint8_t *out)
{
    gv_cpu_once(&add_row_once, pixels_dsp_init);
    add_row_kernel(co, eobs, channels, by, out);
}
