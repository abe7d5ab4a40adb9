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
 * AVX2, else level 0 (the portable C).  The kernels live in x86/, one
 * file per instruction set compiled with its own flags: predict_avx2.c
 * (level 1 and the residual addition), predict_avx512.c (level 2's
 * horizontal sums) and predict_avx512icl.c (level 3); the plain C loops
 * they share with this file are written once in predict_int.h.
 */
#include <stddef.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/predict_int.h"
#include "codec/tile.h"
#include "codec/x86/predict_avx2.h"
#include "codec/x86/predict_avx512.h"
#include "codec/x86/predict_avx512icl.h"

/* First tap of child coordinate u in quadrant q. */
static inline int first_tap(int q, int u)
{
    int p = 256 * q + (u >> 1);
    return (u & 1) ? p - 1 : p - 2;
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

/* ---------------------------------------------------------- the table */

/* The portable C: predict_int.h's loops compiled for the baseline. */
static void filter_interior_c(const uint8_t *restrict src, int C,
                              uint16_t *restrict even,
                              uint16_t *restrict odd, int n)
{
    filter_interior(src, C, even, odd, n);
}

static void filter_row_c(const uint8_t *src, int C, int qx, int16_t *dst)
{
    filter_row(src, C, qx, dst, filter_interior_c, interleave3_c);
}

static void add_clamped_portable(uint8_t *row, const int8_t *res, size_t n)
{
    add_clamped_c(row, res, n);
}

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
    dsp.filter_row = gv_predict_filter_row_avx2;            /* level 1 */
    dsp.interleave_pair = gv_predict_interleave_pair_avx2;
    dsp.vertical_pairs = gv_predict_vertical_pairs_avx2;
    dsp.add_clamped = gv_predict_add_clamped_avx2;
    if (flags & GV_CPU_AVX512)                              /* level 2 */
        dsp.filter_row = gv_predict_filter_row_avx512;
    if ((flags & l3) == l3) {                               /* level 3 */
        dsp.filter_row = gv_predict_filter_row_vbmi;
        dsp.interleave_pair = gv_predict_interleave_pair_avx512;
        dsp.vertical_pairs = gv_predict_vertical_pairs_vnni;
    }
#else
    (void)flags;
#endif
}

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
