/*
 * vq_avx512.c - vq.c's nearest-codevector search in AVX-512 F and BW
 * (vq_avx512.h): the walk of vq_walk.h a run of 16 codevectors at a time
 * in one register, with mask registers for the compare-and-keep; and
 * codebooks of up to LANES_MAXK entries the other way round, sixteen
 * vectors at a time.
 *
 * Compiled with -mavx512f -mavx512bw (Makefile.am,
 * lib/codec/x86/libgvcodec_avx512.a): nothing here may run before vq.c
 * has checked GV_CPU_AVX512.
 */
#include <limits.h>
#include <stddef.h>

#include "base/cpu.h"
#include "codec/vq_int.h"
#include "codec/x86/vq_avx512.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

/* One run of 16 codevectors for the walk: the costs, kept per lane where
 * less than the lane's best (or equal with a lower index); with ub, *ub
 * is lowered to the least best when some cost fell below it. */
__attribute__((always_inline)) static inline void
run16(const struct vq_search *s, int r, const __m512i *xp, int pairs,
      __m512i *best, __m512i *besti, int64_t *ub)
{
    const int c = 16 * r, k = s->kpad;
    __m512i acc = _mm512_loadu_si512(s->bias + c);
    for (int j = 0; j < pairs; j++) {
        __m512i d = _mm512_sub_epi16(xp[j], _mm512_loadu_si512(s->pairs + j * k + c));
        acc = _mm512_add_epi32(acc, _mm512_madd_epi16(d, d));
    }
    __m512i oi = _mm512_loadu_si512(s->orig + c);
    __mmask16 lt = _mm512_cmpgt_epi32_mask(*best, acc) |
                   (_mm512_cmpeq_epi32_mask(*best, acc) &
                    _mm512_cmpgt_epi32_mask(*besti, oi));
    *best = _mm512_mask_mov_epi32(*best, lt, acc);
    *besti = _mm512_mask_mov_epi32(*besti, lt, oi);
    if (ub && _mm512_cmplt_epi32_mask(acc, _mm512_set1_epi32((int32_t)*ub)))
        *ub = _mm512_reduce_min_epi32(*best);
}

#define WALK walk_avx512
#define VEC __m512i
#define SPLAT(v) _mm512_set1_epi32(v)
#define RUN(r, ub) run16(s, r, xp, pairs, &best, &besti, ub)
#define REDUCE(m, mi)                                                      \
    do {                                                                   \
        m = _mm512_reduce_min_epi32(best);                                 \
        mi = _mm512_mask_reduce_min_epi32(                                 \
            _mm512_cmpeq_epi32_mask(best, _mm512_set1_epi32(m)), besti);   \
    } while (0)
#include "codec/x86/vq_walk.h"

/* Small codebooks the other way round: sixteen vectors at a time, one
 * per lane (their pairs gathered), against every codevector in turn, so
 * that no lane needs reducing.  The same costs and the same rule for ties
 * as the other kernels.  Returns how many vectors it did (a multiple of
 * 16); the rest are left to the walk. */
__attribute__((always_inline)) static inline size_t
nearest_lanes(const struct vq_search *s, const int16_t *vecs, size_t n,
                     uint16_t *idx, uint32_t *dist, const int pairs)
{
    const int k = s->k, kp = s->kpad;
    const __m512i rows = _mm512_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56, 64,
                                           72, 80, 88, 96, 104, 112, 120);
    size_t i = 0;
    for (; i + 16 <= n; i += 16) {
        const int32_t *base = (const int32_t *)(const void *)(vecs + i * VQ_STRIDE);
        __m512i xp[VQ_MAXDIM / 2];
        for (int j = 0; j < pairs; j++)
            xp[j] = _mm512_i32gather_epi32(
                _mm512_add_epi32(rows, _mm512_set1_epi32(j)), base, 4);
        __m512i best = _mm512_set1_epi32(INT_MAX);
        __m512i besti = _mm512_set1_epi32(INT_MAX);
        for (int p = 0; p < k; p++) {
            __m512i acc = _mm512_set1_epi32(s->bias[p]);
            for (int j = 0; j < pairs; j++) {
                __m512i d = _mm512_sub_epi16(xp[j], _mm512_set1_epi32(s->pairs[j * kp + p]));
                acc = _mm512_add_epi32(acc, _mm512_madd_epi16(d, d));
            }
            const __m512i oi = _mm512_set1_epi32(s->orig[p]);
            __mmask16 lt = _mm512_cmpgt_epi32_mask(best, acc) |
                           (_mm512_cmpeq_epi32_mask(best, acc) &
                            _mm512_cmpgt_epi32_mask(besti, oi));
            best = _mm512_mask_mov_epi32(best, lt, acc);
            besti = _mm512_mask_mov_epi32(besti, lt, oi);
        }
        _mm256_storeu_si256((__m256i *)(void *)(idx + i), _mm512_cvtepi32_epi16(besti));
        if (dist)
            _mm512_storeu_si512(dist + i, best);
    }
    return i;
}

/* Codebooks of at most this many entries go to nearest_lanes. */
#define LANES_MAXK 32

void gv_vq_nearest_avx512(const struct vq_search *s, const int16_t *vecs,
                          size_t n, uint16_t *idx, uint32_t *dist, int warm)
{
    size_t done = 0;
    if (s->k <= LANES_MAXK)
        done = s->dim == 12 ? nearest_lanes(s, vecs, n, idx, dist, 6) :
               s->dim == 4 ? nearest_lanes(s, vecs, n, idx, dist, 2) :
               nearest_lanes(s, vecs, n, idx, dist, s->dim / 2);
    vecs += done * VQ_STRIDE;
    idx += done;
    if (dist)
        dist += done;
    n -= done;
    if (s->dim == 12)
        walk_avx512(s, vecs, n, idx, dist, 6, warm);
    else if (s->dim == 4)
        walk_avx512(s, vecs, n, idx, dist, 2, warm);
    else
        walk_avx512(s, vecs, n, idx, dist, s->dim / 2, warm);
}
#endif
