/*
 * lambda_model.c - reverse water filling over level 0's 2x2 blocks (see
 * lambda_model.h).
 *
 * A block's detail is kept as the integer V = sum over its channels and
 * its 4 pixels of (16 x - p)^2, p = 9 a + 3 b + 3 c + d the bilinear 2x
 * upsampling of the level-1 means (a the block's own, b and c its
 * horizontal and vertical neighbours on the pixel's side, d the
 * diagonal one, the edge repeated): 256 times the squared error of that
 * prediction, so V / (1024 C) is the detail per sample.  Bins are 8 per octave of V + 1, by integer
 * arithmetic.  D(theta) sums the exact detail of the bins wholly under
 * the water and theta for the blocks of the bins wholly above; the bin
 * that straddles it counts min(its mean detail, theta) per block.  The
 * split of RGB rows into even and odd pixels runs in SSSE3 where
 * gv_cpu_flags() (base/cpu.h) has it (x86/lambda_split_ssse3.c), picked
 * once into split_rgb.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/tile.h"
#include "encode/lambda_model.h"
#include "encode/x86/lambda_split_ssse3.h"
#include "store/geometry.h"

/* lambda = K * 2 ln 2 * theta, and the parent's share: chosen together
 * on eight photographs at -q 32 to 44 and on the 58 MP relief of the
 * bench (docs/FORMAT.md section 8).  A share of 1/2 fitted the photos
 * best at 40 dB and up, but left smooth images with no bits at all well
 * short of the target (the relief: 31 dB for 38). */
#define LM_K 1.5
#define LM_K_DCT 4.3     /* with layout D allowed: at -q 40, Picos de Europa
                         * 40.28 dB and Dragonfly 40.49 dB (9: 37.90 and
                         * 39.32); 4.5 until the encoder cut blocks short
                         * (tile_dct_encode.c, truncate_tails), which
                         * lowered the landing by 0.17 dB on average */
#define LM_ALPHA 0.75   /* share of a parent's error its children inherit */
#define LM_FLOOR 64.0   /* lambda >= gv_rd_lambda(target) / LM_FLOOR */
#define LM_CEIL 64.0    /* lambda <= K * gv_rd_lambda(target) * LM_CEIL: where
                         * the model says the prediction alone reaches the
                         * target (theta saturates), a first guess the
                         * lambda trial can leave in two steps */

#define V_PER_SAMPLE 1024.0   /* V / (this x C): detail per sample */

int gv_lambda_model_init(struct gv_lambda_model *m, uint32_t width,
                         int channels)
{
    memset(m, 0, sizeof *m);
    m->channels = channels;
    m->width = width;
    /* 4 bytes to spare past the split rows (gv_lambda_split_rgb_ssse3). */
    const size_t hb = (size_t)(width / 2) * channels + 4;
    const size_t mb = (size_t)((width + 1) / 2 + 2) * channels;
    for (int i = 0; i < 2; i++)
        if (!(m->even[i] = malloc(hb)) || !(m->odd[i] = malloc(hb)))
            return -1;
    for (int i = 0; i < 3; i++)
        if (!(m->mean[i] = malloc(mb)))
            return -1;
    if (!(m->detail = malloc(hb * sizeof *m->detail)))
        return -1;
    return 0;
}

void gv_lambda_model_free(struct gv_lambda_model *m)
{
    for (int i = 0; i < 2; i++) {
        free(m->even[i]);
        free(m->odd[i]);
        m->even[i] = m->odd[i] = NULL;
    }
    for (int i = 0; i < 3; i++) {
        free(m->mean[i]);
        m->mean[i] = NULL;
    }
    free(m->detail);
    m->detail = NULL;
    free(m->t_count);
    free(m->t_sum);
    m->t_count = NULL;
    m->t_sum = NULL;
}

int gv_lambda_model_set_tiles(struct gv_lambda_model *m, uint32_t tiles_x,
                              uint32_t tiles_y)
{
    const size_t n = (size_t)tiles_x * tiles_y * GV_LM_TBINS;
    free(m->t_count);
    free(m->t_sum);
    m->t_count = calloc(n ? n : 1, sizeof *m->t_count);
    m->t_sum = calloc(n ? n : 1, sizeof *m->t_sum);
    if (!m->t_count || !m->t_sum)
        return -1;
    m->tiles_x = tiles_x;
    m->tiles_y = tiles_y;
    return 0;
}

/* 8 bins per octave of v + 1: the octave, then the next 3 bits. */
static int bin_of(uint64_t v)
{
    uint64_t x = v + 1;
    int oct = 63 - __builtin_clzll(x);
    int frac = oct >= 3 ? (int)((x >> (oct - 3)) & 7) : (int)((x << (3 - oct)) & 7);
    int b = oct * 8 + frac;
    return b < GV_LM_BINS ? b : GV_LM_BINS - 1;
}

/* The whole groups of four RGB blocks a kernel splits (returns how many
 * blocks it did); the rest is plain C. */
typedef uint32_t split_fn(const uint8_t *, uint32_t, uint8_t *, uint8_t *);

static uint32_t split_rgb_none(const uint8_t *row, uint32_t bw, uint8_t *even,
                               uint8_t *odd)
{
    (void)row, (void)bw, (void)even, (void)odd;
    return 0;
}

static split_fn *split_rgb = split_rgb_none;
static struct gv_cpu_once split_once = GV_CPU_ONCE_INIT;

static void split_dsp_init(unsigned flags)
{
    split_rgb = split_rgb_none;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_SSSE3)
        split_rgb = gv_lambda_split_rgb_ssse3;
#else
    (void)flags;
#endif
}

/* Split a level-0 row into its even and its odd pixels, of the width / 2
 * whole blocks (an odd width's last pixel is in none). */
static void split_row(const struct gv_lambda_model *m, const uint8_t *row,
                      uint8_t *even, uint8_t *odd)
{
    const uint32_t bw = m->width / 2;
    if (m->channels == 3) {
        gv_cpu_once(&split_once, split_dsp_init);
        uint32_t bx = split_rgb(row, bw, even, odd);
        for (; bx < bw; bx++) {
            memcpy(even + 3 * bx, row + 6 * bx, 3);
            memcpy(odd + 3 * bx, row + 6 * bx + 3, 3);
        }
    } else {
        for (uint32_t bx = 0; bx < bw; bx++) {
            even[bx] = row[2 * bx];
            odd[bx] = row[2 * bx + 1];
        }
    }
}

/* Store a level-1 row in mean row buffer i, between copies of its edge
 * pixels. */
static void put_mean(struct gv_lambda_model *m, int i, const uint8_t *row)
{
    const int c = m->channels;
    const uint32_t mw = (m->width + 1) / 2;
    uint8_t *d = m->mean[i];
    memcpy(d + c, row, (size_t)mw * c);
    memcpy(d, row, (size_t)c);
    memcpy(d + (size_t)(mw + 1) * c, row + (size_t)(mw - 1) * c, (size_t)c);
}

/* The detail of every block and channel of the pending block row into
 * det[0 .. n-1]: a loop of unit stride over the samples, which the
 * compiler vectorizes (restrict: no output aliases an input). */
static void block_detail(uint32_t n, int c, const uint8_t *restrict m0,
                         const uint8_t *restrict m1, const uint8_t *restrict m2,
                         const uint8_t *restrict e0, const uint8_t *restrict o0,
                         const uint8_t *restrict e1, const uint8_t *restrict o1,
                         uint32_t *restrict det)
{
    /* Sample j of a block row is channel j % c of block j / c; in the
     * padded mean rows it is at j + c, its neighbours at j and j + 2c. */
    const uint8_t *a0 = m0 + c, *a1 = m1 + c, *a2 = m2 + c;
    const uint8_t *r0 = m0 + 2 * c, *r1 = m1 + 2 * c, *r2 = m2 + 2 * c;
    for (uint32_t j = 0; j < n; j++) {
        /* p = 9 a + 3 b + 3 c + d: a the block's mean, b its horizontal
         * neighbour on the pixel's side, c the vertical one, d the
         * diagonal; each e^2 < 2^24, the four < 2^26. */
        const int up = 9 * a1[j] + 3 * a0[j], down = 9 * a1[j] + 3 * a2[j];
        const int el0 = 16 * e0[j] - (up + 3 * m1[j] + m0[j]);
        const int er0 = 16 * o0[j] - (up + 3 * r1[j] + r0[j]);
        const int el1 = 16 * e1[j] - (down + 3 * m1[j] + m2[j]);
        const int er1 = 16 * o1[j] - (down + 3 * r1[j] + r2[j]);
        det[j] = (uint32_t)(el0 * el0 + er0 * er0) + (uint32_t)(el1 * el1 + er1 * er1);
    }
}

/* Add the blocks of the pending block row (even[], odd[]) over mean[1],
 * with mean[0] above and mean[2] below.  First the detail of every block
 * and channel (block_detail), then the blocks' sums into bins.  As
 * one loop over blocks with the channels inside, the model took 11.7 %
 * of a -j 1 encode of the 54 MP bench mosaic (perf), on the thread that
 * bounds pass 1; now 5.2 %, the row split included.  Block bx's left
 * neighbour is mean pixel bx - 1 and its right bx + 1, the edge
 * repeated: the padding of the mean rows gives both. */
static void add_block_row(struct gv_lambda_model *m)
{
    const int c = m->channels;
    const uint32_t bw = m->width / 2;
    uint32_t *det = m->detail;
    block_detail(bw * (uint32_t)c, c, m->mean[0], m->mean[1], m->mean[2],
                 m->even[0], m->odd[0], m->even[1], m->odd[1], det);
    /* Each block also goes into its tile's coarse bins, where there are
     * tiles: 256 blocks a tile, either way. */
    const uint32_t ty = m->block_rows++ / (GV_STEP / 2);
    uint32_t *tcount = NULL;
    uint64_t *tsum = NULL;
    if (m->t_count && ty < m->tiles_y) {
        tcount = m->t_count + (size_t)ty * m->tiles_x * GV_LM_TBINS;
        tsum = m->t_sum + (size_t)ty * m->tiles_x * GV_LM_TBINS;
    }
    for (uint32_t bx = 0; bx < bw; bx++) {
        const uint32_t v = c == 3 ? det[3 * bx] + det[3 * bx + 1] + det[3 * bx + 2]
                                  : det[bx];
        int k = bin_of(v);
        m->count[k]++;
        m->sum[k] += v;
        if (tcount) {
            const size_t at = (size_t)(bx / (GV_STEP / 2)) * GV_LM_TBINS + (size_t)(k >> 2);
            tcount[at]++;
            tsum[at] += v;
        }
    }
    m->blocks += bw;
}

void gv_lambda_model_rows(struct gv_lambda_model *m, const uint8_t *r0,
                          const uint8_t *r1, const uint8_t *reduced)
{
    if (m->have == 0) {
        /* The first block row: the row above it repeats it. */
        put_mean(m, 1, reduced);
        put_mean(m, 0, reduced);
        split_row(m, r0, m->even[0], m->odd[0]);
        split_row(m, r1, m->even[1], m->odd[1]);
        m->have = 1;
        return;
    }
    put_mean(m, 2, reduced);
    add_block_row(m);
    uint8_t *t = m->mean[0];
    m->mean[0] = m->mean[1];
    m->mean[1] = m->mean[2];
    m->mean[2] = t;
    split_row(m, r0, m->even[0], m->odd[0]);
    split_row(m, r1, m->even[1], m->odd[1]);
}

void gv_lambda_model_finish(struct gv_lambda_model *m)
{
    if (m->have == 0 || !m->mean[2])
        return;
    memcpy(m->mean[2], m->mean[1], (size_t)((m->width + 1) / 2 + 2) * m->channels);
    add_block_row(m);
    m->have = 0;
}

/* The model's mean error per sample at water level theta (per sample)
 * when every block's detail is raised by `shift` (per sample): the error
 * its decoded parent passes down. */
static double model_mse(const struct gv_lambda_model *m, double theta,
                        double shift)
{
    const double scale = V_PER_SAMPLE * m->channels;
    double d = 0;
    for (int k = 0; k < GV_LM_BINS; k++) {
        if (!m->count[k])
            continue;
        double mean = (double)m->sum[k] / (double)m->count[k] / scale + shift;
        d += (mean < theta ? mean : theta) * (double)m->count[k];
    }
    return d / (double)m->blocks;
}

/* Level 0's error at water level theta: from the level below the root
 * (its parent, the root, is exact) down, each level's blocks carrying
 * LM_ALPHA of their parent level's error. */
static double pyramid_mse(const struct gv_lambda_model *lv, int n, double theta)
{
    double parent = 0;
    for (int k = n - 1; k >= 0; k--)
        if (lv[k].blocks)
            parent = model_mse(&lv[k], theta, LM_ALPHA * parent);
    return parent;
}

double gv_lambda_model_theta(const struct gv_lambda_model *lv, int n,
                             double target_mse)
{
    if (n <= 0 || !lv[0].blocks)
        return 0;
    double lo = 0, hi = 65025.0;
    for (int i = 0; i < 64; i++) {
        double mid = 0.5 * (lo + hi);
        if (pyramid_mse(lv, n, mid) < target_mse)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* One tile's modelled error per sample and its blocks (*blocks). */
static double tile_mse(const struct gv_lambda_model *m, size_t tile,
                       double theta, double shift, uint64_t *blocks)
{
    const uint32_t *count = m->t_count + tile * GV_LM_TBINS;
    const uint64_t *sum = m->t_sum + tile * GV_LM_TBINS;
    const double scale = V_PER_SAMPLE * m->channels;
    double d = 0;
    uint64_t nb = 0;
    for (int k = 0; k < GV_LM_TBINS; k++) {
        if (!count[k])
            continue;
        double mean = (double)sum[k] / (double)count[k] / scale + shift;
        d += (mean < theta ? mean : theta) * (double)count[k];
        nb += count[k];
    }
    *blocks = nb;
    return nb ? d / (double)nb : shift;
}

double gv_lambda_model_tiles_mse(const struct gv_lambda_model *lv, int n,
                                 double theta, const uint8_t *mask0)
{
    if (n <= 0)
        return 0;
    for (int k = 0; k < n; k++)
        if (!lv[k].t_count)
            return 0;
    /* err[k & 1]: each tile's error at level k, from level n-1 down. */
    double *err[2] = {NULL, NULL};
    size_t cap = 0;
    for (int k = 0; k < n; k++) {
        size_t t = (size_t)lv[k].tiles_x * lv[k].tiles_y;
        cap = t > cap ? t : cap;
    }
    err[0] = malloc((cap ? cap : 1) * sizeof *err[0]);
    err[1] = malloc((cap ? cap : 1) * sizeof *err[1]);
    double total = 0, blocks = 0;
    if (!err[0] || !err[1]) {
        free(err[0]);
        free(err[1]);
        return -1;
    }
    for (int k = n - 1; k >= 0; k--) {
        const struct gv_lambda_model *m = &lv[k];
        const struct gv_lambda_model *up = k + 1 < n ? &lv[k + 1] : NULL;
        double *e = err[k & 1];
        const double *pe = err[(k + 1) & 1];
        for (uint32_t ty = 0; ty < m->tiles_y; ty++)
            for (uint32_t tx = 0; tx < m->tiles_x; tx++) {
                const size_t t = (size_t)ty * m->tiles_x + tx;
                double parent = 0;
                if (up && tx / 2 < up->tiles_x && ty / 2 < up->tiles_y)
                    parent = pe[(size_t)(ty / 2) * up->tiles_x + tx / 2];
                uint64_t nb;
                e[t] = tile_mse(m, t, theta, LM_ALPHA * parent, &nb);
                if (k == 0 && (!mask0 || mask0[t])) {
                    total += e[t] * (double)nb;
                    blocks += (double)nb;
                }
            }
    }
    free(err[0]);
    free(err[1]);
    return blocks > 0 ? total / blocks : 0;
}

double gv_lambda_model_k(double target_mse, int dct)
{
    if (!dct)
        return LM_K;
    /* Above 40 dB layout D's tiles fell short of the target by more
     * the higher it was (halved photographs: -1.2 dB at 44, -1.6 at
     * 46 with K = 4.5): K halves every 4 dB from there. */
    const double q = 10.0 * log10(65025.0 / target_mse);
    return q > 40.0 ? LM_K_DCT * pow(2.0, -(q - 40.0) / 4.0) : LM_K_DCT;
}

double gv_lambda_model_lambda(const struct gv_lambda_model *lv, int n,
                              double target_mse, int dct)
{
    const double k = gv_lambda_model_k(target_mse, dct);
    double lambda = k * 2.0 * log(2.0) * gv_lambda_model_theta(lv, n, target_mse);
    double floor = gv_rd_lambda(target_mse) / LM_FLOOR;
    double ceil = k * gv_rd_lambda(target_mse) * LM_CEIL;
    return lambda > ceil ? ceil : lambda > floor ? lambda : floor;
}

double gv_lambda_model_level_factor(const struct gv_lambda_model *lv, int n,
                                    double target_mse)
{
    if (n <= 0 || !lv[0].blocks)
        return 1.0;
    const struct gv_lambda_model *m = &lv[0];
    const double theta = gv_lambda_model_theta(lv, n, target_mse);
    const double scale = V_PER_SAMPLE * m->channels;
    double above = 0;
    for (int k = 0; k < GV_LM_BINS; k++)
        if (m->count[k] && (double)m->sum[k] / (double)m->count[k] / scale > theta)
            above += (double)m->count[k];
    return 0.5 + 0.5 * above / (double)m->blocks;
}

double gv_level_lambda(double lambda, double f, int level)
{
    return lambda * pow(f, level);
}
