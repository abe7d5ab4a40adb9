/*
 * predict_avx512icl.c - the prediction's level 3 (predict_avx512icl.h):
 * the horizontal sums straight into the interleaved child order by
 * VPERMB and VPMADDUBSW (AVX-512 VBMI), and the vertical sum on pairs of
 * rows by VPDPWSSD (AVX-512 VNNI).
 *
 * Compiled with -mavx512f -mavx512bw -mavx512vbmi -mavx512vnni
 * (Makefile.am, lib/codec/x86/libgvcodec_avx512icl.a): nothing here may
 * run before predict.c has checked all three flags.
 */
#include <pthread.h>

#include "base/cpu.h"
#include "codec/predict_int.h"
#include "codec/x86/predict_avx512icl.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

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
static void
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
void gv_predict_filter_row_vbmi(const uint8_t *src, int C, int qx,
                                int16_t *dst)
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

/*
 * The vertical sum on pairs of rows.  A child row is
 * w0 h[t] + w1 h[t+1] + w2 h[t+2] + w3 h[t+3], rows clamped to the tile;
 * the pairs (h[t], h[t+1]) and (h[t+2], h[t+3]) are interleaved once into
 * 16-bit pairs (as VPUNPCKLWD / VPUNPCKHWD would, 32 samples of each row
 * per 64 values) and kept, since each serves four child rows, so a child
 * row takes two loads and two VPMADDWD per 32 samples and no unpacking.
 */
void gv_predict_interleave_pair_avx512(const int16_t *a, const int16_t *b,
                                       size_t n, int16_t *dst)
{
    /* Whole groups of 64 samples (the padding zero), as
     * gv_predict_vertical_pairs_vnni reads them. */
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
__attribute__((always_inline)) static inline __m512i
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
void gv_predict_vertical_pairs_vnni(const int16_t *p0, const int16_t *p1,
                                    const int *w, size_t n, uint8_t *out)
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
#endif
