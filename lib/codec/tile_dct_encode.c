/*
 * tile_dct_encode.c - the layout D encoder (docs/FORMAT.md section 4.3).
 *
 * The residual against the prediction is taken to YCoCg (floating point:
 * the decoder's YCoCg-R lifting inverts it to within its rounding), the
 * pixels past the tile or the image replicated from the last valid ones
 * so that padding costs few bits, and every 8x8 block transformed by the
 * forward form of the decoder's integer DCT.  Blocks wholly outside the
 * image are coded as zero.
 *
 * Quantization rounds with a dead zone (offset ROUND_OFFSET instead of
 * 1/2), which lowers the rate more than it raises the error.  The step
 * of channel 0 is searched over quarter octaves around the high-rate
 * optimum for lambda, by descent from the commonest best while the cost
 * falls (J is unimodal there but for a plateau where every block is
 * zero), each candidate costed by its exact model entropy
 * (the 8-bit models as the buffer will store them, their bytes included)
 * and by its squared error estimated in the transform domain; chroma
 * steps follow at the ratios that equalize the slopes of the YCoCg-R
 * inverse (a unit of error in Y reaches three channels, one in Co half
 * of two, one in Cg a quarter of three: weights 3, 1/2, 3/4).  The best
 * candidate's blocks are then cut short where their last values cost
 * more bits than the error they remove (truncate_tails), and it is
 * written and rebuilt as gv_dct_decode would decode it, whose error is
 * exact.
 *
 * Speed (bench/README.md, 2026-11-26 later): a candidate is quantized and
 * its symbols counted in one pass, without copying; the transform and the
 * quantizer run in SSE2 (the transform also in AVX2, chosen at run time)
 * with the roundings of the plain C, in the same order, so the stores do
 * not depend on the path.  The AVX2 transform also takes the residual of
 * eight pixels at once and writes its second pass straight in zigzag
 * order (2.1 times faster than the plain C's structure in 8 lanes).
 * The encoder of 2026-11-26 (bench/README.md, "2026-11-26, encoder CPU"):
 * the tokens, contexts and escapes of a block are computed eight at a
 * time as slots (block_slots), which both the counting and the writing
 * use; the rANS rows are coded four at a time in lockstep, without a
 * branch, by a per-symbol table and a 64-bit multiply for x / f.  All of
 * it integer, so every path gives the same bytes.
 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "base/byteorder.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_layout.h"
#include "codec/sse.h"
#include "codec/tile_rans.h"

#define NB (GV_DCT_BLOCKS * GV_DCT_BLOCKS)
#define ROUND_OFFSET 0.36f      /* dead-zone rounding: floor(|x|/S + this) */
#define HEADER_BYTES 12
#define LENGTHS_BYTES (2 * GV_DCT_BLOCKS)
#define STEP_CANDIDATES 13      /* quarter octaves from 2^-0.5 to 2^2.5 */
#define STEP_START 3            /* the commonest best: 2^0.25 */
#define LN2 0.69314718055994530942

/* 2^(-0.5 + 0.25 i), written out rather than computed with pow(), whose
 * last bit may differ between C libraries: the steps, and so the stores,
 * must not depend on the machine (sqrt is exact in IEEE arithmetic). */
static const double step_factor[STEP_CANDIDATES] = {
    0.70710678118654752, 0.84089641525371454, 1.0, 1.18920711500272107,
    1.41421356237309505, 1.68179283050742908, 2.0, 2.37841423000544213,
    2.82842712474619010, 3.36358566101485816, 4.0, 4.75682846001088427,
    5.65685424949238020,
};
#define MAX_ROW_SYMBOLS (GV_DCT_BLOCKS * 3 * (1 + 64 * 3))
#define LANES 4                 /* rows whose rANS states are coded together */

static const double channel_weight[3] = {3.0, 0.5, 0.75};

/* A symbol's rANS coding at 8 bits (put_sym): x / f = x * m >> 40, the
 * state renormalized when x > thr = f 2^24 - 1, g = 256 - f, c its
 * cumulative frequency.  Entry enc_at[model] + symbol for a model's
 * symbols, ENC_UNIFORM + v for a uniform 6-bit step v. */
struct enc_sym {
    uint64_t m;
    uint32_t thr;
    uint16_t g, c;
};

#define ENC_UNIFORM (GV_DCT_EOB_MODELS * GV_DCT_EOB_SYMBOLS +                \
                     (GV_DCT_MODELS - GV_DCT_EOB_MODELS) * GV_DCT_TOKEN_SYMBOLS)
#define ENC_SYMBOLS (ENC_UNIFORM + 64)

struct models {
    uint32_t count[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS];
    uint32_t freq[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS];
    uint32_t cum[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS + 1];
    uint32_t total[GV_DCT_MODELS];
    uint64_t uniform;            /* uniform steps */
};

/* A candidate's quantized coefficients (zigzag order; of a block only the
 * first eob are meaningful) and symbol counts. */
struct candidate {
    int16_t q[3][NB][64];
    uint8_t eob[3][NB];
    struct models md;
};

struct gv_dct_workspace {
    float x[3][NB][64];          /* transform of the residual, zigzag order */
    float maxabs[3][NB];         /* largest |coefficient| of each block */
    double energy[3][NB];        /* sum of its squares */
    struct candidate cand[2];    /* the one being tried, and the best */
    uint16_t syms[LANES][MAX_ROW_SYMBOLS + 64]; /* rows' symbols (enc[]) */
    struct enc_sym enc[ENC_SYMBOLS];   /* the coding of every symbol */
    uint16_t words[LANES][MAX_ROW_SYMBOLS + 2];
};

struct gv_dct_workspace *gv_dct_workspace_new(void)
{
    return malloc(sizeof(struct gv_dct_workspace));
}

void gv_dct_workspace_free(struct gv_dct_workspace *ws)
{
    free(ws);
}

/* The residual of channel c (YCoCg when C = 3) at pixel (x, y), the
 * coordinates clamped to the valid area. */
__attribute__((always_inline)) static inline void
residual_block(const uint8_t *orig, const uint8_t *pred,
                           int channels, int bx, int by, uint32_t vw,
                           uint32_t vh, float out[3][64])
{
    if (channels == 3 && (uint32_t)(8 * bx + 8) <= vw &&
        (uint32_t)(8 * by + 8) <= vh) {
        /* Inside the valid area: no clamping, the same arithmetic. */
        for (int j = 0; j < 8; j++) {
            const size_t at = ((size_t)(8 * by + j) * GV_TILE + 8 * bx) * 3;
            const uint8_t *o = orig + at, *p = pred + at;
            for (int i = 0; i < 8; i++) {
                const float r = (float)(o[3 * i] - p[3 * i]);
                const float g = (float)(o[3 * i + 1] - p[3 * i + 1]);
                const float b = (float)(o[3 * i + 2] - p[3 * i + 2]);
                const float co = r - b, t = b + co / 2, cg = g - t;
                out[0][8 * j + i] = t + cg / 2;
                out[1][8 * j + i] = co;
                out[2][8 * j + i] = cg;
            }
        }
        return;
    }
    for (int j = 0; j < 8; j++) {
        uint32_t y = (uint32_t)(8 * by + j);
        if (y >= vh)
            y = vh - 1;
        for (int i = 0; i < 8; i++) {
            uint32_t x = (uint32_t)(8 * bx + i);
            if (x >= vw)
                x = vw - 1;
            const size_t at = ((size_t)y * GV_TILE + x) * (size_t)channels;
            if (channels == 1) {
                out[0][8 * j + i] = (float)orig[at] - (float)pred[at];
                continue;
            }
            const float r = (float)orig[at] - pred[at];
            const float g = (float)orig[at + 1] - pred[at + 1];
            const float b = (float)orig[at + 2] - pred[at + 2];
            const float co = r - b, t = b + co / 2, cg = g - t;
            out[0][8 * j + i] = t + cg / 2;
            out[1][8 * j + i] = co;
            out[2][8 * j + i] = cg;
        }
    }
}

/* K transposed, as floats: kt[i][u] = K[u][i].  For the AVX2 second
 * pass, per group g of eight coefficients in zigzag order and lane p
 * (zz = gv_dct_zigzag[8 g + p]): the column zz % 8 in zz_col[g][p] and
 * K[zz / 8][j] in zz_k[g][j][p]. */
static float kt[8][8];
static _Alignas(32) int32_t zz_col[8][8];
static _Alignas(32) float zz_k[8][8][8];

static void init_kt(void)
{
    for (int i = 0; i < 8; i++)
        for (int u = 0; u < 8; u++)
            kt[i][u] = (float)gv_dct_matrix[u][i];
    for (int g = 0; g < 8; g++)
        for (int p = 0; p < 8; p++) {
            const int zz = gv_dct_zigzag[8 * g + p];
            zz_col[g][p] = zz % 8;
            for (int j = 0; j < 8; j++)
                zz_k[g][j][p] = (float)gv_dct_matrix[zz / 8][j];
        }
}

/* d[zz^-1(8 v + u)] = sum_j sum_i K[v][j] K[u][i] e(i, j) / 4096: the
 * coefficients whose integer inverse (FORMAT.md 4.3) gives back e, in
 * zigzag order.  Each sum runs over i (then j) in increasing order, in
 * eight lanes over u so that it vectorizes; the order of the additions,
 * and so every rounding, is that of a plain loop (no FMA: ISO C mode). */
#if defined(__SSE2__)
static inline void forward(const float *e, float *d)
{
    __m128 t[8][2];   /* t[j][u / 4] */
    for (int j = 0; j < 8; j++) {
        __m128 s0 = _mm_setzero_ps(), s1 = _mm_setzero_ps();
        for (int i = 0; i < 8; i++) {
            const __m128 ei = _mm_set1_ps(e[8 * j + i]);
            s0 = _mm_add_ps(s0, _mm_mul_ps(_mm_loadu_ps(kt[i]), ei));
            s1 = _mm_add_ps(s1, _mm_mul_ps(_mm_loadu_ps(kt[i] + 4), ei));
        }
        t[j][0] = s0;
        t[j][1] = s1;
    }
    float r[64];
    const __m128 scale = _mm_set1_ps(1.0f / 4096.0f);
    for (int v = 0; v < 8; v++) {
        __m128 s0 = _mm_setzero_ps(), s1 = _mm_setzero_ps();
        for (int j = 0; j < 8; j++) {
            const __m128 k = _mm_set1_ps((float)gv_dct_matrix[v][j]);
            s0 = _mm_add_ps(s0, _mm_mul_ps(k, t[j][0]));
            s1 = _mm_add_ps(s1, _mm_mul_ps(k, t[j][1]));
        }
        _mm_storeu_ps(r + 8 * v, _mm_mul_ps(s0, scale));
        _mm_storeu_ps(r + 8 * v + 4, _mm_mul_ps(s1, scale));
    }
    for (int k = 0; k < 64; k++)
        d[k] = r[gv_dct_zigzag[k]];
}
#else
static inline void forward(const float *e, float *d)
{
    float t[8][8];   /* t[j][u] */
    for (int j = 0; j < 8; j++) {
        float s[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int i = 0; i < 8; i++) {
            const float ei = e[8 * j + i];
            for (int u = 0; u < 8; u++)
                s[u] += kt[i][u] * ei;
        }
        memcpy(t[j], s, sizeof s);
    }
    float r[64];
    for (int v = 0; v < 8; v++) {
        float s[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int j = 0; j < 8; j++) {
            const float k = (float)gv_dct_matrix[v][j];
            for (int u = 0; u < 8; u++)
                s[u] += k * t[j][u];
        }
        for (int u = 0; u < 8; u++)
            r[8 * v + u] = s[u] * (1.0f / 4096.0f);
    }
    for (int k = 0; k < 64; k++)
        d[k] = r[gv_dct_zigzag[k]];
}
#endif

#if GV_HAVE_X86_SIMD
/* forward() in 8 lanes: the same operations in the same order, but for
 * the first pass's fused multiply-adds.  They give the same floats: the
 * residual is a multiple of 1/4 below 2^9 in magnitude (YCoCg of 8-bit
 * differences), so each product K e and each partial sum (at most 464 x
 * 510 < 2^18, in quarters) is exact in single precision, and a rounding
 * of an exact value changes nothing.  The second pass's sums are not
 * exact, so it keeps a multiply and an add. */
__attribute__((target("avx2,fma"), always_inline)) static inline void
forward_avx2(const float *e, float *d)
{
    __m256 t[8];
    for (int j = 0; j < 8; j++) {
        __m256 s = _mm256_setzero_ps();
        for (int i = 0; i < 8; i++)
            s = _mm256_fmadd_ps(_mm256_loadu_ps(kt[i]),
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
        const __m256i ui = _mm256_load_si256((const __m256i *)zz_col[g]);
        __m256 s = _mm256_setzero_ps();
        for (int j = 0; j < 8; j++)
            s = _mm256_add_ps(s, _mm256_mul_ps(_mm256_load_ps(zz_k[g][j]),
                                               _mm256_permutevar8x32_ps(t[j], ui)));
        _mm256_storeu_ps(d + 8 * g, _mm256_mul_ps(s, scale));
    }
}
#endif

#if GV_HAVE_X86_SIMD
/* residual_block, an RGB block inside the valid area eight pixels at a
 * time.  The same floats: with r, g, b the differences (integers), the
 * plain code's exact steps give Y = (r + 2g + b) / 4, Co = r - b and
 * Cg = (2g - r - b) / 2, each an integer scaled by a power of two, and
 * neither way makes a negative zero.  Loads exactly the block's 24 bytes
 * of each row (16 + 8), never past the tile. */
__attribute__((target("avx2,fma"), always_inline)) static inline void
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
#endif

/* Lane l of m and e2 (zero on entry): the largest |x[k + l]| and the sum
 * of the squares in increasing k, k = 0, 8, ..., 56 (the roundings of
 * that order, a multiply and an add each, on every path). */
__attribute__((always_inline)) static inline void
block_stats(const float *x, float *m, float *e2)
{
#if defined(__SSE2__)
    const __m128 absmask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    for (int h = 0; h < 8; h += 4) {
        __m128 mv = _mm_setzero_ps(), ev = _mm_setzero_ps();
        for (int k = 0; k < 64; k += 8) {
            const __m128 a = _mm_and_ps(_mm_loadu_ps(x + k + h), absmask);
            mv = _mm_max_ps(a, mv);
            ev = _mm_add_ps(ev, _mm_mul_ps(a, a));
        }
        _mm_storeu_ps(m + h, mv);
        _mm_storeu_ps(e2 + h, ev);
    }
#else
    for (int k = 0; k < 64; k += 8)
        for (int l = 0; l < 8; l++) {
            const float a = fabsf(x[k + l]);
            m[l] = a > m[l] ? a : m[l];
            e2[l] += a * a;
        }
#endif
}

typedef void residual_fn(const uint8_t *, const uint8_t *, int, int, int,
                         uint32_t, uint32_t, float[3][64]);

__attribute__((always_inline)) static inline void
transform_body(struct gv_dct_workspace *ws, const uint8_t *orig,
               const uint8_t *pred, int channels, uint32_t vw, uint32_t vh,
               void (*fwd)(const float *, float *), residual_fn *residual)
{
    for (int by = 0; by < GV_DCT_BLOCKS; by++)
        for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
            const int b = by * GV_DCT_BLOCKS + bx;
            if ((uint32_t)(8 * bx) >= vw || (uint32_t)(8 * by) >= vh) {
                /* All zero: quantize_count never reads x of a block
                 * whose maxabs is under half a step, so x is left. */
                for (int c = 0; c < channels; c++) {
                    ws->maxabs[c][b] = 0;
                    ws->energy[c][b] = 0;
                }
                continue;
            }
            float e[3][64];
            residual(orig, pred, channels, bx, by, vw, vh, e);
            for (int c = 0; c < channels; c++) {
                float *x = ws->x[c][b];
                fwd(e[c], x);
                float m[8] = {0, 0, 0, 0, 0, 0, 0, 0};
                float e2[8] = {0, 0, 0, 0, 0, 0, 0, 0};
                block_stats(x, m, e2);
                float mm = 0;
                for (int l = 0; l < 8; l++)
                    mm = m[l] > mm ? m[l] : mm;
                ws->maxabs[c][b] = mm;
                ws->energy[c][b] = ((double)e2[0] + e2[1] + e2[2] + e2[3]) +
                                   ((double)e2[4] + e2[5] + e2[6] + e2[7]);
            }
        }
}

/* The transform of a tile: residual, forward transform, the largest
 * coefficient and the energy of every block.  The same C compiled twice,
 * for the baseline and for AVX2 (8 lanes instead of 4; no FMA, so every
 * rounding is the same and so are the stores), chosen at run time. */
static void transform_tile_base(struct gv_dct_workspace *ws,
                                const uint8_t *orig, const uint8_t *pred,
                                int channels, uint32_t vw, uint32_t vh)
{
    transform_body(ws, orig, pred, channels, vw, vh, forward, residual_block);
}

#if GV_HAVE_X86_SIMD
__attribute__((target("avx2,fma"))) static void
transform_tile_avx2(struct gv_dct_workspace *ws, const uint8_t *orig,
                    const uint8_t *pred, int channels, uint32_t vw,
                    uint32_t vh)
{
    transform_body(ws, orig, pred, channels, vw, vh, forward_avx2,
                   residual_block_avx2);
}
#endif

typedef void transform_fn(struct gv_dct_workspace *, const uint8_t *,
                          const uint8_t *, int, uint32_t, uint32_t);
static transform_fn *transform_tile = transform_tile_base;

/* token | class << 4 of a quantized value q, at tc[q + 2048]. */
static uint8_t tc[4096];

static void init_tc(void)
{
    for (int q = -2048; q < 2048; q++) {
        int t = q == 0 ? 0 : (q > 0 && q <= 7) ? 2 * q - 1 :
                (q < 0 && q >= -7) ? -2 * q : GV_DCT_ESCAPE;
        tc[q + 2048] = (uint8_t)(t | gv_dct_class(q) << 4);
    }
}

/* Quantize one block x[64] with step s (inv = 1 / s) into q[64]: the
 * dead-zone rounding floor(|x| / s + ROUND_OFFSET), capped at 2047, with
 * the sign of x.  acc[l] gets the squared error of lanes l, l + 8, ...,
 * summed in that order (the same roundings with SSE2 as without).
 * Returns the mask of the nonzero values (bit k for q[k]). */
static inline uint64_t quantize_block(const float *x, float inv, float s,
                                      int16_t *q, float *acc)
{
#if defined(__SSE2__)
    const __m128 vinv = _mm_set1_ps(inv), vs = _mm_set1_ps(s);
    const __m128 off = _mm_set1_ps(ROUND_OFFSET), cap = _mm_set1_ps(2047.5f);
    const __m128 absmask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128i zero = _mm_setzero_si128();
    __m128 acc0 = _mm_setzero_ps(), acc1 = _mm_setzero_ps();
    uint64_t nz = 0;
    for (int k = 0; k < 64; k += 8) {
        __m128i m2[2];
        for (int h = 0; h < 2; h++) {
            const __m128 v = _mm_loadu_ps(x + k + 4 * h);
            const __m128 a = _mm_and_ps(v, absmask);
            __m128 f = _mm_add_ps(_mm_mul_ps(a, vinv), off);
            f = _mm_min_ps(f, cap);
            const __m128i m = _mm_cvttps_epi32(f);
            const __m128 err = _mm_sub_ps(a, _mm_mul_ps(_mm_cvtepi32_ps(m), vs));
            if (h)
                acc1 = _mm_add_ps(acc1, _mm_mul_ps(err, err));
            else
                acc0 = _mm_add_ps(acc0, _mm_mul_ps(err, err));
            const __m128i sg = _mm_srai_epi32(_mm_castps_si128(v), 31);
            m2[h] = _mm_sub_epi32(_mm_xor_si128(m, sg), sg);
        }
        const __m128i q8 = _mm_packs_epi32(m2[0], m2[1]);
        _mm_storeu_si128((__m128i *)(q + k), q8);
        const __m128i eq = _mm_cmpeq_epi16(q8, zero);
        const int z = _mm_movemask_epi8(_mm_packs_epi16(eq, eq)) & 0xff;
        nz |= (uint64_t)(~z & 0xff) << k;
    }
    _mm_storeu_ps(acc, acc0);
    _mm_storeu_ps(acc + 4, acc1);
    return nz;
#else
    for (int l = 0; l < 8; l++)
        acc[l] = 0;
    for (int k = 0; k < 64; k += 8)
        for (int l = 0; l < 8; l++) {
            const float v = x[k + l], a = fabsf(v);
            float f = a * inv + ROUND_OFFSET;
            f = f < 2047.5f ? f : 2047.5f;
            const int m = (int)f;
            const float err = a - (float)m * s;
            acc[l] += err * err;
            q[k + l] = (int16_t)(v < 0 ? -m : m);
        }
    uint64_t nz = 0;
    for (int k = 0; k < 64; k++)
        nz |= (uint64_t)(q[k] != 0) << k;
    return nz;
#endif
}

#if GV_HAVE_X86_SIMD
/* quantize_block in eight lanes: the same operations in the same order
 * (a multiply and an add, never fused: ISO C mode), so the same q, the
 * same return and the same acc[l], lane l summing k = l, l + 8, ... */
__attribute__((target("avx2,fma"), always_inline)) static inline uint64_t
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
#endif

/* The token counts of quantize_count: the 24 token models (12 per
 * channel class, 16 symbols each), packed, copied into the models after. */
#define TOKEN_SLOTS (12 * GV_DCT_TOKEN_SYMBOLS)     /* one channel class */

/* The slot of token k's band within its channel class's counts. */
static _Alignas(16) uint16_t tok_base[64];

static void init_tok_base(void)
{
    for (int k = 0; k < 64; k++)
        tok_base[k] = (uint16_t)(gv_dct_band_model[k] * GV_DCT_TOKEN_SYMBOLS);
}

/* The token slots of a block q (zigzag order) whose eob is n >= 1:
 * slot[k] = add + tok_base[k] + 16 class(q[k - 1]) + token(q[k]) for
 * k < n, class(q[-1]) taken as dcp (the class of the previous block's
 * first value), as write_buffer codes them: token k's model is its
 * band's for the class of value k - 1.  Values up to n rounded up to 8
 * are written.  Returns twice the escapes (their uniform steps).  Eight
 * at a time: t = min(2 |q| - (q > 0), 15) is tc[]'s token and
 * min(|q|, 2) the class. */
__attribute__((always_inline)) static inline int
block_slots(const int16_t *q, int n, int dcp, int add, uint16_t *slot)
{
#if defined(__SSE2__)
    const __m128i zero = _mm_setzero_si128(), two = _mm_set1_epi16(2);
    const __m128i fifteen = _mm_set1_epi16(15), seven = _mm_set1_epi16(7);
    const __m128i vadd = _mm_set1_epi16((int16_t)add);
    __m128i prev = _mm_insert_epi16(zero, dcp, 7);
    int esc = 0;
    for (int k = 0; k < n; k += 8) {
        const __m128i v = _mm_loadu_si128((const __m128i *)(q + k));
        const __m128i a = _mm_max_epi16(v, _mm_sub_epi16(zero, v));
        const __m128i t = _mm_min_epi16(
            _mm_add_epi16(_mm_add_epi16(a, a), _mm_cmpgt_epi16(v, zero)),
            fifteen);
        const __m128i cls = _mm_min_epi16(a, two);
        const __m128i p = _mm_or_si128(_mm_slli_si128(cls, 2),
                                       _mm_srli_si128(prev, 14));
        prev = cls;
        const __m128i base = _mm_add_epi16(
            _mm_load_si128((const __m128i *)(tok_base + k)), vadd);
        _mm_storeu_si128((__m128i *)(slot + k), _mm_add_epi16(
            _mm_add_epi16(base, _mm_slli_epi16(p, 4)), t));
        /* Two mask bits per escape. */
        esc += __builtin_popcount(
            (unsigned)_mm_movemask_epi8(_mm_cmpgt_epi16(a, seven)));
    }
    return esc;
#else
    int esc = 0, p = dcp;
    for (int k = 0; k < n; k++) {
        const int y = tc[q[k] + 2048], t = y & 15;
        slot[k] = (uint16_t)(add + tok_base[k] + 16 * p + t);
        esc += t == GV_DCT_ESCAPE ? 2 : 0;
        p = y >> 4;
    }
    return esc;
#endif
}

/* Count the tokens of block q (eob n >= 1, dcp as block_slots) into h,
 * the counts of its channel class; returns its uniform steps. */
__attribute__((always_inline)) static inline uint64_t
count_block(const int16_t *q, int n, int dcp, uint32_t *h)
{
    _Alignas(16) uint16_t slot[64];
    const int esc = block_slots(q, n, dcp, 0, slot);
    for (int k = 0; k < n; k++)
        h[slot[k]]++;
    return (uint64_t)esc;
}

/* The token counts of both channel classes (tokh, TOKEN_SLOTS each) and
 * the uniform steps into the models' counts. */
static void tokens_to_models(struct models *md, const uint32_t *tokh,
                             uint64_t uniform)
{
    for (int m = 0; m < 2 * 12; m++)
        memcpy(md->count[GV_DCT_EOB_MODELS + m],
               tokh + m * GV_DCT_TOKEN_SYMBOLS,
               GV_DCT_TOKEN_SYMBOLS * sizeof *tokh);
    md->uniform = uniform;
}

typedef uint64_t quantize_fn(const float *, float, float, int16_t *, float *);

/* Quantize every block at steps[] into cd (q, eob) and count its symbols
 * into cd->md (counts and the uniform steps; totals and frequencies are
 * build_models'); returns the estimated weighted squared error (transform
 * domain, pixel units).  A block whose largest coefficient rounds to 0 is
 * all zero: its error is its energy and its q is left alone (only the
 * first eob values are ever read).  The counts are the symbols that
 * write_buffer codes (FORMAT.md 4.3), channel by channel: the contexts
 * pe and dcp run along a row within one channel. */
__attribute__((always_inline)) static inline double
quantize_count_body(const struct gv_dct_workspace *ws, struct candidate *cd,
                    int channels, const int *steps, quantize_fn *qblock)
{
    struct models *md = &cd->md;
    memset(md->count, 0, sizeof md->count);
    uint32_t tokh[2 * TOKEN_SLOTS];
    memset(tokh, 0, sizeof tokh);
    uint64_t uniform = 0;
    double sse = 0;
    for (int c = 0; c < channels; c++) {
        const float inv = 1.0f / (float)steps[c], s = (float)steps[c];
        const float zero_below = (1.0f - ROUND_OFFSET) * s;
        const double w = channels == 1 ? 1.0 : channel_weight[c];
        const int cc = c > 0;
        uint32_t *eobc = md->count[3 * cc];
        uint32_t *tokc = tokh + TOKEN_SLOTS * cc;
        double e2 = 0;
        for (int by = 0; by < GV_DCT_BLOCKS; by++) {
            int pe = 0, dcp = 0;
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx;
                if (ws->maxabs[c][b] < zero_below) {
                    /* A run of all-zero blocks, in a loop of its own that
                     * keeps the error's sum in a register: its first eob
                     * in context pe, the others in context 0. */
                    const float *ma = ws->maxabs[c] + by * GV_DCT_BLOCKS;
                    const double *en = ws->energy[c] + by * GV_DCT_BLOCKS;
                    uint8_t *eob = cd->eob[c] + by * GV_DCT_BLOCKS;
                    double t = e2;
                    int r = bx;
                    do {
                        eob[r] = 0;
                        t += en[r];
                        r++;
                    } while (r < GV_DCT_BLOCKS && ma[r] < zero_below);
                    e2 = t;
                    eobc[pe * GV_DCT_EOB_SYMBOLS]++;
                    eobc[0] += (uint32_t)(r - bx - 1);
                    pe = dcp = 0;
                    bx = r - 1;
                    continue;
                }
                const float *x = ws->x[c][b];
                int16_t *q = cd->q[c][b];
                float acc[8];
                const uint64_t nz = qblock(x, inv, s, q, acc);
                e2 += ((acc[0] + acc[1]) + (acc[2] + acc[3])) +
                      ((acc[4] + acc[5]) + (acc[6] + acc[7]));
                const int n = nz ? 64 - __builtin_clzll(nz) : 0;
                cd->eob[c][b] = (uint8_t)n;
                eobc[pe * GV_DCT_EOB_SYMBOLS + n]++;
                pe = gv_dct_eob_class(n);
                if (!n) {
                    dcp = 0;
                    continue;
                }
                const int dc_ctx = dcp;
                dcp = gv_dct_class(q[0]);
                uniform += count_block(q, n, dc_ctx, tokc);
            }
        }
        sse += w * e2 / 64.0;
    }
    tokens_to_models(md, tokh, uniform);
    return sse;
}

/* quantize_count_body compiled for the baseline and for AVX2, chosen at
 * run time with the transform (the same results). */
static double quantize_count_base(const struct gv_dct_workspace *ws,
                                  struct candidate *cd, int channels,
                                  const int *steps)
{
    return quantize_count_body(ws, cd, channels, steps, quantize_block);
}

#if GV_HAVE_X86_SIMD
__attribute__((target("avx2,fma"))) static double
quantize_count_avx2(const struct gv_dct_workspace *ws, struct candidate *cd,
                    int channels, const int *steps)
{
    return quantize_count_body(ws, cd, channels, steps, quantize_block_avx2);
}
#endif

typedef double quantize_count_fn(const struct gv_dct_workspace *,
                                 struct candidate *, int, const int *);
static quantize_count_fn *quantize_count = quantize_count_base;

/* Frequencies summing to 256, every used symbol at least 1, and the last
 * symbol at least 1 even when unused: the stored cumulative frequencies
 * are bytes, so none may reach 256. */
static void normalize(const uint32_t *count, int k, uint32_t total,
                      uint32_t *freq)
{
    int big = 0;
    uint32_t sum = 0;
    for (int s = 0; s < k; s++) {
        if (!count[s]) {
            freq[s] = s == k - 1;
            sum += freq[s];
            continue;
        }
        uint32_t f = (uint32_t)(((uint64_t)count[s] * 256 + total / 2) / total);
        freq[s] = f ? f : 1;
        sum += freq[s];
        if (count[s] > count[big] || !count[big])
            big = s;
    }
    /* Take from (or give to) the commonest symbols until the sum is 256;
     * never below 1. */
    while (sum > 256) {
        int best = -1;
        for (int s = 0; s < k; s++)
            if (freq[s] > 1 && (best < 0 || freq[s] > freq[best]))
                best = s;
        freq[best]--;
        sum--;
    }
    freq[big] += 256 - sum;
}

/* Build the stored models from the counts; the model bytes. */
static size_t build_models(struct models *md, uint32_t *mask)
{
    size_t bytes = 0;
    *mask = 0;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        const int k = gv_dct_model_symbols(m);
        uint32_t total = 0;
        for (int s = 0; s < k; s++)
            total += md->count[m][s];
        md->total[m] = total;
        if (!total)
            continue;
        *mask |= 1u << m;
        bytes += (size_t)k;
        normalize(md->count[m], k, md->total[m], md->freq[m]);
        md->cum[m][0] = 0;
        for (int s = 0; s < k; s++)
            md->cum[m][s + 1] = md->cum[m][s] + md->freq[m][s];
    }
    return bytes;
}

static double log2_table[257];

/* ceil(2^40 / f): x / f = x * freq_m40[f] >> 40 exactly for every
 * state x < f 2^24 (the bound after renormalization at 8 bits).  With
 * freq_m40[f] = (2^40 + r) / f, 0 <= r < f, the product exceeds x / f 2^40
 * by x r / f < (f - 1) 2^24, and f (f - 1) < 2^16 for f <= 256, so the
 * excess stays under 2^40 / f: too little to carry past the next
 * multiple of 1 / f, the least gap above a quotient's fraction.  The
 * product stays under 2^64 since f r < 2^16.  One 64-bit multiply
 * instead of gv_rans_rcp's 128-bit one, and no case for f = 1. */
static uint64_t freq_m40[257];

static void init_log2(void)
{
    for (int f = 1; f <= 256; f++) {
        log2_table[f] = log2(256.0 / f);
        freq_m40[f] = ((1ull << 40) + (uint64_t)f - 1) / (uint64_t)f;
    }
}

/* Estimated bytes of the buffer with these models. */
static double estimate_bytes(const struct models *md, size_t model_bytes)
{
    double bits = 6.0 * (double)md->uniform;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        if (!md->total[m])
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            if (md->count[m][s])
                bits += md->count[m][s] * log2_table[md->freq[m][s]];
    }
    return bits / 8 + (double)model_bytes + HEADER_BYTES + LENGTHS_BYTES +
           4.0 * GV_DCT_BLOCKS;
}

/* The first enc[] entry of model m. */
static inline int enc_at(int m)
{
    return m < GV_DCT_EOB_MODELS ? m * GV_DCT_EOB_SYMBOLS :
           GV_DCT_EOB_MODELS * GV_DCT_EOB_SYMBOLS +
           (m - GV_DCT_EOB_MODELS) * GV_DCT_TOKEN_SYMBOLS;
}

static void set_enc(struct enc_sym *e, uint32_t f, uint32_t c)
{
    e->m = freq_m40[f];
    e->thr = (uint32_t)(((uint64_t)f << 24) - 1);
    e->g = (uint16_t)(256 - f);
    e->c = (uint16_t)c;
}

/* gv_rans_put_rcp at 8 bits for symbol e: the same state and words, with
 * x - (x / f) f + (x / f) 2^8 written x + (x / f) g, and no branch: the
 * renormalized state and the other are both at hand and one is kept
 * (whether a word goes out follows the data and would be mispredicted
 * often; words[] has room for a store that the count then drops). */
static inline uint32_t put_sym(uint32_t x, const struct enc_sym *e,
                               uint16_t **w)
{
    const int out = x > e->thr;
    **w = (uint16_t)x;
    *w += out;
    const uint32_t xr = out ? x >> 16 : x;
    const uint32_t q = (uint32_t)((uint64_t)xr * e->m >> 40);
    return xr + q * e->g + e->c;
}

/* The symbols of block row `by` in stream order into sy, as enc[]
 * entries (FORMAT.md 4.3: per block, per channel, the eob, then each
 * token, an escape followed by its two uniform steps); returns their
 * number.  sy has room for 64 past the last. */
static int collect_row(const struct candidate *cd, int channels, int by,
                       uint16_t *sy)
{
    int k = 0, pe[3] = {0, 0, 0}, dcp[3] = {0, 0, 0};
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
        const int b = by * GV_DCT_BLOCKS + bx;
        for (int c = 0; c < channels; c++) {
            const int cc = c > 0, n = cd->eob[c][b];
            const int16_t *q = cd->q[c][b];
            sy[k++] = (uint16_t)(enc_at(3 * cc + pe[c]) + n);
            pe[c] = gv_dct_eob_class(n);
            if (!n) {
                dcp[c] = 0;
                continue;
            }
            const int tokens = enc_at(GV_DCT_EOB_MODELS) + TOKEN_SLOTS * cc;
            if (!block_slots(q, n, dcp[c], tokens, sy + k)) {
                k += n;
            } else {
                /* Escapes: their uniform steps go in after them. */
                _Alignas(16) uint16_t slot[64];
                block_slots(q, n, dcp[c], tokens, slot);
                for (int j = 0; j < n; j++) {
                    sy[k++] = slot[j];
                    if (q[j] > 7 || q[j] < -7) {
                        const int e = q[j] + 2048;
                        sy[k++] = (uint16_t)(ENC_UNIFORM + (e >> 6));
                        sy[k++] = (uint16_t)(ENC_UNIFORM + (e & 63));
                    }
                }
            }
            dcp[c] = gv_dct_class(q[0]);
        }
    }
    return k;
}

/* Code the collected symbols of `rows` rows (at most LANES; left[r] of
 * row r, coded last to first) into their states x[] and words.  The
 * rows' states are independent chains of multiplies: coded in lockstep,
 * LANES at a time while every row has symbols left, then two, then
 * one, so that each chain's latency hides behind the others'. */
static void code_rows(struct gv_dct_workspace *ws, int rows, int *left,
                      uint32_t *x, int *n)
{
    const struct enc_sym *enc = ws->enc;
    uint16_t *w[LANES];
    for (int r = 0; r < rows; r++)
        w[r] = ws->words[r];
    _Static_assert(LANES == 4, "code_rows names four lanes");
    if (rows == LANES) {
        int common = left[0];
        for (int r = 1; r < LANES; r++)
            common = left[r] < common ? left[r] : common;
        /* Each row's last symbol first; the lanes in locals, so that
         * their states and pointers stay in registers. */
        const uint16_t *s0 = ws->syms[0] + left[0] - 1;
        const uint16_t *s1 = ws->syms[1] + left[1] - 1;
        const uint16_t *s2 = ws->syms[2] + left[2] - 1;
        const uint16_t *s3 = ws->syms[3] + left[3] - 1;
        uint32_t x0 = x[0], x1 = x[1], x2 = x[2], x3 = x[3];
        uint16_t *w0 = w[0], *w1 = w[1], *w2 = w[2], *w3 = w[3];
        for (int j = 0; j < common; j++) {
            x0 = put_sym(x0, &enc[s0[-j]], &w0);
            x1 = put_sym(x1, &enc[s1[-j]], &w1);
            x2 = put_sym(x2, &enc[s2[-j]], &w2);
            x3 = put_sym(x3, &enc[s3[-j]], &w3);
        }
        x[0] = x0, x[1] = x1, x[2] = x2, x[3] = x3;
        w[0] = w0, w[1] = w1, w[2] = w2, w[3] = w3;
        for (int r = 0; r < LANES; r++)
            left[r] -= common;
    }
    for (int a = 0; a < rows; a++) {
        if (!left[a])
            continue;
        int b = a + 1;
        while (b < rows && !left[b])
            b++;
        if (b < rows)
            for (; left[a] && left[b];) {
                x[a] = put_sym(x[a], &enc[ws->syms[a][--left[a]]], &w[a]);
                x[b] = put_sym(x[b], &enc[ws->syms[b][--left[b]]], &w[b]);
            }
        while (left[a])
            x[a] = put_sym(x[a], &enc[ws->syms[a][--left[a]]], &w[a]);
        /* Row b, if it still has symbols, pairs with the next. */
    }
    for (int r = 0; r < rows; r++)
        n[r] = (int)(w[r] - ws->words[r]);
}

/* The bytes of the stored models of a mask. */
static size_t mask_model_bytes(uint32_t mask)
{
    size_t bytes = 0;
    for (int m = 0; m < GV_DCT_MODELS; m++)
        if (mask >> m & 1)
            bytes += (size_t)gv_dct_model_symbols(m);
    return bytes;
}

/* Write the buffer of candidate cd (its models built, mask theirs).
 * Returns its length, or 0 past cap. */
static size_t write_buffer(struct gv_dct_workspace *ws,
                           const struct candidate *cd, int channels,
                           const int *steps, uint32_t mask, uint8_t *buf,
                           size_t cap)
{
    const struct models *md = &cd->md;
    size_t at = HEADER_BYTES + mask_model_bytes(mask);
    const size_t lengths = (at + 1) & ~(size_t)1;
    const size_t streams = lengths + LENGTHS_BYTES;
    if (streams > cap)
        return 0;
    memset(buf, 0, streams);
    buf[0] = GV_TILE_DCT;
    for (int c = 0; c < channels && c < 3; c++)
        gv_put16(buf + 2 + 2 * c, (uint16_t)steps[c]);
    gv_put32(buf + 8, mask);
    at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        if (!(mask >> m & 1))
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            buf[at++] = (uint8_t)md->cum[m][s];
    }
    for (int m = 0; m < GV_DCT_MODELS; m++)
        if (mask >> m & 1)
            for (int v = 0; v < gv_dct_model_symbols(m); v++)
                set_enc(&ws->enc[enc_at(m) + v], md->freq[m][v],
                        md->cum[m][v]);
    for (int v = 0; v < 64; v++)
        set_enc(&ws->enc[ENC_UNIFORM + v], 4, 4u * (uint32_t)v);
    at = streams;
    for (int by = 0; by < GV_DCT_BLOCKS; by += LANES) {
        const int rows = GV_DCT_BLOCKS - by < LANES ? GV_DCT_BLOCKS - by
                                                    : LANES;
        int left[LANES] = {0}, n[LANES] = {0};
        uint32_t x[LANES];
        for (int r = 0; r < rows; r++) {
            left[r] = collect_row(cd, channels, by + r, ws->syms[r]);
            x[r] = 1u << 16;     /* the initial and final state */
        }
        code_rows(ws, rows, left, x, n);
        for (int r = 0; r < rows; r++)
            if (!(at = gv_rans_put_stream(buf, lengths, by + r, at, x[r],
                                          ws->words[r], n[r], cap)))
                return 0;
    }
    return gv_rans_finish(buf, at, cap);
}

static void chroma_steps(int s0, int channels, int *steps)
{
    steps[0] = s0;
    steps[1] = steps[2] = 0;
    if (channels == 3) {
        int co = (int)lrint(s0 * 2.449), cg = 2 * s0;
        steps[1] = co > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : co;
        steps[2] = cg > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : cg;
    }
}

static pthread_once_t tables_once = PTHREAD_ONCE_INIT;
static int rdo_tails = 1;   /* GIGAVIEW_RDO_TAILS=0: off (benchmarks) */

/* The kernels: AVX2 with FMA where gv_cpu_flags() (base/cpu.h) has both,
 * else the baseline (SSE2 where the compiler targets it); the same floats
 * either way. */
static struct gv_cpu_once kernels_once = GV_CPU_ONCE_INIT;

static void dct_encode_dsp_init(unsigned flags)
{
    transform_tile = transform_tile_base;
    quantize_count = quantize_count_base;
#if GV_HAVE_X86_SIMD
    if ((flags & (GV_CPU_AVX2 | GV_CPU_FMA)) == (GV_CPU_AVX2 | GV_CPU_FMA)) {
        transform_tile = transform_tile_avx2;
        quantize_count = quantize_count_avx2;
    }
#else
    (void)flags;
#endif
}

static void init_tables(void)
{
    const char *rt = getenv("GIGAVIEW_RDO_TAILS");
    rdo_tails = !(rt && !strcmp(rt, "0"));
    init_kt();
    init_tc();
    init_tok_base();
    init_log2();
}

/* The steps of candidate i: channel 0's s_opt * step_factor[i], in
 * 1 .. GV_DCT_MAX_STEP, and the chroma steps that follow from it. */
static void candidate_steps(double s_opt, int i, int channels, int *steps)
{
    int s0 = (int)lrint(s_opt * step_factor[i]);
    s0 = s0 < 1 ? 1 : (s0 > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : s0);
    chroma_steps(s0, channels, steps);
}

/* The J of candidate i; its quantized values and models in cd. */
static double try_step(const struct gv_dct_workspace *ws,
                       struct candidate *cd, int channels, double s_opt,
                       double lambda, int i, uint32_t *mask)
{
    int steps[3];
    candidate_steps(s_opt, i, channels, steps);
    double err = quantize_count(ws, cd, channels, steps);
    size_t mb = build_models(&cd->md, mask);
    return err + lambda * 8.0 * estimate_bytes(&cd->md, mb);
}


/* Count the symbols of cd's q and eob into cd->md, as quantize_count
 * does, from the values instead of the coefficients.  Values past a
 * block's eob may be stale (truncate_tails has not cleared them yet):
 * block_slots reads up to the next multiple of 8, but they are of
 * magnitude 1 at most, so they add no escape, and their slots are not
 * counted. */
static void count_symbols(struct candidate *cd, int channels)
{
    struct models *md = &cd->md;
    memset(md->count, 0, sizeof md->count);
    uint32_t tokh[2 * TOKEN_SLOTS];
    memset(tokh, 0, sizeof tokh);
    uint64_t uniform = 0;
    for (int c = 0; c < channels; c++) {
        const int cc = c > 0;
        uint32_t *eobc = md->count[3 * cc];
        uint32_t *tokc = tokh + TOKEN_SLOTS * cc;
        for (int by = 0; by < GV_DCT_BLOCKS; by++) {
            int pe = 0, dcp = 0;
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx, n = cd->eob[c][b];
                eobc[pe * GV_DCT_EOB_SYMBOLS + n]++;
                pe = gv_dct_eob_class(n);
                if (!n) {
                    dcp = 0;
                    continue;
                }
                const int16_t *q = cd->q[c][b];
                uniform += count_block(q, n, dcp, tokc);
                dcp = gv_dct_class(q[0]);
            }
        }
    }
    tokens_to_models(md, tokh, uniform);
}

/* Bits of symbol s in model m as the candidate's models code it; a symbol
 * the models do not have yet is priced as one of frequency 1/2 in 256. */
static inline double symbol_bits(const struct models *md, int m, int s)
{
    const uint32_t f = md->total[m] ? md->freq[m][s] : 0;
    return f ? log2_table[f] : 9.0;
}

/*
 * Rate-distortion truncation of each block's coded coefficients (the
 * encoder side of RDOQ, as in x264's and HM's "trellis"-lite): a block's
 * last nonzero values often cost more bits (the zero tokens before them,
 * the value, the longer count) than the error they remove.  For every
 * block, channel by channel in stream order, the count n' is chosen
 * among n and each shorter count that ends after a nonzero value (or is
 * 0), back to the last value of magnitude 2 or more, minimizing the added
 * squared error (transform domain, weighted as quantize_count weighs it)
 * plus lambda times the bits, priced by the candidate's models with the
 * contexts of the blocks already decided.  The symbols are then counted
 * again and the models rebuilt; if the estimated J did not fall, the
 * counts stay as they were.  Fewer coded coefficients also mean fewer
 * rANS steps for every decoder.  Plain C on every CPU (the same doubles
 * in the same order), so the stores do not depend on the path.  Returns
 * the (new) model mask in *mask.
 */
static void truncate_tails(const struct gv_dct_workspace *ws,
                           struct candidate *cd, int channels,
                           const int *steps, double lambda, uint32_t *mask)
{
    struct models *md = &cd->md;
    /* Each block cut: c * NB + b, and its count before the cut. */
    static _Thread_local struct {
        uint16_t block;
        uint8_t was;
    } cut[3 * NB];
    static _Thread_local double bits[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS];
    int ncut = 0;
    for (int m = 0; m < GV_DCT_MODELS; m++)
        for (int v = 0; v < gv_dct_model_symbols(m); v++)
            bits[m][v] = symbol_bits(md, m, v);
    const double j_old = lambda * 8.0 * estimate_bytes(md, mask_model_bytes(*mask));
    double added = 0, added_at = 0;
    for (int c = 0; c < channels; c++) {
        const double s = (double)steps[c];
        const double w = (channels == 1 ? 1.0 : channel_weight[c]) / 64.0;
        const int cc = c > 0;
        const double *eob_bits = bits[3 * cc];
        const double(*tok_bits)[GV_DCT_EOB_SYMBOLS] = bits + GV_DCT_EOB_MODELS + 12 * cc;
        for (int by = 0; by < GV_DCT_BLOCKS; by++) {
            int pe = 0, dcp = 0;
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx, n = cd->eob[c][b];
                if (!n) {
                    pe = dcp = 0;
                    continue;
                }
                const int16_t *q = cd->q[c][b];
                const float *x = ws->x[c][b];
                /* From the end: the bits of the tail's tokens and the
                 * error its values remove, J(n') - J(n) at each n' that
                 * ends on a nonzero value (or is 0).  The scan stops at
                 * the first value of magnitude 2 or more, whose removal
                 * does not pay.  y is value k's token and class. */
                const double *eob_pe = eob_bits + pe * GV_DCT_EOB_SYMBOLS;
                const double eob_n = eob_pe[n];
                double tail_bits = 0, tail_err = 0, best = 0;
                int best_n = n, y = tc[q[n - 1] + 2048];
                for (int k = n - 1; k >= 0; k--) {
                    const int t = y & 15;
                    const int yp = k ? tc[q[k - 1] + 2048] : dcp << 4;
                    tail_bits += tok_bits[gv_dct_band_model[k] + (yp >> 4)][t];
                    if (t == GV_DCT_ESCAPE)
                        tail_bits += 12.0;
                    y = yp;
                    if (q[k]) {
                        if (q[k] > 1 || q[k] < -1)
                            break;
                        const double xa = fabs((double)x[k]), r = xa - s;
                        tail_err += (xa * xa - r * r) * w;
                    }
                    if (k > 0 && !q[k - 1])
                        continue;
                    const double j = tail_err + lambda * (eob_pe[k] - eob_n - tail_bits);
                    if (j < best) {
                        best = j;
                        best_n = k;
                        added_at = tail_err;
                    }
                }
                if (best_n < n) {
                    added += added_at;
                    cd->eob[c][b] = (uint8_t)best_n;
                    cut[ncut].block = (uint16_t)(c * NB + b);
                    cut[ncut++].was = (uint8_t)n;
                }
                const int m = cd->eob[c][b];
                pe = gv_dct_eob_class(m);
                dcp = m ? gv_dct_class(q[0]) : 0;
            }
        }
    }
    if (!ncut)
        return;
    struct models before = *md;
    uint32_t new_mask;
    count_symbols(cd, channels);
    const size_t mb = build_models(md, &new_mask);
    if (added + lambda * 8.0 * estimate_bytes(md, mb) < j_old) {
        /* Clear the values cut off, for the writer's block_slots, which
         * reads past the eob to a multiple of 8. */
        for (int i = 0; i < ncut; i++) {
            const int c = cut[i].block / NB, b = cut[i].block % NB;
            for (int k = cd->eob[c][b]; k < cut[i].was; k++)
                cd->q[c][b][k] = 0;
        }
        *mask = new_mask;
        return;
    }
    for (int i = 0; i < ncut; i++)
        cd->eob[cut[i].block / NB][cut[i].block % NB] = cut[i].was;
    *md = before;
}

size_t gv_dct_encode(struct gv_dct_workspace *ws, const uint8_t *orig,
                     const uint8_t *pred, int channels, uint32_t valid_w,
                     uint32_t valid_h, double lambda, uint8_t *buf,
                     size_t cap, uint8_t *recon, uint64_t *sse)
{
    pthread_once(&tables_once, init_tables);
    gv_cpu_once(&kernels_once, dct_encode_dsp_init);
    transform_tile(ws, orig, pred, channels, valid_w, valid_h);
    /* High-rate optimum for channel 0: step^2 = 6 lambda / (w ln 2) in
     * orthonormal units, 8 times that in the plane's. */
    const double w0 = channels == 1 ? 1.0 : channel_weight[0];
    const double s_opt = 8.0 * sqrt(6.0 * lambda / (w0 * LN2));
    /* Descent over quarter octaves from 2^-0.5 to 2^2.5 times the
     * high-rate optimum: from the commonest best (2^0.25), one step up,
     * then on in the direction J falls until it rises.  J is unimodal
     * apart from a plateau at the largest steps, where every block is
     * zero and the prediction alone is cheaper anyway.  3.6 candidates
     * on average instead of 9 for the half-then-quarter octave search
     * (bench/README.md, 2026-11-26 later). */
    int best = 0, cur = 1, best_i = STEP_START;
    uint32_t mask, cmask;
    double best_j = try_step(ws, &ws->cand[best], channels, s_opt, lambda,
                             STEP_START, &mask);
    for (int dir = 1, i = STEP_START + 1; i >= 0 && i < STEP_CANDIDATES;
         i += dir) {
        double j = try_step(ws, &ws->cand[cur], channels, s_opt, lambda, i,
                            &cmask);
        if (j < best_j) {
            best_j = j;
            best_i = i;
            mask = cmask;
            best = cur;
            cur = 1 - cur;
        } else if (dir > 0 && best_i == STEP_START) {
            dir = -1;       /* up did not help: try down */
            i = STEP_START;
        } else {
            break;
        }
    }
    int best_steps[3] = {0, 0, 0};
    candidate_steps(s_opt, best_i, channels, best_steps);
    if (rdo_tails)
        truncate_tails(ws, &ws->cand[best], channels, best_steps, lambda, &mask);
    size_t len = write_buffer(ws, &ws->cand[best], channels, best_steps, mask,
                              buf, cap);
    if (!len)
        return 0;
    /* What gv_dct_decode would give, from the values just coded. */
    gv_dct_rebuild((const int16_t (*)[NB][64])ws->cand[best].q,
                   (const uint8_t (*)[NB])ws->cand[best].eob, best_steps,
                   channels, pred, recon);
    *sse = gv_sse_u8(orig, recon, valid_w * (uint32_t)channels, valid_h,
                     (size_t)GV_TILE * channels);
    return len;
}
