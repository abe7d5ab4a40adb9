/*
 * tile_dct_encode_int.h - what tile_dct_encode.c (layout D's encoder)
 * shares with its AVX2 kernels (x86/tile_dct_encode_avx2.c): the
 * workspace and candidate structures, the tables filled once by
 * tile_dct_encode.c's init_tables, and the transform and quantization
 * written once and instantiated for the baseline (tile_dct_encode.c) and
 * for AVX2 (x86/), so that both give the same floats in the same order.
 * Not part of the codec's interface; tile_dct_encode.c's design comment
 * explains the arithmetic.
 */
#ifndef GV_TILE_DCT_ENCODE_INT_H
#define GV_TILE_DCT_ENCODE_INT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "base/cpu.h"
#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "codec/tile_dct.h"
#include "codec/tile_layout.h"

#define NB (GV_DCT_BLOCKS * GV_DCT_BLOCKS)
#define ROUND_OFFSET 0.36f      /* dead-zone rounding: floor(|x|/S + this) */
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
                     (GV_DCT_MODELS_D2 - GV_DCT_EOB_MODELS) * GV_DCT_TOKEN_SYMBOLS)
#define ENC_SYMBOLS (ENC_UNIFORM + 64)

struct models {
    uint32_t count[GV_DCT_MODELS_D2][GV_DCT_EOB_SYMBOLS];
    uint32_t freq[GV_DCT_MODELS_D2][GV_DCT_EOB_SYMBOLS];
    uint32_t cum[GV_DCT_MODELS_D2][GV_DCT_EOB_SYMBOLS + 1];
    uint32_t total[GV_DCT_MODELS_D2];
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

/* K transposed, as floats: gv_dct_enc_kt[i][u] = K[u][i].  For the AVX2 second
 * pass, per group g of eight coefficients in zigzag order and lane p
 * (zz = gv_dct_zigzag[8 g + p]): the column zz % 8 in gv_dct_enc_zz_col[g][p] and
 * K[zz / 8][j] in gv_dct_enc_zz_k[g][j][p]. */
extern float gv_dct_enc_kt[8][8];
extern _Alignas(32) int32_t gv_dct_enc_zz_col[8][8];
extern _Alignas(32) float gv_dct_enc_zz_k[8][8][8];

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
            s0 = _mm_add_ps(s0, _mm_mul_ps(_mm_loadu_ps(gv_dct_enc_kt[i]), ei));
            s1 = _mm_add_ps(s1, _mm_mul_ps(_mm_loadu_ps(gv_dct_enc_kt[i] + 4), ei));
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
                s[u] += gv_dct_enc_kt[i][u] * ei;
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

/* token | class << 4 of a quantized value q, at gv_dct_enc_tc[q + 2048]. */
extern uint8_t gv_dct_enc_tc[4096];

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

/* The token counts of quantize_count: the 24 token models (12 per
 * channel class, 16 symbols each), then the 2 last-value models (layout
 * D2, FORMAT.md 4.4), packed, copied into the models after. */
#define TOKEN_SLOTS (12 * GV_DCT_TOKEN_SYMBOLS)     /* one channel class */
#define TOKEN_COUNTS (2 * TOKEN_SLOTS + 2 * GV_DCT_TOKEN_SYMBOLS)
/* The first count of channel class cc's last-value model. */
#define LAST_SLOTS(cc) (2 * TOKEN_SLOTS + GV_DCT_TOKEN_SYMBOLS * (cc))

/* The slot of token k's band within its channel class's counts. */
extern _Alignas(16) uint16_t gv_dct_enc_tok_base[64];

/* The token slots of a block q (zigzag order) whose eob is n >= 1:
 * slot[k] = add + gv_dct_enc_tok_base[k] + 16 class(q[k - 1]) + token(q[k]) for
 * k < n, class(q[-1]) taken as dcp (the class of the previous block's
 * first value), as write_buffer codes them: token k's model is its
 * band's for the class of value k - 1.  Values up to n rounded up to 8
 * are written.  Returns twice the escapes (their uniform steps).  Eight
 * at a time: t = min(2 |q| - (q > 0), 15) is gv_dct_enc_tc[]'s token and
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
            _mm_load_si128((const __m128i *)(gv_dct_enc_tok_base + k)), vadd);
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
        const int y = gv_dct_enc_tc[q[k] + 2048], t = y & 15;
        slot[k] = (uint16_t)(add + gv_dct_enc_tok_base[k] + 16 * p + t);
        esc += t == GV_DCT_ESCAPE ? 2 : 0;
        p = y >> 4;
    }
    return esc;
#endif
}

/* Count the tokens of block q (eob n >= 1, dcp as block_slots) into h,
 * the counts of its channel class, but its last value's into hl, those
 * of the class's last-value model; returns its uniform steps. */
__attribute__((always_inline)) static inline uint64_t
count_block(const int16_t *q, int n, int dcp, uint32_t *h, uint32_t *hl)
{
    _Alignas(16) uint16_t slot[64];
    const int esc = block_slots(q, n, dcp, 0, slot);
    for (int k = 0; k < n - 1; k++)
        h[slot[k]]++;
    hl[gv_dct_enc_tc[q[n - 1] + 2048] & 15]++;
    return (uint64_t)esc;
}

/* The token counts of both channel classes and their last values (tokh,
 * TOKEN_COUNTS) and the uniform steps into the models' counts. */
static inline void tokens_to_models(struct models *md,
                                    const uint32_t *tokh, uint64_t uniform)
{
    for (int m = 0; m < GV_DCT_MODELS_D2 - GV_DCT_EOB_MODELS; m++)
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
    uint32_t tokh[TOKEN_COUNTS];
    memset(tokh, 0, sizeof tokh);
    uint64_t uniform = 0;
    double sse = 0;
    for (int c = 0; c < channels; c++) {
        const float inv = 1.0f / (float)steps[c], s = (float)steps[c];
        const float zero_below = (1.0f - ROUND_OFFSET) * s;
        const double w = channels == 1 ? 1.0 : channel_weight[c];
        const int cc = c > 0;
        uint32_t *eobc = md->count[3 * cc];
        uint32_t *tokc = tokh + TOKEN_SLOTS * cc, *lastc = tokh + LAST_SLOTS(cc);
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
                uniform += count_block(q, n, dc_ctx, tokc, lastc);
            }
        }
        sse += w * e2 / 64.0;
    }
    tokens_to_models(md, tokh, uniform);
    return sse;
}

#endif
