/*
 * vq.c - exact nearest-codevector search and LBG training.
 *
 * The search packs two dimensions per 32-bit lane so that one
 * _mm256_madd_epi16 yields d0^2 + d1^2 for eight codevectors at once; a
 * codevector needs dim/2 (6 for RGB) load-subtract-madd-add steps.  An
 * AVX-512 kernel (16 codevectors at once) or the AVX2 one is chosen at run
 * time (GIGAVIEW_NO_AVX512 in the environment rules out the first), and
 * each returns exactly what the portable loop returns (strictly-less
 * comparison in index order, ties to the lowest index), so stores do not
 * depend on the CPU that wrote them.  A per-codevector bias is where each
 * cost starts: every path adds it before the first pair, in int32.
 *
 * Training is LBG (vq_train_double) and, for the rate-distortion mode,
 * entropy-constrained refinement (vq_train_ecvq: Chou, Lookabaugh and
 * Gray's ECVQ, the assignment by distortion + lambda * code length).
 */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define VQ_HAVE_X86 1
#endif

#include "codec/vq.h"

static inline int32_t pack_pair(int a, int b)
{
    return (int32_t)(((uint32_t)(uint16_t)(int16_t)b << 16) |
                     (uint16_t)(int16_t)a);
}

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
    for (int j = 0; j < dim / 2; j++) {
        for (int i = 0; i < k; i++)
            s->pairs[j * s->kpad + i] =
                pack_pair(book[i * dim + 2 * j], book[i * dim + 2 * j + 1]);
        for (int i = k; i < s->kpad; i++)
            s->pairs[j * s->kpad + i] = j == 0 ? pack_pair(PAD_VALUE, PAD_VALUE) : 0;
    }
    memset(s->bias, 0, sizeof(int32_t) * (size_t)s->kpad);
}

void vq_search_set_bias(struct vq_search *s, const int32_t *bias)
{
    for (int i = 0; i < s->k; i++) {
        int32_t b = bias ? bias[i] : 0;
        s->bias[i] = b < 0 ? 0 : (b > VQ_BIAS_MAX ? VQ_BIAS_MAX : b);
    }
}

static void nearest_portable(const struct vq_search *s, const int16_t *vecs,
                             size_t n, uint16_t *idx, uint32_t *dist)
{
    const int k = s->k, pairs = s->dim / 2, stride = s->kpad;
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = vecs + i * VQ_STRIDE;
        uint32_t best = UINT32_MAX;
        int besti = 0;
        for (int c = 0; c < k; c++) {
            uint32_t d = (uint32_t)s->bias[c];
            for (int j = 0; j < pairs; j++) {
                int32_t p = s->pairs[j * stride + c];
                int d0 = x[2 * j] - (int16_t)(p & 0xffff);
                int d1 = x[2 * j + 1] - (int16_t)((uint32_t)p >> 16);
                d += (uint32_t)(d0 * d0 + d1 * d1);
            }
            if (d < best) {
                best = d;
                besti = c;
            }
        }
        idx[i] = (uint16_t)besti;
        if (dist)
            dist[i] = best;
    }
}

#ifdef VQ_HAVE_X86
/* The search eight codevectors at a time.  nearest_avx512 repeats this
 * loop on purpose, with 16 lanes and mask registers: one generic kernel
 * would need the width and the compare-and-blend as parameters and would
 * no longer compile to either instruction set's best form.  A change to
 * one kernel must be made to the other, and to nearest_portable, which
 * both must match exactly. */
__attribute__((target("avx2"))) static void
nearest_avx2(const struct vq_search *s, const int16_t *vecs, size_t n,
             uint16_t *idx, uint32_t *dist)
{
    const int k = s->kpad, pairs = s->dim / 2;
    const __m256i step = _mm256_set1_epi32(8);
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = vecs + i * VQ_STRIDE;
        __m256i xp[VQ_MAXDIM / 2];
        for (int j = 0; j < pairs; j++)
            xp[j] = _mm256_set1_epi32(pack_pair(x[2 * j], x[2 * j + 1]));
        __m256i best = _mm256_set1_epi32(INT_MAX);
        __m256i besti = _mm256_setzero_si256();
        __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for (int c = 0; c < k; c += 8) {
            __m256i acc = _mm256_loadu_si256((const __m256i *)(s->bias + c));
            for (int j = 0; j < pairs; j++) {
                __m256i cv = _mm256_loadu_si256(
                    (const __m256i *)(s->pairs + j * k + c));
                __m256i d = _mm256_sub_epi16(xp[j], cv);
                acc = _mm256_add_epi32(acc, _mm256_madd_epi16(d, d));
            }
            __m256i lt = _mm256_cmpgt_epi32(best, acc);
            best = _mm256_blendv_epi8(best, acc, lt);
            besti = _mm256_blendv_epi8(besti, lane, lt);
            lane = _mm256_add_epi32(lane, step);
        }
        int32_t bd[8], bi[8];
        _mm256_storeu_si256((__m256i *)bd, best);
        _mm256_storeu_si256((__m256i *)bi, besti);
        int32_t m = bd[0], mi = bi[0];
        for (int l = 1; l < 8; l++)
            if (bd[l] < m || (bd[l] == m && bi[l] < mi)) {
                m = bd[l];
                mi = bi[l];
            }
        idx[i] = (uint16_t)mi;
        if (dist)
            dist[i] = (uint32_t)m;
    }
}
#endif

#ifdef VQ_HAVE_X86
/* The same search sixteen codevectors at a time: a deliberate repeat of
 * nearest_avx2 for AVX-512 (see there why), returning exactly what it and
 * nearest_portable return. */
__attribute__((target("avx512f,avx512bw"))) static void
nearest_avx512(const struct vq_search *s, const int16_t *vecs, size_t n,
               uint16_t *idx, uint32_t *dist)
{
    const int k = s->kpad, pairs = s->dim / 2;
    const __m512i step = _mm512_set1_epi32(16);
    const __m512i first = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10,
                                            11, 12, 13, 14, 15);
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = vecs + i * VQ_STRIDE;
        __m512i xp[VQ_MAXDIM / 2];
        for (int j = 0; j < pairs; j++)
            xp[j] = _mm512_set1_epi32(pack_pair(x[2 * j], x[2 * j + 1]));
        __m512i best = _mm512_set1_epi32(INT_MAX);
        __m512i besti = _mm512_setzero_si512();
        __m512i lane = first;
        for (int c = 0; c < k; c += 16) {
            __m512i acc = _mm512_loadu_si512(s->bias + c);
            for (int j = 0; j < pairs; j++) {
                __m512i cv = _mm512_loadu_si512(s->pairs + j * k + c);
                __m512i d = _mm512_sub_epi16(xp[j], cv);
                acc = _mm512_add_epi32(acc, _mm512_madd_epi16(d, d));
            }
            __mmask16 lt = _mm512_cmpgt_epi32_mask(best, acc);
            best = _mm512_mask_mov_epi32(best, lt, acc);
            besti = _mm512_mask_mov_epi32(besti, lt, lane);
            lane = _mm512_add_epi32(lane, step);
        }
        /* Smallest distance, then the lowest index among lanes holding it. */
        int32_t m = _mm512_reduce_min_epi32(best);
        __mmask16 at = _mm512_cmpeq_epi32_mask(best, _mm512_set1_epi32(m));
        idx[i] = (uint16_t)_mm512_mask_reduce_min_epi32(at, besti);
        if (dist)
            dist[i] = (uint32_t)m;
    }
}
#endif

int vq_nearest_path(enum vq_path path, const struct vq_search *s,
                    const int16_t *vecs, size_t n, uint16_t *idx,
                    uint32_t *dist)
{
    switch (path) {
    case VQ_PATH_PORTABLE:
        nearest_portable(s, vecs, n, idx, dist);
        return 0;
#ifdef VQ_HAVE_X86
    case VQ_PATH_AVX2:
        if (!__builtin_cpu_supports("avx2"))
            return -1;
        nearest_avx2(s, vecs, n, idx, dist);
        return 0;
    case VQ_PATH_AVX512:
        if (!__builtin_cpu_supports("avx512f") || !__builtin_cpu_supports("avx512bw"))
            return -1;
        nearest_avx512(s, vecs, n, idx, dist);
        return 0;
#endif
    default:
        return -1;
    }
}

void vq_nearest(const struct vq_search *s, const int16_t *vecs, size_t n,
                uint16_t *idx, uint32_t *dist)
{
#ifdef VQ_HAVE_X86
    static int have_avx2 = -1, have_avx512 = -1;
    if (have_avx2 < 0) {
        have_avx512 = __builtin_cpu_supports("avx512f") &&
                      __builtin_cpu_supports("avx512bw") &&
                      !getenv("GIGAVIEW_NO_AVX512");
        have_avx2 = __builtin_cpu_supports("avx2") ? 1 : 0;
    }
    if (have_avx512) {
        nearest_avx512(s, vecs, n, idx, dist);
        return;
    }
    if (have_avx2) {
        nearest_avx2(s, vecs, n, idx, dist);
        return;
    }
#endif
    nearest_portable(s, vecs, n, idx, dist);
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

/* Principal axis of the vectors assigned to cell c by power iteration;
 * returns the variance along it and the unit axis in e. */
static double principal_axis(const struct vq_trainer *t, const int16_t *sample,
                             size_t n, const uint16_t *idx, int c, double *e)
{
    const int dim = t->dim;
    double cov[VQ_MAXDIM * VQ_MAXDIM] = {0}, mean[VQ_MAXDIM] = {0};
    size_t m = 0;
    /* Start (and fallback for cells too small to have an axis): a fixed
     * direction with unequal weights, so it is not orthogonal to the axis
     * of typical residuals. */
    for (int a = 0; a < dim; a++)
        e[a] = 1.0 / sqrt((double)dim) * (a % 3 == 0 ? 1.0 : 0.9);
    for (size_t i = 0; i < n; i++) {
        if (idx[i] != c)
            continue;
        const int16_t *x = sample + i * VQ_STRIDE;
        for (int a = 0; a < dim; a++) {
            mean[a] += x[a];
            for (int b = 0; b <= a; b++)
                cov[a * dim + b] += (double)x[a] * x[b];
        }
        m++;
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
    for (int c = 0; c < k; c++) {
        double e[VQ_MAXDIM];
        double var = principal_axis(t, sample, n, idx, c, e);
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
        vq_search_prepare(&t->search, t->book, t->k, t->dim);
        vq_nearest(&t->search, sample, n, idx, dist);
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
                       double lambda, int iters, uint16_t *idx, uint32_t *dist)
{
    uint64_t total = 0;
    memset(t->bias, 0, sizeof(int32_t) * (size_t)t->k);
    for (int it = 0;; it++) {
        vq_search_prepare(&t->search, t->book, t->k, t->dim);
        vq_search_set_bias(&t->search, t->bias);
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
