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
 * that straddles it counts min(its mean detail, theta) per block.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec/tile.h"
#include "encode/lambda_model.h"

/* lambda = K * 2 ln 2 * theta, and the parent's share: chosen together
 * on eight photographs at -q 32 to 44 and on the 58 MP relief of the
 * bench (docs/FORMAT.md section 8).  A share of 1/2 fitted the photos
 * best at 40 dB and up, but left smooth images with no bits at all well
 * short of the target (the relief: 31 dB for 38). */
#define LM_K 1.5
#define LM_K_DCT 4.5     /* with layout D allowed: at -q 40, Picos de Europa
                         * 40.28 dB and Dragonfly 40.49 dB (9: 37.90 and
                         * 39.32) */
#define LM_ALPHA 0.75   /* share of a parent's error its children inherit */
#define LM_FLOOR 64.0   /* lambda >= gv_rd_lambda(target) / LM_FLOOR */

#define V_PER_SAMPLE 1024.0   /* V / (this x C): detail per sample */

int gv_lambda_model_init(struct gv_lambda_model *m, uint32_t width,
                         int channels)
{
    memset(m, 0, sizeof *m);
    m->channels = channels;
    m->width = width;
    const size_t rb = (size_t)width * channels;
    const size_t mb = (size_t)((width + 1) / 2) * channels;
    for (int i = 0; i < 2; i++)
        if (!(m->pair[i] = malloc(rb)))
            return -1;
    for (int i = 0; i < 3; i++)
        if (!(m->mean[i] = malloc(mb)))
            return -1;
    return 0;
}

void gv_lambda_model_free(struct gv_lambda_model *m)
{
    for (int i = 0; i < 2; i++) {
        free(m->pair[i]);
        m->pair[i] = NULL;
    }
    for (int i = 0; i < 3; i++) {
        free(m->mean[i]);
        m->mean[i] = NULL;
    }
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

/* Add the blocks of the pending block row: pair[] over mean[1], with
 * mean[0] above and mean[2] below. */
static void add_block_row(struct gv_lambda_model *m)
{
    const int c = m->channels;
    const uint32_t bw = m->width / 2, mw = (m->width + 1) / 2;
    for (uint32_t bx = 0; bx < bw; bx++) {
        const uint32_t xl = bx > 0 ? bx - 1 : 0, xr = bx + 1 < mw ? bx + 1 : bx;
        uint64_t v = 0;
        for (int ch = 0; ch < c; ch++) {
            const int a = m->mean[1][bx * c + ch];
            for (int dy = 0; dy < 2; dy++) {
                const uint8_t *vert = m->mean[dy ? 2 : 0];
                const int cv = vert[bx * c + ch];
                for (int dx = 0; dx < 2; dx++) {
                    const uint32_t xs = dx ? xr : xl;
                    const int b = m->mean[1][xs * c + ch], d = vert[xs * c + ch];
                    const int p = 9 * a + 3 * b + 3 * cv + d;
                    const int x = m->pair[dy][(2 * bx + dx) * c + ch];
                    const int e = 16 * x - p;
                    v += (uint64_t)(e * e);
                }
            }
        }
        int k = bin_of(v);
        m->count[k]++;
        m->sum[k] += v;
        m->blocks++;
    }
}

void gv_lambda_model_rows(struct gv_lambda_model *m, const uint8_t *r0,
                          const uint8_t *r1, const uint8_t *reduced)
{
    const size_t rb = (size_t)m->width * m->channels;
    const size_t mb = (size_t)((m->width + 1) / 2) * m->channels;
    if (m->have == 0) {
        /* The first block row: the row above it repeats it. */
        memcpy(m->mean[1], reduced, mb);
        memcpy(m->mean[0], reduced, mb);
        memcpy(m->pair[0], r0, rb);
        memcpy(m->pair[1], r1, rb);
        m->have = 1;
        return;
    }
    memcpy(m->mean[2], reduced, mb);
    add_block_row(m);
    uint8_t *t = m->mean[0];
    m->mean[0] = m->mean[1];
    m->mean[1] = m->mean[2];
    m->mean[2] = t;
    memcpy(m->pair[0], r0, rb);
    memcpy(m->pair[1], r1, rb);
}

void gv_lambda_model_finish(struct gv_lambda_model *m)
{
    if (m->have == 0 || !m->mean[2])
        return;
    memcpy(m->mean[2], m->mean[1], (size_t)((m->width + 1) / 2) * m->channels);
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

double gv_lambda_model_lambda(const struct gv_lambda_model *lv, int n,
                              double target_mse, int dct)
{
    double k = LM_K;
    if (dct) {
        /* Above 40 dB layout D's tiles fell short of the target by more
         * the higher it was (halved photographs: -1.2 dB at 44, -1.6 at
         * 46 with K = 4.5): K halves every 4 dB from there. */
        const double q = 10.0 * log10(65025.0 / target_mse);
        k = q > 40.0 ? LM_K_DCT * pow(2.0, -(q - 40.0) / 4.0) : LM_K_DCT;
    }
    double lambda = k * 2.0 * log(2.0) * gv_lambda_model_theta(lv, n, target_mse);
    double floor = gv_rd_lambda(target_mse) / LM_FLOOR;
    return lambda > floor ? lambda : floor;
}
