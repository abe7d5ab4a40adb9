/*
 * vq_avx2.c - vq.c's nearest-codevector search in AVX2 (vq_avx2.h): the
 * walk of vq_walk.h over runs of 16 codevectors as two halves of 8 lanes,
 * two dimensions per 32-bit lane, so that one VPMADDWD gives
 * d0^2 + d1^2 for eight codevectors.
 *
 * Compiled with -mavx2 (Makefile.am, lib/codec/x86/libgvcodec_avx2.a):
 * nothing here may run before vq.c has checked GV_CPU_AVX2.
 */
#include <limits.h>
#include <stddef.h>

#include "base/cpu.h"
#include "codec/vq_int.h"
#include "codec/x86/vq_avx2.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* One run of 16 codevectors for the walk, as two halves of 8:
 * the costs, kept per lane where less than the lane's best (or equal
 * with a lower index); with ub, *ub is lowered to the least best when
 * some cost fell below it. */
__attribute__((always_inline)) static inline void
run8x2(const struct vq_search *s, int r, const __m256i *xp, int pairs,
       __m256i *best, __m256i *besti, int64_t *ub)
{
    const int k = s->kpad;
    __m256i any = _mm256_setzero_si256();
    const __m256i ubv = _mm256_set1_epi32(ub ? (int32_t)*ub : 0);
    for (int c = 16 * r; c < 16 * r + 16; c += 8) {
        __m256i acc = _mm256_loadu_si256((const __m256i *)(s->bias + c));
        for (int j = 0; j < pairs; j++) {
            __m256i cv = _mm256_loadu_si256((const __m256i *)(s->pairs + j * k + c));
            __m256i d = _mm256_sub_epi16(xp[j], cv);
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(d, d));
        }
        __m256i oi = _mm256_loadu_si256((const __m256i *)(s->orig + c));
        __m256i lt = _mm256_or_si256(
            _mm256_cmpgt_epi32(*best, acc),
            _mm256_and_si256(_mm256_cmpeq_epi32(*best, acc),
                             _mm256_cmpgt_epi32(*besti, oi)));
        *best = _mm256_blendv_epi8(*best, acc, lt);
        *besti = _mm256_blendv_epi8(*besti, oi, lt);
        if (ub)
            any = _mm256_or_si256(any, _mm256_cmpgt_epi32(ubv, acc));
    }
    if (ub && !_mm256_testz_si256(any, any)) {
        __m256i m = _mm256_min_epi32(*best, _mm256_shuffle_epi32(*best, 0x4e));
        m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0xb1));
        m = _mm256_min_epi32(m, _mm256_permute2x128_si256(m, m, 1));
        *ub = _mm256_cvtsi256_si32(m);
    }
}

/* The lane holding the least cost, the lowest index among equal ones. */
__attribute__((always_inline)) static inline void
reduce8(__m256i best, __m256i besti, int32_t *m_out, int32_t *mi_out)
{
    int32_t bd[8], bi[8];
    _mm256_storeu_si256((__m256i *)bd, best);
    _mm256_storeu_si256((__m256i *)bi, besti);
    int32_t m = bd[0], mi = bi[0];
    for (int l = 1; l < 8; l++)
        if (bd[l] < m || (bd[l] == m && bi[l] < mi)) {
            m = bd[l];
            mi = bi[l];
        }
    *m_out = m;
    *mi_out = mi;
}

#define WALK walk_avx2
#define VEC __m256i
#define SPLAT(v) _mm256_set1_epi32(v)
#define RUN(r, ub) run8x2(s, r, xp, pairs, &best, &besti, ub)
#define REDUCE(m, mi) reduce8(best, besti, &m, &mi)
#include "codec/x86/vq_walk.h"

void gv_vq_nearest_avx2(const struct vq_search *s, const int16_t *vecs,
                        size_t n, uint16_t *idx, uint32_t *dist, int warm)
{
    if (s->dim == 12)
        walk_avx2(s, vecs, n, idx, dist, 6, warm);
    else if (s->dim == 4)
        walk_avx2(s, vecs, n, idx, dist, 2, warm);
    else
        walk_avx2(s, vecs, n, idx, dist, s->dim / 2, warm);
}
#endif
