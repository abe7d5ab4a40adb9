/*
 * vq_walk.h - the nearest-codevector search walk of vq.c's SIMD kernels,
 * written once and instantiated per instruction set (as
 * filters/edt_kernel.h is): include it after defining
 *
 *   WALK                 the function's name
 *   VEC                  the vector of 32-bit lanes
 *   SPLAT(v)             v in every lane
 *   RUN(r, ub)           the costs of run r (16 codevectors) into best and
 *                        besti, per lane where less (or equal at a lower
 *                        index); ub: NULL, or the bound to lower to the
 *                        least best when a cost fell below it
 *   REDUCE(m, mi)        the least cost of best into m and the least
 *                        index among the lanes holding it into mi
 *
 * RUN and REDUCE see s, xp, pairs, best and besti.  The walk is the
 * pruned order of vq_int.h: all runs for small codebooks, else the run
 * where the vector's component sum falls, then outwards while a run's
 * best case can still beat the bound; a warm start bounds the search with
 * its guess's cost from the start and takes the guess at the end only if
 * nothing visited costs less, or as much at a lower index.  `pairs` is a
 * constant in each caller, so the inner loops unroll.
 */
__attribute__((always_inline)) static inline void
WALK(const struct vq_search *s, const int16_t *vecs, size_t n, uint16_t *idx,
     uint32_t *dist, const int pairs, int warm)
{
    const int64_t dim = 2 * pairs;
    const int nruns = s->kpad / 16;
    for (size_t i = 0; i < n; i++) {
        const int16_t *x = vecs + i * VQ_STRIDE;
        VEC xp[VQ_MAXDIM / 2];
        int sx = 0;
        for (int j = 0; j < pairs; j++) {
            xp[j] = SPLAT(pack_pair(x[2 * j], x[2 * j + 1]));
            sx += x[2 * j] + x[2 * j + 1];
        }
        VEC best = SPLAT(INT_MAX);
        VEC besti = SPLAT(INT_MAX);
        const int g = warm ? idx[i] : 0;
        int64_t gc = INT64_MAX;   /* the guess's cost, when it was used */
        if (nruns <= SMALL_RUNS) {
            for (int r = 0; r < nruns; r++)
                RUN(r, NULL);
        } else {
            int64_t ub = INT_MAX;
            if (warm)
                ub = gc = guess_cost(s, x, g, pairs);
            const int r0 = s->run_at[run_key(sx)];
            RUN(r0, &ub);
            for (int r = r0 + 1; r < nruns; r++) {
                const int64_t gap = s->run_smin[r] - sx;
                const int64_t g2 = gap > 0 ? gap * gap : 0;
                if (g2 > dim * ub)
                    break;
                if (g2 <= dim * (ub - s->run_bmin[r]))
                    RUN(r, &ub);
            }
            for (int r = r0 - 1; r >= 0; r--) {
                const int64_t gap = sx - s->run_smax[r];
                const int64_t g2 = gap > 0 ? gap * gap : 0;
                if (g2 > dim * ub)
                    break;
                if (g2 <= dim * (ub - s->run_bmin[r]))
                    RUN(r, &ub);
            }
        }
        /* Smallest cost, then the lowest index among lanes holding it;
         * then the guess, which the search may have skipped. */
        int32_t m, mi;
        REDUCE(m, mi);
        if (gc < m || (gc == m && g < mi)) {
            m = (int32_t)gc;
            mi = g;
        }
        idx[i] = (uint16_t)mi;
        if (dist)
            dist[i] = (uint32_t)m;
    }
}

#undef WALK
#undef VEC
#undef SPLAT
#undef RUN
#undef REDUCE
