/*
 * edt_exact.c - exact squared Euclidean distance transforms (edt_exact.h).
 *
 * Felzenszwalb-Huttenlocher in two separable passes:
 *   1. columns: g(x, y) = distance to the nearest site in column x (a
 *      forward and a backward scan over rows, row-major friendly);
 *   2. rows: the lower envelope of the parabolas f(q) + (x - q)^2 with
 *      f(q) = g(q, y)^2, over the q where g is finite.
 * The textbook version keeps the envelope's breakpoints as doubles; here
 * each breakpoint is the fraction num / den with den = 2 (q - v) > 0, and
 * comparisons cross-multiply in int64, so the envelope is exact: the
 * result is the true minimum of dx^2 + dy^2 for every pixel.
 */
#include <stdlib.h>

#include "edt_exact.h"

#define G_INF UINT32_MAX

int edt_exact_d2(const uint32_t *ids, uint32_t w, uint32_t h, uint64_t *d2)
{
    uint32_t *g = NULL, *v = NULL;
    int64_t *zn = NULL, *zd = NULL;
    int rc = -1;

    if (w == 0 || h == 0 || w > EDT_EXACT_MAX_DIM || h > EDT_EXACT_MAX_DIM)
        return -1;
    g = malloc((size_t)w * h * sizeof *g);
    v = malloc((size_t)w * sizeof *v);
    zn = malloc(((size_t)w + 1) * sizeof *zn);
    zd = malloc(((size_t)w + 1) * sizeof *zd);
    if (!g || !v || !zn || !zd)
        goto out;

    /* 1. Column distances, downwards then upwards. */
    for (uint32_t x = 0; x < w; x++)
        g[x] = ids[x] ? 0 : G_INF;
    for (uint32_t y = 1; y < h; y++) {
        const uint32_t *id = ids + (size_t)y * w;
        uint32_t *gr = g + (size_t)y * w, *gp = gr - w;
        for (uint32_t x = 0; x < w; x++)
            gr[x] = id[x] ? 0 : gp[x] == G_INF ? G_INF : gp[x] + 1;
    }
    for (uint32_t y = h - 1; y-- > 0;) {
        uint32_t *gr = g + (size_t)y * w, *gn = gr + w;
        for (uint32_t x = 0; x < w; x++)
            if (gn[x] != G_INF && gn[x] + 1 < gr[x])
                gr[x] = gn[x] + 1;
    }

    /* 2. Rows: lower envelope of parabolas. */
    for (uint32_t y = 0; y < h; y++) {
        const uint32_t *gr = g + (size_t)y * w;
        uint64_t *out = d2 + (size_t)y * w;
        int64_t k = -1;
        for (uint32_t q = 0; q < w; q++) {
            if (gr[q] == G_INF)
                continue;
            int64_t fq = (int64_t)gr[q] * gr[q] + (int64_t)q * q;
            int64_t num = 0, den = 1;
            while (k >= 0) {
                int64_t p = v[k];
                int64_t fp = (int64_t)gr[p] * gr[p] + p * p;
                num = fq - fp;
                den = 2 * ((int64_t)q - p);
                /* Drop v[k] while the new breakpoint is at or before
                 * the one where v[k] starts (k = 0 starts at -inf). */
                if (k > 0 && num * zd[k] <= zn[k] * den)
                    k--;
                else
                    break;
            }
            k++;
            v[k] = q;
            if (k > 0) {
                zn[k] = num;
                zd[k] = den;
            }
        }
        if (k < 0) {
            for (uint32_t x = 0; x < w; x++)
                out[x] = EDT_EXACT_NONE;
            continue;
        }
        int64_t nseg = k + 1, s = 0;
        for (uint32_t x = 0; x < w; x++) {
            /* Segment s + 1 starts at zn/zd; move on while that is < x. */
            while (s + 1 < nseg && zn[s + 1] < (int64_t)x * zd[s + 1])
                s++;
            int64_t dx = (int64_t)x - v[s];
            out[x] = (uint64_t)((int64_t)gr[v[s]] * gr[v[s]] + dx * dx);
        }
    }
    rc = 0;
out:
    free(g);
    free(v);
    free(zn);
    free(zd);
    return rc;
}

void edt_brute_d2(const uint32_t *ids, uint32_t w, uint32_t h, uint64_t *d2)
{
    size_t n = (size_t)w * h;
    for (size_t p = 0; p < n; p++)
        d2[p] = EDT_EXACT_NONE;
    for (uint32_t sy = 0; sy < h; sy++)
        for (uint32_t sx = 0; sx < w; sx++) {
            if (!ids[(size_t)sy * w + sx])
                continue;
            for (uint32_t y = 0; y < h; y++)
                for (uint32_t x = 0; x < w; x++) {
                    int64_t dx = (int64_t)x - sx, dy = (int64_t)y - sy;
                    uint64_t d = (uint64_t)(dx * dx + dy * dy);
                    if (d < d2[(size_t)y * w + x])
                        d2[(size_t)y * w + x] = d;
                }
        }
}
