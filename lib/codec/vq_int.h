/*
 * vq_int.h - what vq.c shares with its SIMD kernels (x86/vq_*.c): the
 * packing of two dimensions per 32-bit lane, the range of component sums
 * and the pruned order of the searches.  Not part of the codec's
 * interface.
 */
#ifndef GV_VQ_INT_H
#define GV_VQ_INT_H

#include <stdint.h>

#include "codec/vq.h"

static inline int32_t pack_pair(int a, int b)
{
    return (int32_t)(((uint32_t)(uint16_t)(int16_t)b << 16) |
                     (uint16_t)(int16_t)a);
}

/* The sum of a codevector's components ranges over SUM_LO .. -SUM_LO. */
#define SUM_LO (-128 * VQ_MAXDIM)
#define SUM_SPAN (256 * VQ_MAXDIM)

/*
 * The pruned order of the SIMD searches, for one vector whose components
 * sum to sx: the run where sx falls first (run_at), then the runs above
 * it, then those below it.  A run is skipped when even its best case, its
 * least bias plus ceil(gap^2 / dim) (gap: from sx to the run's sums),
 * exceeds the best cost found so far, and a direction ends when the gap
 * alone does (farther runs only have larger gaps).  Skipped runs cannot
 * hold the answer, not even a tie, so the result is the exhaustive one.
 * With integers, ceil(a / dim) > t is a > dim * t.  Searches of at most
 * SMALL_RUNS runs visit them all: there the branches cost more than the
 * runs they would skip.
 */
#define SMALL_RUNS 4

/* The run_at entry for a vector whose components sum to sx: residuals
 * reach +-255 per component, beyond the codevectors' sums, and there
 * the first run (below) or the last (above) is the start. */
static inline int run_key(int sx)
{
    int v = sx - SUM_LO;
    return v < 0 ? 0 : (v > SUM_SPAN ? SUM_SPAN : v);
}

/* The cost of codevector g for x (as every kernel computes it: bias plus
 * the squared differences, in int32 with no overflow), for warm starts. */
static inline int64_t guess_cost(const struct vq_search *s, const int16_t *x,
                                 int g, int pairs)
{
    const int p = s->pos[g];
    int32_t d = s->bias[p];
    for (int j = 0; j < pairs; j++) {
        int32_t pr = s->pairs[j * s->kpad + p];
        int d0 = x[2 * j] - (int16_t)(pr & 0xffff);
        int d1 = x[2 * j + 1] - (int16_t)((uint32_t)pr >> 16);
        d += d0 * d0 + d1 * d1;
    }
    return d;
}

/* A search kernel: vq_nearest (warm 0) or vq_nearest_warm (warm 1) on
 * one instruction set, the same answers as the portable loop. */
typedef void vq_nearest_fn(const struct vq_search *s, const int16_t *vecs,
                           size_t n, uint16_t *idx, uint32_t *dist, int warm);

#endif
