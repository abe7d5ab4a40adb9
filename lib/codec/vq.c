/*
 * vq.c - exact nearest-codevector search and LBG training.
 *
 * The search packs two dimensions per 32-bit lane so that one
 * _mm256_madd_epi16 yields d0^2 + d1^2 for eight codevectors at once; a
 * codevector needs dim/2 (6 for RGB) load-subtract-madd-add steps.  An
 * AVX-512 kernel (16 codevectors at once, x86/vq_avx512.c) or the AVX2
 * one (x86/vq_avx2.c), both the walk of x86/vq_walk.h, is picked from
 * gv_cpu_flags() (base/cpu.h; GIGAVIEW_SIMD=avx2 rules out the first)
 * into a one-entry table, and each returns exactly what the portable loop returns (the least cost,
 * ties to the lowest index), so stores do not depend on the CPU that
 * wrote them.  A per-codevector bias is where each cost starts: every
 * path adds it before the first pair, in int32.  The codevectors are kept
 * sorted by the sum of their components, in runs of 16; the SIMD kernels
 * skip the runs that a Cauchy-Schwarz bound on that sum rules out (exact,
 * in integers: see the pruned order below), and search codebooks of up
 * to 32 entries sixteen vectors at a time instead.  vq_nearest_warm
 * starts each search with the cost of a guessed index (a previous
 * assignment) as the bound, and takes the guess at the end only if
 * nothing visited costs less, or as much at a lower index: the same
 * answers, fewer runs visited.
 *
 * Training is LBG (vq_train_double) and, for the rate-distortion mode,
 * entropy-constrained refinement (vq_train_ecvq: Chou, Lookabaugh and
 * Gray's ECVQ, the assignment by distortion + lambda * code length).
 */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/vq.h"
#include "codec/vq_int.h"
#include "codec/x86/vq_avx2.h"
#include "codec/x86/vq_avx512.h"

/* Padding codevectors fill the SIMD lanes past k: -32000 in the first two
 * dimensions and 0 elsewhere, with bias 0.  Against any residual
 * (|x| <= 255) their distance is over 2.01e9, far above any real cost (at
 * most VQ_BIAS_MAX + 12 * 383^2 < 1.08e9), yet the int16 differences and
 * the int32 sums cannot overflow (at most 2.09e9); so they are never
 * chosen and every path returns what the portable loop returns. */
#define PAD_VALUE (-32000)

void vq_search_prepare(struct vq_search *s, const int8_t *book, int k, int dim)
{
    s->k = k;
    s->dim = dim;
    s->kpad = (k + 15) & ~15;
    /* Counting sort by sum: stable, so equal sums stay in index order. */
    uint32_t start[SUM_SPAN + 1] = {0};
    int32_t sum[VQ_MAXK];
    for (int i = 0; i < k; i++) {
        int t = 0;
        for (int d = 0; d < dim; d++)
            t += book[i * dim + d];
        sum[i] = t;
        start[t - SUM_LO + 1]++;
    }
    for (int v = 0; v < SUM_SPAN; v++)
        start[v + 1] += start[v];
    for (int i = 0; i < k; i++)
        s->orig[start[sum[i] - SUM_LO]++] = i;
    for (int p = 0; p < k; p++)
        s->pos[s->orig[p]] = p;
    for (int j = 0; j < dim / 2; j++) {
        for (int p = 0; p < k; p++) {
            const int8_t *cv = book + s->orig[p] * dim;
            s->pairs[j * s->kpad + p] = pack_pair(cv[2 * j], cv[2 * j + 1]);
        }
        for (int p = k; p < s->kpad; p++)
            s->pairs[j * s->kpad + p] = j == 0 ? pack_pair(PAD_VALUE, PAD_VALUE) : 0;
    }
    for (int p = k; p < s->kpad; p++)
        s->orig[p] = INT32_MAX;
    /* Runs of 16: the sums of their real codevectors (the padding never
     * wins, so it need not be bounded). */
    for (int r = 0; r < s->kpad / 16; r++) {
        s->run_smin[r] = sum[s->orig[16 * r]];
        int last = 16 * r + 15 < k ? 16 * r + 15 : k - 1;
        s->run_smax[r] = sum[s->orig[last]];
    }
    for (int v = 0, r = 0, last = s->kpad / 16 - 1; v <= SUM_SPAN; v++) {
        while (r < last && s->run_smax[r] < v + SUM_LO)
            r++;
        s->run_at[v] = (uint16_t)r;
    }
    vq_search_set_bias(s, NULL);
}

void vq_search_set_bias(struct vq_search *s, const int32_t *bias)
{
    for (int p = 0; p < s->k; p++) {
        int32_t b = bias ? bias[s->orig[p]] : 0;
        s->bias[p] = b < 0 ? 0 : (b > VQ_BIAS_MAX ? VQ_BIAS_MAX : b);
    }
    for (int p = s->k; p < s->kpad; p++)
        s->bias[p] = 0;
    for (int r = 0; r < s->kpad / 16; r++) {
        int32_t m = VQ_BIAS_MAX;
        for (int p = 16 * r; p < 16 * r + 16 && p < s->k; p++)
            m = s->bias[p] < m ? s->bias[p] : m;
        s->run_bmin[r] = m;
    }
}

/* The exhaustive search: the least cost, and among equal costs the least
 * original index.  The SIMD paths must return exactly this. */
static void nearest_portable(const struct vq_search *s, const int16_t *vecs,
                             size_t n, uint16_t *idx, uint32_t *dist)
{
    const int k = s->k, pairs = s->dim / 2, stride = s->kpad;
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = vecs + i * VQ_STRIDE;
        uint32_t best = UINT32_MAX;
        int32_t besti = INT32_MAX;
        for (int p = 0; p < k; p++) {
            uint32_t d = (uint32_t)s->bias[p];
            for (int j = 0; j < pairs; j++) {
                int32_t pr = s->pairs[j * stride + p];
                int d0 = x[2 * j] - (int16_t)(pr & 0xffff);
                int d1 = x[2 * j + 1] - (int16_t)((uint32_t)pr >> 16);
                d += (uint32_t)(d0 * d0 + d1 * d1);
            }
            if (d < best || (d == best && s->orig[p] < besti)) {
                best = d;
                besti = s->orig[p];
            }
        }
        idx[i] = (uint16_t)besti;
        if (dist)
            dist[i] = best;
    }
}

static void nearest_c(const struct vq_search *s, const int16_t *vecs,
                      size_t n, uint16_t *idx, uint32_t *dist, int warm)
{
    (void)warm;   /* the exhaustive search needs no bound */
    nearest_portable(s, vecs, n, idx, dist);
}

static vq_nearest_fn *nearest_kernel = nearest_c;
static struct gv_cpu_once nearest_once = GV_CPU_ONCE_INIT;

static void vq_dsp_init(unsigned flags)
{
    nearest_kernel = nearest_c;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_AVX512)
        nearest_kernel = gv_vq_nearest_avx512;
    else if (flags & GV_CPU_AVX2)
        nearest_kernel = gv_vq_nearest_avx2;
#else
    (void)flags;
#endif
}

void vq_nearest(const struct vq_search *s, const int16_t *vecs, size_t n,
                uint16_t *idx, uint32_t *dist)
{
    gv_cpu_once(&nearest_once, vq_dsp_init);
    nearest_kernel(s, vecs, n, idx, dist, 0);
}

void vq_nearest_warm(const struct vq_search *s, const int16_t *vecs, size_t n,
                     uint16_t *idx, uint32_t *dist)
{
    gv_cpu_once(&nearest_once, vq_dsp_init);
    nearest_kernel(s, vecs, n, idx, dist, 1);
}

static inline int8_t clamp_s8(long v)
{
    return (int8_t)(v < -128 ? -128 : (v > 127 ? 127 : v));
}

/* Rounded mean, half away from zero, in the signed 8-bit range. */
static inline int8_t mean_s8(int64_t sum, uint32_t n)
{
    double m = (double)sum / n;
    return clamp_s8(lround(m));
}

void vq_train_init(struct vq_trainer *t, int dim, const int16_t *sample,
                   size_t n)
{
    t->dim = dim;
    t->k = 1;
    for (int d = 0; d < dim; d++) {
        int64_t s = 0;
        for (size_t i = 0; i < n; i++)
            s += sample[i * VQ_STRIDE + d];
        t->book[d] = n ? mean_s8(s, (uint32_t)n) : 0;
    }
}

/* Principal axis of the m vectors of a cell (sample rows members[0..m),
 * in increasing order) by power iteration; returns the variance along it
 * and the unit axis in e. */
static double principal_axis(const struct vq_trainer *t, const int16_t *sample,
                             const uint32_t *members, size_t m, double *e)
{
    const int dim = t->dim;
    double cov[VQ_MAXDIM * VQ_MAXDIM] = {0}, mean[VQ_MAXDIM] = {0};
    /* Start (and fallback for cells too small to have an axis): a fixed
     * direction with unequal weights, so it is not orthogonal to the axis
     * of typical residuals. */
    for (int a = 0; a < dim; a++)
        e[a] = 1.0 / sqrt((double)dim) * (a % 3 == 0 ? 1.0 : 0.9);
    for (size_t i = 0; i < m; i++) {
        const int16_t *x = sample + (size_t)members[i] * VQ_STRIDE;
        for (int a = 0; a < dim; a++) {
            mean[a] += x[a];
            for (int b = 0; b <= a; b++)
                cov[a * dim + b] += (double)x[a] * x[b];
        }
    }
    if (m < 2)
        return 0.0;
    for (int a = 0; a < dim; a++)
        mean[a] /= (double)m;
    for (int a = 0; a < dim; a++)
        for (int b = 0; b <= a; b++) {
            double v = cov[a * dim + b] / (double)m - mean[a] * mean[b];
            cov[a * dim + b] = cov[b * dim + a] = v;
        }
    double lambda = 0.0;
    for (int it = 0; it < 12; it++) {
        double y[VQ_MAXDIM], norm = 0.0;
        for (int a = 0; a < dim; a++) {
            y[a] = 0.0;
            for (int b = 0; b < dim; b++)
                y[a] += cov[a * dim + b] * e[b];
            norm += y[a] * y[a];
        }
        norm = sqrt(norm);
        if (norm <= 1e-12)
            return 0.0;
        for (int a = 0; a < dim; a++)
            e[a] = y[a] / norm;
        lambda = norm;
    }
    return lambda;
}

/* Split every cell c of the current book into c +/- 0.8 sigma along its
 * principal axis (the half-means of a Gaussian lie at +/-0.8 sigma),
 * doubling t->k; idx is scratch for the assignment. */
static void split_cells(struct vq_trainer *t, const int16_t *sample, size_t n,
                        uint16_t *idx)
{
    const int dim = t->dim, k = t->k;
    vq_search_prepare(&t->search, t->book, k, dim);
    vq_nearest(&t->search, sample, n, idx, NULL);
    /* The members of every cell in sample order (a stable counting sort),
     * so each cell's sums run in the same order as a scan would. */
    memset(t->count, 0, sizeof(uint32_t) * (size_t)k);
    for (size_t i = 0; i < n; i++)
        t->count[idx[i]]++;
    uint32_t start = 0;
    for (int c = 0; c < k; c++) {
        uint32_t m = t->count[c];
        t->count[c] = start;
        start += m;
    }
    for (size_t i = 0; i < n; i++)
        t->members[t->count[idx[i]]++] = (uint32_t)i;
    for (int c = 0; c < k; c++) {
        double e[VQ_MAXDIM];
        const uint32_t end = t->count[c], first = c ? t->count[c - 1] : 0;
        double var = principal_axis(t, sample, t->members + first, end - first, e);
        double s = 0.8 * sqrt(var);
        if (s < 1.0)
            s = 1.0;
        for (int d = 0; d < dim; d++) {
            long base = t->book[c * dim + d];
            long off = lround(s * e[d]);
            t->book[(k + c) * dim + d] = clamp_s8(base - off);
            t->book[c * dim + d] = clamp_s8(base + off);
        }
    }
    t->k = 2 * k;
}

/* One LBG step after an assignment (idx, dist): every cell moves to the
 * rounded mean of its vectors; an empty cell is reseeded with the
 * worst-coded vector, each used once. */
static void move_cells(struct vq_trainer *t, const int16_t *sample, size_t n,
                       const uint16_t *idx, uint32_t *dist)
{
    const int dim = t->dim, kk = t->k;
    memset(t->sum, 0, sizeof(int64_t) * (size_t)kk * dim);
    memset(t->count, 0, sizeof(uint32_t) * (size_t)kk);
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = sample + i * VQ_STRIDE;
        int64_t *s = t->sum + (size_t)idx[i] * dim;
        for (int d = 0; d < dim; d++)
            s[d] += x[d];
        t->count[idx[i]]++;
    }
    for (int c = 0; c < kk; c++) {
        if (t->count[c]) {
            for (int d = 0; d < dim; d++)
                t->book[c * dim + d] = mean_s8(t->sum[c * dim + d], t->count[c]);
            continue;
        }
        size_t worst = 0;
        uint32_t wd = 0;
        for (size_t i = 0; i < n; i++)
            if (dist[i] > wd) {
                wd = dist[i];
                worst = i;
            }
        if (wd == 0)
            continue;
        for (int d = 0; d < dim; d++)
            t->book[c * dim + d] = clamp_s8(sample[worst * VQ_STRIDE + d]);
        dist[worst] = 0;
    }
}

uint64_t vq_train_double(struct vq_trainer *t, const int16_t *sample, size_t n,
                         int max_iters, uint16_t *idx, uint32_t *dist)
{
    split_cells(t, sample, n, idx);
    uint64_t prev = UINT64_MAX, total = 0;
    for (int it = 0; it < max_iters; it++) {
        /* idx holds the last assignment (the split's, first): a guess. */
        vq_search_prepare(&t->search, t->book, t->k, t->dim);
        vq_nearest_warm(&t->search, sample, n, idx, dist);
        total = 0;
        for (size_t i = 0; i < n; i++)
            total += dist[i];
        if (prev != UINT64_MAX && (double)(prev - total) < 0.005 * (double)total)
            break;
        if (total == 0)
            break;
        prev = total;
        move_cells(t, sample, n, idx, dist);
    }
    return total;
}

void vq_train_from(struct vq_trainer *t, const int8_t *book, int k, int dim)
{
    t->dim = dim;
    t->k = k;
    memcpy(t->book, book, (size_t)k * dim);
}

uint32_t vq_log2_q16(uint64_t x)
{
    int e = 63 - __builtin_clzll(x);
    /* The mantissa in [1, 2) as Q31; each squaring yields one more bit. */
    uint64_t m = e >= 31 ? x >> (e - 31) : x << (31 - e);
    uint32_t frac = 0;
    for (int b = 15; b >= 0; b--) {
        m = (m * m) >> 31;
        if (m >= (1ull << 32)) {
            frac |= 1u << b;
            m >>= 1;
        }
    }
    return (uint32_t)e << 16 | frac;
}

void vq_set_biases(struct vq_trainer *t, const uint16_t *idx, size_t n,
                   double lambda)
{
    const int kk = t->k;
    memset(t->count, 0, sizeof(uint32_t) * (size_t)kk);
    for (size_t i = 0; i < n; i++)
        t->count[idx[i]]++;
    const int64_t log_n = vq_log2_q16(n);
    for (int c = 0; c < kk; c++) {
        int64_t len = t->count[c] ? log_n - vq_log2_q16(t->count[c])
                                  : vq_log2_q16(2 * (uint64_t)n);
        double b = lambda * (double)(len > 0 ? len : 0) / 65536.0;
        t->bias[c] = b >= VQ_BIAS_MAX ? VQ_BIAS_MAX : (int32_t)lround(b);
    }
}

/* Every cell with vectors moves to their rounded mean (t->count is the
 * assignment's count); empty cells stay. */
static void move_used_cells(struct vq_trainer *t, const int16_t *sample,
                            size_t n, const uint16_t *idx)
{
    const int dim = t->dim, kk = t->k;
    memset(t->sum, 0, sizeof(int64_t) * (size_t)kk * dim);
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = sample + i * VQ_STRIDE;
        int64_t *s = t->sum + (size_t)idx[i] * dim;
        for (int d = 0; d < dim; d++)
            s[d] += x[d];
    }
    for (int c = 0; c < kk; c++)
        if (t->count[c])
            for (int d = 0; d < dim; d++)
                t->book[c * dim + d] = mean_s8(t->sum[c * dim + d], t->count[c]);
}

uint64_t vq_train_ecvq(struct vq_trainer *t, const int16_t *sample, size_t n,
                       double lambda, int iters, int warm, uint16_t *idx,
                       uint32_t *dist)
{
    uint64_t total = 0;
    memset(t->bias, 0, sizeof(int32_t) * (size_t)t->k);
    for (int it = 0;; it++) {
        vq_search_prepare(&t->search, t->book, t->k, t->dim);
        vq_search_set_bias(&t->search, t->bias);
        if (it || warm)
            vq_nearest_warm(&t->search, sample, n, idx, dist);
        else
            vq_nearest(&t->search, sample, n, idx, dist);
        total = 0;
        for (size_t i = 0; i < n; i++)
            total += dist[i];
        vq_set_biases(t, idx, n, lambda);
        if (it == iters)
            break;
        move_used_cells(t, sample, n, idx);
    }
    vq_search_set_bias(&t->search, t->bias);
    return total;
}
