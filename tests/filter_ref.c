/*
 * filter_ref.c - CPU references of the stock filter graphs (filter_ref.h).
 *
 * Written from the formulas of docs/FILTERS.md section 8, not from the
 * graphs' GLSL: kernels are summed directly in 2D (the library's separable
 * Gaussians must agree with the 2D sum, edge clamping being separable),
 * block filters visit each block's pixels directly instead of building a
 * pyramid, and the distance transforms run the propagation rules of
 * filters/edt_cpu.h scalar and in place (the previous line is already
 * updated, the current one not yet, exactly the state the propagation
 * template exposes).  Sums are in double; decisions that must agree bit for
 * bit with the GPU (feature masks, random sites, squared distances) are in
 * integer arithmetic or in the same float operations the graphs document.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "filter_ref.h"

#define NONE 0xffffffffu

static int clampi(int v, int lo, int hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

static const float *texel(const struct ref_image *im, int x, int y)
{
    x = clampi(x, 0, im->w - 1);
    y = clampi(y, 0, im->h - 1);
    return im->px + ((size_t)y * (size_t)im->w + (size_t)x) * 4;
}

static float *out_at(const struct ref_region *r, float *out, int i, int j)
{
    return out + ((size_t)j * (size_t)r->roi_w + (size_t)i) * 4;
}

/* ------------------------------------------------------------ point */

int ref_threshold(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state)
{
    (void)state;
    const float a = (float)p[0], b = (float)p[1];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *v = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            for (int c = 0; c < 3; c++)
                o[c] = v[c] <= a ? 0.0f : v[c] >= b ? 1.0f : v[c];
            o[3] = v[3];
        }
    return 0;
}

int ref_negate(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)p;
    (void)state;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *v = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            for (int c = 0; c < 3; c++)
                o[c] = 1.0f - v[c];
            o[3] = v[3];
        }
    return 0;
}

int ref_gamma(const struct ref_region *r, const double *p, float *out,
              uint32_t *state)
{
    (void)state;
    const double g = (float)p[0];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *v = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            for (int c = 0; c < 3; c++)
                o[c] = (float)pow(v[c], g);
            o[3] = v[3];
        }
    return 0;
}

/* Eq. 7.5 with x = 1..width and y = 1..height over the ROI. */
int ref_sine_window(const struct ref_region *r, const double *p, float *out,
                    uint32_t *state)
{
    (void)p;
    (void)state;
    const double pi = 3.14159265358979323846;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *v = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            double w = sin((i + 1) * pi / r->roi_w) * sin((j + 1) * pi / r->roi_h);
            for (int c = 0; c < 3; c++)
                o[c] = (float)(v[c] * w);
            o[3] = v[3];
        }
    return 0;
}

/* ITU-R BT.709 luma of the stored values. */
static double luma709(const float *v)
{
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

int ref_grayscale(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state)
{
    (void)p;
    (void)state;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *v = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            o[0] = o[1] = o[2] = (float)luma709(v);
            o[3] = v[3];
        }
    return 0;
}

/* ----------------------------------------------------------- linear */

/* Correlate every channel of the region with a kw x kh kernel (row major,
 * top row first, centred), scaled; writes RGBA over the ROI. */
static void correlate(const struct ref_region *r, int kw, int kh, const double *k,
                      double scale, float *out)
{
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            double s[4] = {0, 0, 0, 0};
            for (int v = 0; v < kh; v++)
                for (int u = 0; u < kw; u++) {
                    const double w = k[v * kw + u];
                    if (w == 0.0)
                        continue;
                    const float *t = texel(&r->img, r->roi_x + i + u - kw / 2,
                                           r->roi_y + j + v - kh / 2);
                    for (int c = 0; c < 4; c++)
                        s[c] += w * t[c];
                }
            float *o = out_at(r, out, i, j);
            for (int c = 0; c < 4; c++)
                o[c] = (float)(scale * s[c]);
        }
}

static int box(const struct ref_region *r, int n, float *out)
{
    double *k = malloc(sizeof *k * (size_t)(n * n));
    if (!k)
        return -1;
    for (int i = 0; i < n * n; i++)
        k[i] = 1.0;
    correlate(r, n, n, k, 1.0 / (n * n), out);
    free(k);
    return 0;
}

int ref_box3(const struct ref_region *r, const double *p, float *out,
             uint32_t *state)
{
    (void)p;
    (void)state;
    return box(r, 3, out);
}

int ref_box7(const struct ref_region *r, const double *p, float *out,
             uint32_t *state)
{
    (void)p;
    (void)state;
    return box(r, 7, out);
}

/* The 2D Gaussian of standard deviation sigma on |i|, |j| <= 3 sigma,
 * weights exp(-(i^2 + j^2) / (2 sigma^2)) normalized to sum 1. */
static int gauss(const struct ref_region *r, int sigma, float *out)
{
    const int rad = 3 * sigma, n = 2 * rad + 1;
    double *k = malloc(sizeof *k * (size_t)(n * n)), sum = 0;
    if (!k)
        return -1;
    for (int j = -rad; j <= rad; j++)
        for (int i = -rad; i <= rad; i++) {
            k[(j + rad) * n + i + rad] = exp(-(i * i + j * j) / (2.0 * sigma * sigma));
            sum += k[(j + rad) * n + i + rad];
        }
    correlate(r, n, n, k, 1.0 / sum, out);
    free(k);
    return 0;
}

int ref_gauss1(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)p;
    (void)state;
    return gauss(r, 1, out);
}

int ref_gauss2(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)p;
    (void)state;
    return gauss(r, 2, out);
}

int ref_gauss4(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)p;
    (void)state;
    return gauss(r, 4, out);
}

/* Eq. 7.10 and its transpose, then gain * sqrt(gx^2 + gy^2) per channel. */
int ref_sobel(const struct ref_region *r, const double *p, float *out,
              uint32_t *state)
{
    (void)state;
    static const double kx[9] = {1, 0, -1, 2, 0, -2, 1, 0, -1};
    static const double ky[9] = {1, 2, 1, 0, 0, 0, -1, -2, -1};
    const size_t n = (size_t)r->roi_w * (size_t)r->roi_h * 4;
    float *gx = malloc(sizeof *gx * n), *gy = malloc(sizeof *gy * n);
    if (!gx || !gy) {
        free(gx);
        free(gy);
        return -1;
    }
    correlate(r, 3, 3, kx, 0.125, gx);
    correlate(r, 3, 3, ky, 0.125, gy);
    const double gain = (float)p[0];
    for (size_t i = 0; i < n; i += 4) {
        for (int c = 0; c < 3; c++)
            out[i + c] = (float)(gain * sqrt((double)gx[i + c] * gx[i + c] +
                                             (double)gy[i + c] * gy[i + c]));
        out[i + 3] = 1.0f;
    }
    free(gx);
    free(gy);
    return 0;
}

/* Fig. 7.10: s + amount * (s - blur(s)), the Gaussian of sigma 2. */
int ref_detail(const struct ref_region *r, const double *p, float *out,
               uint32_t *state)
{
    (void)state;
    if (gauss(r, 2, out) < 0)
        return -1;
    const double x = (float)p[0];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const float *s = texel(&r->img, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            for (int c = 0; c < 3; c++)
                o[c] = (float)(s[c] + x * (s[c] - o[c]));
            o[3] = 1.0f;
        }
    return 0;
}

/* ------------------------------------------------------- log-reduce */

enum block_op { BLOCK_MAX, BLOCK_MIN, BLOCK_MEAN };

/* Every ROI pixel gets op over its block of 2^level x 2^level pixels,
 * aligned in level coordinates and cut to the region. */
static int block(const struct ref_region *r, const double *p, enum block_op op,
                 float *out)
{
    const int level = (int)((float)p[0] + 0.5f);
    const int64_t size = (int64_t)1 << level;
    for (int j = 0; j < r->roi_h;) {
        const int64_t ay = r->abs_y + r->roi_y + j;
        const int64_t by0 = ay / size * size - r->abs_y;  /* block's rows */
        const int y0 = (int)(by0 < 0 ? 0 : by0);
        const int y1 = (int)(by0 + size > r->img.h ? r->img.h : by0 + size);
        for (int i = 0; i < r->roi_w;) {
            const int64_t ax = r->abs_x + r->roi_x + i;
            const int64_t bx0 = ax / size * size - r->abs_x;
            const int x0 = (int)(bx0 < 0 ? 0 : bx0);
            const int x1 = (int)(bx0 + size > r->img.w ? r->img.w : bx0 + size);
            double acc[4];
            for (int c = 0; c < 4; c++)
                acc[c] = op == BLOCK_MAX ? -1.0 : op == BLOCK_MIN ? 2.0 : 0.0;
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++) {
                    const float *t = texel(&r->img, x, y);
                    for (int c = 0; c < 4; c++)
                        acc[c] = op == BLOCK_MAX ? fmax(acc[c], t[c])
                                 : op == BLOCK_MIN ? fmin(acc[c], t[c])
                                                   : acc[c] + t[c];
                }
            if (op == BLOCK_MEAN)
                for (int c = 0; c < 4; c++)
                    acc[c] /= (double)(x1 - x0) * (y1 - y0);
            /* Fill the part of the ROI this block covers. */
            const int ie = (int)(bx0 + size - r->roi_x < r->roi_w ? bx0 + size - r->roi_x
                                                                  : r->roi_w);
            const int je = (int)(by0 + size - r->roi_y < r->roi_h ? by0 + size - r->roi_y
                                                                  : r->roi_h);
            for (int v = j; v < je; v++)
                for (int u = i; u < ie; u++)
                    for (int c = 0; c < 4; c++)
                        out_at(r, out, u, v)[c] = (float)acc[c];
            i = ie;
        }
        j = (int)(by0 + size - r->roi_y < r->roi_h ? by0 + size - r->roi_y : r->roi_h);
    }
    return 0;
}

int ref_block_max(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state)
{
    (void)state;
    return block(r, p, BLOCK_MAX, out);
}

int ref_block_min(const struct ref_region *r, const double *p, float *out,
                  uint32_t *state)
{
    (void)state;
    return block(r, p, BLOCK_MIN, out);
}

int ref_block_mean(const struct ref_region *r, const double *p, float *out,
                   uint32_t *state)
{
    (void)state;
    return block(r, p, BLOCK_MEAN, out);
}

/* ------------------------------------------- distance transforms */

int ref_is_feature(const float *px, double channel, double threshold,
                   double invert)
{
    uint32_t u[3];
    for (int c = 0; c < 3; c++)
        u[c] = (uint32_t)(px[c] * 255.0f + 0.5f);
    const int ch = (int)((float)channel + 0.5f);
    const uint32_t x = ch < 3 ? 10000u * u[ch] : 2126u * u[0] + 7152u * u[1] + 722u * u[2];
    const int f = (float)x >= (float)threshold * 2550000.0f;
    return f != ((float)invert >= 0.5f);
}

/* Unique within any 4096 x 4096 window and exact as a float. */
static uint32_t point_id(uint32_t ax, uint32_t ay)
{
    return 1u + ((ay & 4095u) << 12) + (ax & 4095u);
}

/* Squared distance in wrapping uint32 arithmetic (filters/edt_cpu.h). */
static uint32_t key(uint32_t sx, uint32_t sy, uint32_t x, uint32_t y)
{
    const uint32_t dx = sx - x, dy = sy - y;
    return dx * dx + dy * dy;
}

static uint32_t *st_at(uint32_t *st, const struct ref_region *r, int x, int y)
{
    return st + ((size_t)y * (size_t)r->img.w + (size_t)x) * 4;
}

static uint32_t abs_x(const struct ref_region *r, int x)
{
    return (uint32_t)(r->abs_x + x);
}

static uint32_t abs_y(const struct ref_region *r, int y)
{
    return (uint32_t)(r->abs_y + y);
}

/* The four sweeps of thesis fig. 7.14 (+x, -x, +y, -y).  Each sweep writes
 * the lines after the first in its direction; candidates are the pixel's
 * own value, then the previous line at the centre, at -perp and at +perp
 * (reads clamped to the region, which only repeats candidates).  k = 1:
 * state (x, y, id, valid), the first strictly nearer valid candidate wins.
 * k = 2: state (x1, y1, x2, y2) with NONE for no site, candidates first
 * then second of each pixel, sites already held skipped. */
static void propagate(const struct ref_region *r, uint32_t *st, int k)
{
    static const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    const int w = r->img.w, h = r->img.h;
    for (int d = 0; d < 4; d++) {
        const int dx = dirs[d][0], dy = dirs[d][1];
        const int px = abs(dy), py = abs(dx);       /* perp */
        const int lines = dx ? w : h, len = dx ? h : w;
        for (int l = 1; l < lines; l++) {
            const int line = dx + dy > 0 ? l : lines - 1 - l;
            for (int t = 0; t < len; t++) {
                const int x = dx ? line : t, y = dx ? t : line;
                const uint32_t mx = abs_x(r, x), my = abs_y(r, y);
                uint32_t *own = st_at(st, r, x, y);
                if (k == 1) {
                    uint32_t best[4];
                    memcpy(best, own, sizeof best);
                    uint32_t bd = key(best[0], best[1], mx, my);
                    for (int c = 0; c < 3; c++) {
                        const int s = c == 0 ? 0 : c == 1 ? -1 : 1;
                        const uint32_t *cand = st_at(st, r, clampi(x - dx + s * px, 0, w - 1),
                                                     clampi(y - dy + s * py, 0, h - 1));
                        const uint32_t cd = key(cand[0], cand[1], mx, my);
                        if (cand[3] && (!best[3] || cd < bd)) {
                            memcpy(best, cand, sizeof best);
                            bd = cd;
                        }
                    }
                    memcpy(own, best, sizeof best);
                } else {
                    uint32_t b1x = own[0], b1y = own[1], b2x = own[2], b2y = own[3];
                    uint32_t d1 = b1x == NONE ? NONE : key(b1x, b1y, mx, my);
                    uint32_t d2 = b2x == NONE ? NONE : key(b2x, b2y, mx, my);
                    for (int c = 0; c < 6; c++) {
                        const int s = c < 2 ? 0 : c < 4 ? -1 : 1;
                        const uint32_t *cand = st_at(st, r, clampi(x - dx + s * px, 0, w - 1),
                                                     clampi(y - dy + s * py, 0, h - 1));
                        const uint32_t cx = cand[(c & 1) * 2], cy = cand[(c & 1) * 2 + 1];
                        if (cx == NONE || (cx == b1x && cy == b1y) || (cx == b2x && cy == b2y))
                            continue;
                        const uint32_t cd = key(cx, cy, mx, my);
                        if (cd < d1) {
                            b2x = b1x, b2y = b1y, d2 = d1;
                            b1x = cx, b1y = cy, d1 = cd;
                        } else if (cd < d2) {
                            b2x = cx, b2y = cy, d2 = cd;
                        }
                    }
                    own[0] = b1x, own[1] = b1y, own[2] = b2x, own[3] = b2y;
                }
            }
        }
    }
}

/* The state buffer of a propagation reference: the caller's, or ours. */
static uint32_t *state_buf(const struct ref_region *r, uint32_t *state)
{
    if (state)
        return state;
    return malloc(sizeof *state * (size_t)r->img.w * (size_t)r->img.h * 4);
}

/* Initial state of the distance transforms: feature pixels are their own
 * sites, id point_id. */
static void init_features(const struct ref_region *r, const double *p, uint32_t *st)
{
    for (int y = 0; y < r->img.h; y++)
        for (int x = 0; x < r->img.w; x++) {
            uint32_t *s = st_at(st, r, x, y);
            if (ref_is_feature(texel(&r->img, x, y), p[0], p[1], p[2])) {
                s[0] = abs_x(r, x), s[1] = abs_y(r, y);
                s[2] = point_id(s[0], s[1]), s[3] = 1;
            } else {
                s[0] = s[1] = s[2] = s[3] = 0;
            }
        }
}

/* Squared distance from ROI pixel (i, j) to the site (sx, sy), as the
 * graphs compute it: |difference| in int, squared in uint. */
static uint32_t site_d2(const struct ref_region *r, int i, int j, uint32_t sx, uint32_t sy)
{
    const int64_t ex = (int64_t)sx - (r->abs_x + r->roi_x + i);
    const int64_t ey = (int64_t)sy - (r->abs_y + r->roi_y + j);
    const uint32_t mx = (uint32_t)(ex < 0 ? -ex : ex), my = (uint32_t)(ey < 0 ? -ey : ey);
    return mx * mx + my * my;
}

int ref_distance(const struct ref_region *r, const double *p, float *out,
                 uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    init_features(r, p, st);
    propagate(r, st, 1);
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const uint32_t *s = st_at(st, r, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            if (!s[3]) {
                o[0] = -1.0f, o[1] = o[2] = o[3] = 0.0f;
                continue;
            }
            o[0] = sqrtf((float)site_d2(r, i, j, s[0], s[1]));
            o[1] = (float)s[2];
            o[2] = (float)((int64_t)s[0] - (r->abs_x + r->roi_x + i));
            o[3] = (float)((int64_t)s[1] - (r->abs_y + r->roi_y + j));
        }
    if (st != state)
        free(st);
    return 0;
}

int ref_distance_display(const struct ref_region *r, const double *p,
                         float *out, uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    init_features(r, p, st);
    propagate(r, st, 1);
    const float scale = (float)p[3];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const uint32_t *s = st_at(st, r, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            float d = 1.0f;
            if (s[3])
                d = fminf(sqrtf((float)site_d2(r, i, j, s[0], s[1])) / scale, 1.0f);
            o[0] = o[1] = o[2] = d;
            o[3] = 1.0f;
        }
    if (st != state)
        free(st);
    return 0;
}

/* Colour regions by the image at their site; black boundaries where the
 * site (coordinates and validity) differs from the right or lower
 * neighbour's (clamped), when boundaries >= 0.5. */
static void show_sites(const struct ref_region *r, uint32_t *st, double boundaries,
                       float *out)
{
    const int lines = (float)boundaries >= 0.5f;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const int x = r->roi_x + i, y = r->roi_y + j;
            const uint32_t *s = st_at(st, r, x, y);
            float *o = out_at(r, out, i, j);
            o[0] = o[1] = o[2] = 0.0f;
            o[3] = 1.0f;
            if (!s[3])
                continue;
            const float *c = texel(&r->img, (int)((int64_t)s[0] - r->abs_x),
                                   (int)((int64_t)s[1] - r->abs_y));
            const uint32_t *nb[2] = {st_at(st, r, clampi(x + 1, 0, r->img.w - 1), y),
                                     st_at(st, r, x, clampi(y + 1, 0, r->img.h - 1))};
            int edge = 0;
            for (int n = 0; n < 2; n++)
                edge |= nb[n][0] != s[0] || nb[n][1] != s[1] || nb[n][3] != s[3];
            if (!(lines && edge))
                memcpy(o, c, 3 * sizeof *o);
        }
}

/* Sites every s pixels, at s/2 + k s in level coordinates. */
static void init_grid(const struct ref_region *r, const double *p, uint32_t *st)
{
    const int s = (int)((float)p[0] + 0.5f);
    for (int y = 0; y < r->img.h; y++)
        for (int x = 0; x < r->img.w; x++) {
            uint32_t *t = st_at(st, r, x, y);
            const uint32_t ax = abs_x(r, x), ay = abs_y(r, y);
            if (ax % (uint32_t)s == (uint32_t)(s / 2) && ay % (uint32_t)s == (uint32_t)(s / 2)) {
                t[0] = ax, t[1] = ay, t[2] = point_id(ax, ay), t[3] = 1;
            } else {
                t[0] = t[1] = t[2] = t[3] = 0;
            }
        }
}

int ref_voronoi_grid(const struct ref_region *r, const double *p, float *out,
                     uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    init_grid(r, p, st);
    propagate(r, st, 1);
    show_sites(r, st, p[1], out);
    if (st != state)
        free(st);
    return 0;
}

/* lowbias32 (Chris Wellons' integer hash) applied to y, xor x, again. */
int ref_random_site(uint32_t ax, uint32_t ay, double density)
{
    uint32_t h = ay;
    for (int i = 0; i < 2; i++) {
        h ^= h >> 16;
        h *= 0x7feb352du;
        h ^= h >> 15;
        h *= 0x846ca68bu;
        h ^= h >> 16;
        if (i == 0)
            h ^= ax;
    }
    return (h >> 8) < (uint32_t)((float)density * 16777216.0f);
}

static void init_mosaic(const struct ref_region *r, const double *p, uint32_t *st)
{
    for (int y = 0; y < r->img.h; y++)
        for (int x = 0; x < r->img.w; x++) {
            uint32_t *t = st_at(st, r, x, y);
            const uint32_t ax = abs_x(r, x), ay = abs_y(r, y);
            if (ref_random_site(ax, ay, p[0])) {
                t[0] = ax, t[1] = ay, t[2] = point_id(ax, ay), t[3] = 1;
            } else {
                t[0] = t[1] = t[2] = t[3] = 0;
            }
        }
}

int ref_voronoi_mosaic(const struct ref_region *r, const double *p, float *out,
                       uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    init_mosaic(r, p, st);
    propagate(r, st, 1);
    show_sites(r, st, p[1], out);
    if (st != state)
        free(st);
    return 0;
}

/* Features by mask; id 1 + the RGB centre of the pixel's colour bin
 * (levels per channel), packed 8 bits per channel. */
static void init_generalized(const struct ref_region *r, const double *p, uint32_t *st)
{
    const uint32_t l = (uint32_t)((float)p[3] + 0.5f);
    for (int y = 0; y < r->img.h; y++)
        for (int x = 0; x < r->img.w; x++) {
            uint32_t *t = st_at(st, r, x, y);
            const float *v = texel(&r->img, x, y);
            if (!ref_is_feature(v, p[0], p[1], p[2])) {
                t[0] = t[1] = t[2] = t[3] = 0;
                continue;
            }
            uint32_t m[3];
            for (int c = 0; c < 3; c++) {
                const uint32_t u = (uint32_t)(v[c] * 255.0f + 0.5f);
                const uint32_t q = u * l / 256u;
                m[c] = (2u * q + 1u) * 255u / (2u * l);
            }
            t[0] = abs_x(r, x), t[1] = abs_y(r, y);
            t[2] = 1u + (m[0] << 16) + (m[1] << 8) + m[2], t[3] = 1;
        }
}

/* Regions show the colour of their feature's bin; black boundaries where
 * the id differs from the right or lower neighbour's. */
int ref_voronoi_generalized(const struct ref_region *r, const double *p,
                            float *out, uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    init_generalized(r, p, st);
    propagate(r, st, 1);
    const int lines = (float)p[4] >= 0.5f;
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const int x = r->roi_x + i, y = r->roi_y + j;
            const uint32_t *s = st_at(st, r, x, y);
            float *o = out_at(r, out, i, j);
            o[0] = o[1] = o[2] = 0.0f;
            o[3] = 1.0f;
            if (!s[3])
                continue;
            const uint32_t id = s[2];
            if (lines && (st_at(st, r, clampi(x + 1, 0, r->img.w - 1), y)[2] != id ||
                          st_at(st, r, x, clampi(y + 1, 0, r->img.h - 1))[2] != id))
                continue;
            const uint32_t k = id - 1u;
            o[0] = (float)(k >> 16) / 255.0f;
            o[1] = (float)((k >> 8) & 255u) / 255.0f;
            o[2] = (float)(k & 255u) / 255.0f;
        }
    if (st != state)
        free(st);
    return 0;
}

/* 2-NN: (d2 - d1) / scale, 1 where fewer than two sites were found. */
int ref_voronoi_knn(const struct ref_region *r, const double *p, float *out,
                    uint32_t *state)
{
    uint32_t *st = state_buf(r, state);
    if (!st)
        return -1;
    for (int y = 0; y < r->img.h; y++)
        for (int x = 0; x < r->img.w; x++) {
            uint32_t *t = st_at(st, r, x, y);
            const uint32_t ax = abs_x(r, x), ay = abs_y(r, y);
            const int site = ref_random_site(ax, ay, p[0]);
            t[0] = site ? ax : NONE, t[1] = site ? ay : NONE;
            t[2] = t[3] = NONE;
        }
    propagate(r, st, 2);
    const float scale = (float)p[1];
    for (int j = 0; j < r->roi_h; j++)
        for (int i = 0; i < r->roi_w; i++) {
            const uint32_t *s = st_at(st, r, r->roi_x + i, r->roi_y + j);
            float *o = out_at(r, out, i, j);
            if (s[2] == NONE) {
                o[0] = o[1] = o[2] = o[3] = 1.0f;
                continue;
            }
            const float d1 = sqrtf((float)site_d2(r, i, j, s[0], s[1]));
            const float d2 = sqrtf((float)site_d2(r, i, j, s[2], s[3]));
            o[0] = o[1] = o[2] = (d2 - d1) / scale;
            o[3] = 1.0f;
        }
    if (st != state)
        free(st);
    return 0;
}

int ref_initial_ids(ref_fn which, const struct ref_region *r, const double *p,
                    uint32_t *ids)
{
    void (*init)(const struct ref_region *, const double *, uint32_t *) =
        which == ref_distance || which == ref_distance_display ? init_features
        : which == ref_voronoi_grid                          ? init_grid
        : which == ref_voronoi_mosaic                        ? init_mosaic
        : which == ref_voronoi_generalized                   ? init_generalized
                                                             : NULL;
    if (!init)
        return -1;
    const size_t n = (size_t)r->img.w * (size_t)r->img.h;
    uint32_t *st = malloc(sizeof *st * n * 4);
    if (!st)
        return -1;
    init(r, p, st);
    for (size_t i = 0; i < n; i++)
        ids[i] = st[i * 4 + 3] ? st[i * 4 + 2] : 0;
    free(st);
    return 0;
}

double ref_exact_distance(const uint8_t *mask, int w, int h, int x, int y)
{
    int64_t best = -1;
    const int far = w > h ? w : h;
    for (int rad = 0; rad <= far; rad++) {
        if (best >= 0 && (int64_t)rad * rad > best)
            break;
        for (int v = y - rad; v <= y + rad; v++) {
            if (v < 0 || v >= h)
                continue;
            const int step = (v == y - rad || v == y + rad) ? 1 : 2 * rad;
            for (int u = x - rad; u <= x + rad; u += step > 0 ? step : 1) {
                if (u < 0 || u >= w || !mask[(size_t)v * (size_t)w + (size_t)u])
                    continue;
                const int64_t d = (int64_t)(u - x) * (u - x) + (int64_t)(v - y) * (v - y);
                if (best < 0 || d < best)
                    best = d;
            }
        }
    }
    return best < 0 ? -1.0 : sqrt((double)best);
}
