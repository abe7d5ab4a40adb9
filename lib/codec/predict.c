/*
 * predict.c - the integer cubic upsample that predicts a tile from one
 * quarter of its decoded parent, row by row (predict.h), and the residual
 * addition that follows it in the decoder.
 *
 * Child pixel u (0..512) of quadrant q sits a quarter pixel before
 * (u even) or after (u odd) parent pixel p = 256*q + u/2, the sample
 * centres of a 2x2 box-filtered pyramid.  It is interpolated with the
 * Catmull-Rom cubic at that offset, whose weights are exact in 1/128ths:
 *
 *   u even: parent p-2, p-1, p, p+1 with weights -3, 29, 111, -9
 *   u odd:  parent p-1, p, p+1, p+2 with weights -9, 111, 29, -3
 *
 * Parent indices are clamped to the parent tile [0,512], so no neighbour
 * tile is ever needed.  Rows are done the same way, and the 2-D result is
 * the product of the two, with a single rounding and a clamp:
 *
 *   s    = sum_j wy[j] * sum_i wx[i] * P[row_j][col_i]     (exact integer)
 *   pred = clamp(s + 8192, 0, 255*16384 + 16383) >> 14
 *
 * Compared with the bilinear (3,1)/4 kernel this lowered the bits needed
 * for the same PSNR by 5 to 10 % on the benchmark photographs (FORMAT.md,
 * section 3).  The GLSL decoders compute the same expression;
 * docs/FORMAT.md is normative.
 *
 * How it is made fast, with the same integers:
 * - Separable: the horizontal sums h of each parent row are computed once
 *   (a ring of rows, since child rows walk the parent downwards), and each
 *   child row is the vertical 4-tap sum of four of them.
 * - 16 bits: h lies in [-12*255, 140*255], so h - 16384 fits in a signed
 *   16-bit integer; the rows are kept that way (half the memory traffic),
 *   and as the vertical weights sum to 128 the offset comes back as the
 *   constant 128*16384 in the 32-bit vertical sum.
 * - No clamping inside the loops: the even and odd children are two
 *   straight 4-tap filters over the parent row, and only the two children
 *   at the tile's edge whose taps leave it are done apart, clamped.
 * - The vertical sum, where the CPU has AVX2, reads successive parent
 *   rows' sums interleaved in pairs (h[t], h[t+1]), each pair made once and
 *   kept in a ring, since it serves four child rows: a child row is two
 *   VPMADDWD per 16 samples (VPDPWSSD per 32 on level 3) and no
 *   unpacking; the clamp is done by the saturating packs, which equals
 *   clamping before the shift since the shift is a floor.  Elsewhere a
 *   plain C loop over four rows, which the compiler vectorizes.  The
 *   residual addition uses AVX2's saturating byte arithmetic.
 * - Where the CPU also has AVX-512 VBMI and VNNI (level 3; Ice Lake, Zen 4
 *   and later), the horizontal sums go straight into the interleaved
 *   child order (VPERMB gathers each sample's four parent bytes,
 *   VPMADDUBSW weighs them in pairs).
 * - On AVX2 alone (level 1) the even and odd children's sums are
 *   interleaved by PSHUFB, four pixel pairs a step.
 * Measured (bench/README.md, 2026-11-26): level 3 1.5 to 1.7 times the
 * prediction's speed of the earlier AVX-512BW path; level 2 1.17 times
 * its own, level 1 1.22 to 1.24 times.
 *
 * The levels are picked from gv_cpu_flags() (base/cpu.h) into one table,
 * predict_dsp, filled by predict_dsp_init: level 3 where the flags have
 * AVX-512 with VBMI and VNNI, level 2 with AVX-512 alone, level 1 with
 * AVX2, else level 0 (the portable C).  The plain C loops are also
 * compiled for AVX2 and for AVX-512 (target attributes) and take the
 * table's place at those levels.
 */
#include <pthread.h>
#include <stddef.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/tile.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#endif

static const int W_EVEN[4] = {-3, 29, 111, -9};  /* taps at p-2 .. p+1 */
static const int W_ODD[4] = {-9, 111, 29, -3};   /* taps at p-1 .. p+2 */

/* h - OFFSET fits in int16_t; sum(w) * OFFSET returns in the vertical sum. */
#define OFFSET 16384
#define ROUND (8192 + 128 * OFFSET)
#define SUM_MAX (255 * 16384 + 16383)

static inline int clamp_tile(int i)
{
    return i < 0 ? 0 : (i > GV_TILE - 1 ? GV_TILE - 1 : i);
}

/* First tap of child coordinate u in quadrant q. */
static inline int first_tap(int q, int u)
{
    int p = 256 * q + (u >> 1);
    return (u & 1) ? p - 1 : p - 2;
}

/* The plain C loops are written once, always inlined, and instantiated
 * per instruction set (C_LOOPS below); the integers are the same on every
 * path. */
#define HOT_LOOP __attribute__((always_inline)) static inline
#if GV_HAVE_X86_SIMD
#define TARGET_AVX2 __attribute__((target("avx2")))
#define TARGET_AVX512 __attribute__((target("avx2,avx512f,avx512bw")))
#endif

/* Even and odd horizontal sums (minus OFFSET) of children k0 <= k < k1,
 * whose taps all lie inside the row: parent pixels p0 + k - k0 onwards,
 * p0 = 256*qx - 2 + k0.  Exact in wrapping 16-bit arithmetic because the
 * true value fits. */
HOT_LOOP void filter_interior(const uint8_t *restrict src, int C,
                                     uint16_t *restrict even,
                                     uint16_t *restrict odd, int n)
{
    const uint8_t *s0 = src, *s1 = src + C, *s2 = src + 2 * C,
                  *s3 = src + 3 * C, *s4 = src + 4 * C;
    for (int i = 0; i < n; i++) {
        even[i] = (uint16_t)(W_EVEN[0] * s0[i] + W_EVEN[1] * s1[i] +
                             W_EVEN[2] * s2[i] + W_EVEN[3] * s3[i] - OFFSET);
        odd[i] = (uint16_t)(W_ODD[0] * s1[i] + W_ODD[1] * s2[i] +
                            W_ODD[2] * s3[i] + W_ODD[3] * s4[i] - OFFSET);
    }
}

/* The same for one child k near the tile's edge, every tap clamped. */
static void filter_edge(const uint8_t *src, int C, int base, int k,
                        uint16_t *even, uint16_t *odd)
{
    for (int c = 0; c < C; c++) {
        int e = 0, o = 0;
        for (int j = 0; j < 4; j++) {
            e += W_EVEN[j] * src[clamp_tile(base + k + j) * C + c];
            o += W_ODD[j] * src[clamp_tile(base + k + 1 + j) * C + c];
        }
        even[k * C + c] = (uint16_t)(e - OFFSET);
        odd[k * C + c] = (uint16_t)(o - OFFSET);
    }
}

#if GV_HAVE_X86_SIMD
/* Interleave three-sample pixels: dst = even pixel 0, odd pixel 0, even
 * pixel 1, ... for 256 pairs, then even pixel 256.  Eight pairs (48
 * samples) per step, as two-source word permutes; the loads read up to 8
 * samples past the 24 they use (the arrays have room). */
__attribute__((target("avx512bw"))) static void
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
#endif

#if GV_HAVE_X86_SIMD
/*
 * The horizontal sums of one parent row straight into the interleaved
 * child order, 32 at a time, with AVX-512 VBMI: child u (of the interior,
 * whose taps all lie in the row) reads parent pixels a(u) .. a(u) + 3,
 * a(u) = base + (u + 1) / 2, so output sample j = u * C + c needs four
 * bytes of the row.  VPERMB gathers the first two of each sample's bytes
 * into adjacent pairs and the last two into another vector, from one
 * 64-byte load; VPMADDUBSW multiplies each pair by its weights (unsigned
 * pixels, signed weights) and adds them.  No pair can saturate: the
 * largest is 255 * 111 = 28305 and the smallest 255 * -9.  The two pair
 * sums and -OFFSET are added in wrapping 16-bit arithmetic, exact since
 * the true value fits (as in filter_interior).  The pattern of indices
 * and weights repeats every lcm(32, 2C) samples: once per vector for one
 * channel, every three vectors for three.
 */
struct vbmi_tables {
    int vectors;                 /* 1 (C = 1) or 3 (C = 3) per period */
    int period_bytes;            /* how far the row advances per period
                                    (32 * vectors samples: 16 * vectors / C
                                    pixels) */
    int load_at[3];              /* each vector's load, from the period's */
    uint8_t idx_a[3][64], idx_b[3][64];
    int8_t w_a[3][64], w_b[3][64];
};

static struct vbmi_tables vbmi_tables[2];   /* [C == 3] */

static void vbmi_tables_init(struct vbmi_tables *t, int C)
{
    t->vectors = C == 1 ? 1 : 3;
    t->period_bytes = (32 * t->vectors / (2 * C)) * C;
    for (int m = 0; m < t->vectors; m++) {
        int lo = 1 << 30;
        for (int i = 0; i < 32; i++) {
            const int j = 32 * m + i, d = j / C, c = j % C;
            const int b = ((d + 1) >> 1) * C + c;
            lo = b < lo ? b : lo;
        }
        t->load_at[m] = lo;
        for (int i = 0; i < 32; i++) {
            const int j = 32 * m + i, d = j / C, c = j % C;
            const int b = ((d + 1) >> 1) * C + c - lo;
            const int *w = (d & 1) ? W_ODD : W_EVEN;
            t->idx_a[m][2 * i] = (uint8_t)b;
            t->idx_a[m][2 * i + 1] = (uint8_t)(b + C);
            t->idx_b[m][2 * i] = (uint8_t)(b + 2 * C);
            t->idx_b[m][2 * i + 1] = (uint8_t)(b + 3 * C);
            t->w_a[m][2 * i] = (int8_t)w[0];
            t->w_a[m][2 * i + 1] = (int8_t)w[1];
            t->w_b[m][2 * i] = (int8_t)w[2];
            t->w_b[m][2 * i + 1] = (int8_t)w[3];
        }
    }
}

static pthread_once_t vbmi_once = PTHREAD_ONCE_INIT;

static void vbmi_init(void)
{
    vbmi_tables_init(&vbmi_tables[0], 1);
    vbmi_tables_init(&vbmi_tables[1], 3);
}

/* One vector of 32 sums from the 64 bytes at p (x, already loaded). */
#define VBMI_SUMS(x, m)                                                      \
    _mm512_add_epi16(                                                        \
        _mm512_add_epi16(                                                    \
            _mm512_maddubs_epi16(_mm512_permutexvar_epi8(ia[m], x), wa[m]),  \
            _mm512_maddubs_epi16(_mm512_permutexvar_epi8(ib[m], x), wb[m])), \
        off)

/* Children u0 .. u0 + n - 1 (u0 even, every tap inside the row) of the
 * row src (end: one past its last byte) into dst[u0 * C ...]; a(u0) =
 * first.  Whole periods whose loads lie in the row go unmasked; the rest
 * is loaded masked at the row's end and stored masked at n * C samples,
 * so nothing outside the row or the children is touched. */
__attribute__((target("avx512bw,avx512vbmi"))) static void
filter_vbmi(const uint8_t *row, const uint8_t *end, int C, int first,
            int u0, int n, int16_t *dst)
{
    const struct vbmi_tables *t = &vbmi_tables[C == 3];
    const uint8_t *src = row + (size_t)first * C;
    int16_t *out = dst + (size_t)u0 * C;
    const int total = n * C, V = t->vectors;
    const __m512i off = _mm512_set1_epi16(-OFFSET);
    __m512i ia[3], ib[3], wa[3], wb[3];
    for (int m = 0; m < V; m++) {
        ia[m] = _mm512_loadu_si512((const void *)t->idx_a[m]);
        ib[m] = _mm512_loadu_si512((const void *)t->idx_b[m]);
        wa[m] = _mm512_loadu_si512((const void *)t->w_a[m]);
        wb[m] = _mm512_loadu_si512((const void *)t->w_b[m]);
    }
    int j = 0;
    if (V == 3) {
        const int o0 = t->load_at[0], o1 = t->load_at[1], o2 = t->load_at[2];
        for (; j + 96 <= total && src + o2 + 64 <= end; j += 96) {
            const __m512i x0 = _mm512_loadu_si512((const void *)(src + o0));
            const __m512i x1 = _mm512_loadu_si512((const void *)(src + o1));
            const __m512i x2 = _mm512_loadu_si512((const void *)(src + o2));
            _mm512_storeu_si512((void *)(out + j), VBMI_SUMS(x0, 0));
            _mm512_storeu_si512((void *)(out + j + 32), VBMI_SUMS(x1, 1));
            _mm512_storeu_si512((void *)(out + j + 64), VBMI_SUMS(x2, 2));
            src += t->period_bytes;
        }
    } else {
        const int o0 = t->load_at[0];
        for (; j + 32 <= total && src + o0 + 64 <= end; j += 32) {
            const __m512i x0 = _mm512_loadu_si512((const void *)(src + o0));
            _mm512_storeu_si512((void *)(out + j), VBMI_SUMS(x0, 0));
            src += t->period_bytes;
        }
    }
    for (int m = 0; j < total; j += 32) {
        const uint8_t *p = src + t->load_at[m];
        const ptrdiff_t avail = end - p;
        const __mmask64 lm = avail >= 64 ? ~(__mmask64)0
                                         : (((__mmask64)1 << avail) - 1);
        const __m512i x = _mm512_maskz_loadu_epi8(lm, p);
        const int left = total - j;
        const __mmask32 sm = left >= 32 ? ~(__mmask32)0
                                        : (((__mmask32)1 << left) - 1);
        _mm512_mask_storeu_epi16(out + j, sm, VBMI_SUMS(x, m));
        if (++m == V) {
            m = 0;
            src += t->period_bytes;
        }
    }
}
#undef VBMI_SUMS

/* filter_row by filter_vbmi: the children whose taps lie inside the row
 * straight from it (4 .. 512 for qx = 0, 0 .. 509 for qx = 1), and the
 * few at the tile's edge from a copy of the pixels they read, clamped to
 * the row (zero past them, for whole loads), so that every child is the
 * same straight filter. */
static void filter_row_vbmi(const uint8_t *src, int C, int qx, int16_t *dst)
{
    pthread_once(&vbmi_once, vbmi_init);
    const int base = 256 * qx - 2;
    const int u0 = qx ? 0 : 4, u1 = qx ? 510 : GV_TILE;   /* interior [u0, u1) */
    filter_vbmi(src, src + (size_t)GV_TILE * C, C, base + (u0 >> 1), u0,
                u1 - u0, dst);
    /* The edge children e0 .. e0 + n - 1 (e0 even) read pixels a(e0)
     * onwards, at most 6 of them. */
    const int e0 = qx ? u1 : 0, n = qx ? GV_TILE - u1 : u0;
    const int first = base + ((e0 + 1) >> 1);
    uint8_t buf[64] = {0};
    for (int i = 0; i < 6; i++)
        for (int c = 0; c < C; c++)
            buf[i * C + c] = src[clamp_tile(first + i) * C + c];
    filter_vbmi(buf, buf + sizeof buf, C, 0, e0, n, dst);
}
#endif

#if GV_HAVE_X86_SIMD
/* interleave3_avx512 with PSHUFB on 128-bit vectors (level 1): four pairs
 * (24 samples, 48 bytes) a step from two overlapping loads of each of
 * even[] and odd[] (samples 0-7 and 4-11 of the four pixels), each output
 * vector the OR of two shuffles; the loads read up to the 12 samples they
 * use. */
__attribute__((target("avx2"))) static void
interleave3_ssse3(const uint16_t *even, const uint16_t *odd, int16_t *dst)
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
#endif

/*
 * Horizontal sums (minus OFFSET) of one parent row for every child column
 * u = 0..512 of quadrant qx, interleaved as dst[u * C + c].  Child 2k
 * ("even") reads parent pixels base+k .. base+k+3 and child 2k+1 ("odd")
 * base+k+1 .. base+k+4, base = 256*qx - 2: only children 0 and 1 (qx = 0)
 * or 255 and 256 (qx = 1) reach outside the tile and are clamped; the
 * rest is a straight filter over the row.
 */
typedef void interior_fn(const uint8_t *restrict, int, uint16_t *restrict,
                         uint16_t *restrict, int);
typedef void interleave3_fn(const uint16_t *, const uint16_t *, int16_t *);

static void interleave3_c(const uint16_t *even, const uint16_t *odd, int16_t *dst)
{
    /* Three samples per pixel: copies of four, each spare sample
     * overwritten by the next copy (even[] and odd[] have spare room). */
    for (int k = 0; k < 256; k++) {
        memcpy(dst + 6 * k, even + 3 * k, 4 * sizeof *dst);
        memcpy(dst + 6 * k + 3, odd + 3 * k, 4 * sizeof *dst);
    }
    memcpy(dst + 6 * 256, even + 3 * 256, 3 * sizeof *dst);
}

__attribute__((always_inline)) static inline void
filter_row(const uint8_t *src, int C, int qx, int16_t *dst,
           interior_fn *interior, interleave3_fn *interleave3)
{
    uint16_t even[257 * 3 + 16], odd[257 * 3 + 16];   /* spare for wide loads */
    const int base = 256 * qx - 2;
    const int k0 = qx ? 0 : 2, k1 = qx ? 255 : 257;   /* interior [k0, k1) */
    interior(src + (size_t)(base + k0) * C, C, even + k0 * C, odd + k0 * C,
             (k1 - k0) * C);
    for (int k = 0; k < k0; k++)
        filter_edge(src, C, base, k, even, odd);
    for (int k = k1; k < 257; k++)
        filter_edge(src, C, base, k, even, odd);
    /* Interleave: child 2k from even[k], 2k+1 from odd[k]. */
    if (C == 1) {
        for (int k = 0; k < 256; k++) {
            dst[2 * k] = (int16_t)even[k];
            dst[2 * k + 1] = (int16_t)odd[k];
        }
        dst[512] = (int16_t)even[256];
        return;
    }
    interleave3(even, odd, dst);
}

/* One child row from the four filtered parent rows it reads (portable). */
HOT_LOOP void vertical_c(const int16_t *restrict h0,
                                const int16_t *restrict h1,
                                const int16_t *restrict h2,
                                const int16_t *restrict h3, const int *w,
                                size_t n, uint8_t *restrict out)
{
    const int32_t w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3];
    for (size_t i = 0; i < n; i++) {
        int32_t s = w0 * h0[i] + w1 * h1[i] + w2 * h2[i] + w3 * h3[i] + ROUND;
        s = s < 0 ? 0 : s;
        s = s > SUM_MAX ? SUM_MAX : s;
        out[i] = (uint8_t)(s >> 14);
    }
}

#if GV_HAVE_X86_SIMD
/* Weights w[k] and w[k + 1] as a VPMADDWD operand: two 16-bit values in a
 * 32-bit lane, w[k] in the low half. */
static inline int32_t weight_pair(const int *w, int k)
{
    return (int32_t)((uint32_t)(uint16_t)w[k] | (uint32_t)(uint16_t)w[k + 1] << 16);
}

#endif

#if GV_HAVE_X86_SIMD
/*
 * The vertical sum on pairs of rows (level 3).  A child row is
 * w0 h[t] + w1 h[t+1] + w2 h[t+2] + w3 h[t+3], rows clamped to the tile;
 * the pairs (h[t], h[t+1]) and (h[t+2], h[t+3]) are interleaved once into
 * 16-bit pairs (as VPUNPCKLWD / VPUNPCKHWD would, 32 samples of each row
 * per 64 values) and kept, since each serves four child rows, so a child
 * row takes two loads and two VPMADDWD per 32 samples and no unpacking.
 */
__attribute__((target("avx512bw"))) static void
interleave_pair(const int16_t *a, const int16_t *b, size_t n, int16_t *dst)
{
    /* Whole groups of 64 samples (the padding zero), as vertical_pairs
     * reads them. */
    const size_t groups = (n + 63) / 64;
    for (size_t i = 0, c = 0; c < 2 * groups; i += 32, c++) {
        const size_t left = i < n ? n - i : 0;
        const __mmask32 m = left >= 32 ? ~(__mmask32)0
                                       : (((__mmask32)1 << left) - 1);
        const __m512i x = _mm512_maskz_loadu_epi16(m, a + i);
        const __m512i y = _mm512_maskz_loadu_epi16(m, b + i);
        _mm512_store_si512((void *)(dst + 64 * c), _mm512_unpacklo_epi16(x, y));
        _mm512_store_si512((void *)(dst + 64 * c + 32), _mm512_unpackhi_epi16(x, y));
    }
}

/* 32 samples (chunk c) of a child row from its two pairs, as 16-bit
 * values before the final pack (the order within 128-bit lanes that
 * VPACKSSDW restores). */
__attribute__((target("avx512bw,avx512vnni"), always_inline)) static inline __m512i
vertical_pairs32(const int16_t *p0, const int16_t *p1, size_t c, __m512i w01,
                 __m512i w23, __m512i rnd)
{
    const int16_t *a = p0 + 64 * c, *b = p1 + 64 * c;
    /* VPDPWSSD: the rounding constant plus both pairs' products, exact
     * (no saturation), as VPMADDWD and two adds would give. */
    __m512i lo = _mm512_dpwssd_epi32(
        _mm512_dpwssd_epi32(rnd, _mm512_load_si512((const void *)a), w01),
        _mm512_load_si512((const void *)b), w23);
    __m512i hi = _mm512_dpwssd_epi32(
        _mm512_dpwssd_epi32(rnd, _mm512_load_si512((const void *)(a + 32)), w01),
        _mm512_load_si512((const void *)(b + 32)), w23);
    lo = _mm512_srai_epi32(lo, 14);
    hi = _mm512_srai_epi32(hi, 14);
    return _mm512_packs_epi32(lo, hi);
}

/* The child row of n samples from pairs p0 (w0, w1) and p1 (w2, w3), 64
 * samples at a time; the last, partial group through a buffer (the pair
 * rows are padded to whole groups). */
__attribute__((target("avx512bw,avx512vnni"))) static void
vertical_pairs(const int16_t *p0, const int16_t *p1, const int *w, size_t n,
               uint8_t *out)
{
    const __m512i w01 = _mm512_set1_epi32(weight_pair(w, 0));
    const __m512i w23 = _mm512_set1_epi32(weight_pair(w, 2));
    const __m512i rnd = _mm512_set1_epi32(ROUND);
    const __m512i order = _mm512_set_epi64(7, 5, 3, 1, 6, 4, 2, 0);
    size_t i = 0, c = 0;
    for (; i < n; i += 64, c += 2) {
        const __m512i a = vertical_pairs32(p0, p1, c, w01, w23, rnd);
        const __m512i b = vertical_pairs32(p0, p1, c + 1, w01, w23, rnd);
        const __m512i v = _mm512_permutexvar_epi64(order, _mm512_packus_epi16(a, b));
        if (i + 64 <= n) {
            _mm512_storeu_si512((void *)(out + i), v);
        } else {
            const __mmask64 m = ((__mmask64)1 << (n - i)) - 1;
            _mm512_mask_storeu_epi8(out + i, m, v);
        }
    }
}
/* The same pairs for AVX2 (level 1): 16 samples of each row per 32
 * values, as VPUNPCKLWD / VPUNPCKHWD give them; whole groups of 32
 * samples, the padding zero. */
__attribute__((target("avx2"))) static void
interleave_pair_avx2(const int16_t *a, const int16_t *b, size_t n, int16_t *dst)
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
__attribute__((target("avx2"), always_inline)) static inline __m256i
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

/* vertical_pairs with AVX2, 32 samples at a time. */
__attribute__((target("avx2"))) static void
vertical_pairs_avx2(const int16_t *p0, const int16_t *p1, const int *w,
                    size_t n, uint8_t *out)
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
#endif

/* The kernels of this mask (predict_dsp_init, below). */
static struct {
    /* one parent row's horizontal sums, in child order */
    void (*filter_row)(const uint8_t *src, int C, int qx, int16_t *dst);
    /* a child row from two interleaved pairs of rows of sums (levels 1
     * to 3; NULL at level 0: vertical_c on four rows) */
    void (*interleave_pair)(const int16_t *a, const int16_t *b, size_t n,
                            int16_t *dst);
    void (*vertical_pairs)(const int16_t *p0, const int16_t *p1,
                           const int *w, size_t n, uint8_t *out);
    /* the residual's clamped addition */
    void (*add_clamped)(uint8_t *row, const int8_t *res, size_t n);
} dsp;
static struct gv_cpu_once dsp_once = GV_CPU_ONCE_INIT;
static void predict_dsp_init(unsigned flags);

/* The horizontal sums of parent row pr (clamped to the tile), from the
 * ring or filtered into it. */
static const int16_t *ring_row(struct gv_predictor *p, int pr)
{
    pr = clamp_tile(pr);
    const int slot = pr % GV_PREDICT_RING;
    if (p->tag[slot] != pr) {
        dsp.filter_row(p->parent + (size_t)pr * GV_TILE * p->channels,
                       p->channels, p->qx, p->ring[slot]);
        p->tag[slot] = pr;
    }
    return p->ring[slot];
}

void gv_predictor_init(struct gv_predictor *p, const uint8_t *parent,
                       int channels, int qx, int qy)
{
    gv_cpu_once(&dsp_once, predict_dsp_init);
    p->parent = parent;
    p->channels = channels;
    p->qx = qx;
    p->qy = qy;
    for (int k = 0; k < GV_PREDICT_RING; k++)
        p->tag[k] = p->pair_tag[k] = -1000;
}

#if GV_HAVE_X86_SIMD
/* The pair of ring rows t, t + 1 (clamped), interleaved (level 3). */
static const int16_t *pair_row(struct gv_predictor *p, int t)
{
    const int slot = (t + 2 * GV_PREDICT_RING) % GV_PREDICT_RING;
    if (p->pair_tag[slot] != t) {
        const int16_t *a = ring_row(p, t), *b = ring_row(p, t + 1);
        const size_t n = (size_t)GV_TILE * p->channels;
        dsp.interleave_pair(a, b, n, p->pair[slot]);
        p->pair_tag[slot] = t;
    }
    return p->pair[slot];
}
#endif

void gv_predictor_row(struct gv_predictor *p, int v, uint8_t *row)
{
    const int C = p->channels;
    const int *w = (v & 1) ? W_ODD : W_EVEN;
    const int t = first_tap(p->qy, v);
    const size_t n = (size_t)GV_TILE * C;
#if GV_HAVE_X86_SIMD
    if (dsp.vertical_pairs) {
        const int16_t *p0 = pair_row(p, t), *p1 = pair_row(p, t + 2);
        dsp.vertical_pairs(p0, p1, w, n, row);
        return;
    }
#endif
    const int16_t *h[4];
    for (int k = 0; k < 4; k++)
        h[k] = ring_row(p, t + k);
    vertical_c(h[0], h[1], h[2], h[3], w, n, row);
}

void gv_predict(const uint8_t *parent, int channels, int qx, int qy,
                uint8_t *pred)
{
    struct gv_predictor p;
    gv_predictor_init(&p, parent, channels, qx, qy);
    const size_t row = (size_t)GV_TILE * channels;
    for (int v = 0; v < GV_TILE; v++)
        gv_predictor_row(&p, v, pred + (size_t)v * row);
}

/* row[i] = clamp(row[i] + res[i], 0, 255). */
HOT_LOOP void add_clamped_c(uint8_t *restrict row,
                                   const int8_t *restrict res, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        int v = row[i] + res[i];
        row[i] = (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
    }
}

#if GV_HAVE_X86_SIMD
/* The same with unsigned saturating byte arithmetic: add max(res, 0),
 * then subtract max(-res, 0) (computed as max(res, 0) - res, which is
 * 128 for -128); at most one of the two is non-zero. */
__attribute__((target("avx2"))) static void
add_clamped_avx2(uint8_t *row, const int8_t *res, size_t n)
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

/* ---------------------------------------------------------- the table */

/* filter_interior per instruction set. */
#define INTERIOR(isa, attr)                                                  \
    attr static void filter_interior_##isa(const uint8_t *restrict src,     \
                                           int C, uint16_t *restrict even,  \
                                           uint16_t *restrict odd, int n)   \
    {                                                                        \
        filter_interior(src, C, even, odd, n);                               \
    }

INTERIOR(c, )
static void filter_row_c(const uint8_t *src, int C, int qx, int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_c, interleave3_c);
}

static void add_clamped_portable(uint8_t *row, const int8_t *res, size_t n)
{
    add_clamped_c(row, res, n);
}

#if GV_HAVE_X86_SIMD
INTERIOR(avx2, TARGET_AVX2)
INTERIOR(avx512, TARGET_AVX512)
static void filter_row_avx2(const uint8_t *src, int C, int qx, int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_avx2, interleave3_ssse3);
}
static void filter_row_avx512(const uint8_t *src, int C, int qx, int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_avx512, interleave3_avx512);
}
#endif

static void predict_dsp_init(unsigned flags)
{
    dsp.filter_row = filter_row_c;
    dsp.interleave_pair = NULL;
    dsp.vertical_pairs = NULL;
    dsp.add_clamped = add_clamped_portable;
#if GV_HAVE_X86_SIMD
    const unsigned l3 = GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI;
    if (!(flags & GV_CPU_AVX2))
        return;
    dsp.filter_row = filter_row_avx2;                 /* level 1 */
    dsp.interleave_pair = interleave_pair_avx2;
    dsp.vertical_pairs = vertical_pairs_avx2;
    dsp.add_clamped = add_clamped_avx2;
    if (flags & GV_CPU_AVX512)                        /* level 2 */
        dsp.filter_row = filter_row_avx512;
    if ((flags & l3) == l3) {                         /* level 3 */
        dsp.filter_row = filter_row_vbmi;
        dsp.interleave_pair = interleave_pair;
        dsp.vertical_pairs = vertical_pairs;
    }
#else
    (void)flags;
#endif
}
#endif

void gv_add_residual_row(uint8_t *row, const int8_t *book,
                         const uint16_t *ids, int channels, int half)
{
    /* The residual row, gathered from the codevectors (the last block's
     * second pixel lands in the spare bytes and is not added). */
    int8_t buf[2 + GV_BLOCKS * 6 + 2], *res = buf + 2;
    if (channels == 3 && half == 0) {
        /* Bytes 0..7 of each codevector: its 6 and 2 spare, which the next
         * block's copy overwrites. */
        for (int bx = 0; bx < GV_BLOCKS; bx++)
            memcpy(res + 6 * bx, book + (size_t)ids[bx] * 12, 8);
    } else if (channels == 3) {
        /* Bytes 4..11 (2 spare, then its 6) placed 2 early, last block
         * first, so each spare lands where an earlier block writes next;
         * no copy reads past its codevector. */
        for (int bx = GV_BLOCKS - 1; bx >= 0; bx--)
            memcpy(res + 6 * bx - 2, book + (size_t)ids[bx] * 12 + 4, 8);
    } else {
        const int8_t *b = book + 2 * half;
        for (int bx = 0; bx < GV_BLOCKS; bx++)
            memcpy(res + 2 * bx, b + (size_t)ids[bx] * 4, 2);
    }
    gv_cpu_once(&dsp_once, predict_dsp_init);
    dsp.add_clamped(row, res, (size_t)GV_TILE * channels);
}
