/*
 * mesh_distance.c - geometric error between two triangle meshes:
 * symmetric Hausdorff distance and RMS surface distance, by our own
 * sampler.
 *
 *   mesh_distance A B [SAMPLES]
 *
 * Each mesh (PLY, OBJ or GLB, lib/mesh/io/mesh_read.h) is sampled at its
 * vertices (every k-th when it has more than SAMPLES) and at SAMPLES points (default 200000) spread over its
 * triangles in proportion to their area (a fixed linear congruential
 * generator: the same numbers on every run); each sample's distance to
 * the nearest point of the other mesh is found through a uniform grid of
 * that mesh's triangles, searched in growing shells until no unsearched
 * cell can be nearer.  Prints one line:
 *   hausdorff H rms R a_to_b H1 b_to_a H2 diag D
 * H = max(H1, H2), R the root mean square over both sample sets, D the
 * diagonal of A's bounding box (to scale the figures).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_read.h"

struct grid {
    const struct gv_mesh *m;
    double lo[3], cell;
    int n[3];
    uint32_t *start, *items;   /* CSR: cell -> triangles */
};

static double clampd(double x, double a, double b)
{
    return x < a ? a : x > b ? b : x;
}

static void sub(double *r, const double *a, const double *b)
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static double dot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Squared distance from p to triangle abc (Ericson, Real-Time Collision
 * Detection, 5.1.5). */
static double tri_dist2(const double *p, const double *a, const double *b,
                        const double *c)
{
    double ab[3], ac[3], ap[3], q[3];
    sub(ab, b, a);
    sub(ac, c, a);
    sub(ap, p, a);
    double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) {
        memcpy(q, a, sizeof q);
        goto done;
    }
    double bp[3];
    sub(bp, p, b);
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        memcpy(q, b, sizeof q);
        goto done;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        for (int k = 0; k < 3; k++) q[k] = a[k] + v * ab[k];
        goto done;
    }
    double cp[3];
    sub(cp, p, c);
    double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        memcpy(q, c, sizeof q);
        goto done;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double w = d2 / (d2 - d6);
        for (int k = 0; k < 3; k++) q[k] = a[k] + w * ac[k];
        goto done;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int k = 0; k < 3; k++) q[k] = b[k] + w * (c[k] - b[k]);
        goto done;
    }
    double den = 1.0 / (va + vb + vc), v = vb * den, w = vc * den;
    for (int k = 0; k < 3; k++) q[k] = a[k] + ab[k] * v + ac[k] * w;
done:;
    double d[3];
    sub(d, p, q);
    return dot(d, d);
}

static void vert(const struct gv_mesh *m, uint32_t i, double *v)
{
    for (int k = 0; k < 3; k++)
        v[k] = m->pos[3 * (size_t)i + k];
}

static int cell_of(const struct grid *g, double x, int k)
{
    return (int)clampd(floor((x - g->lo[k]) / g->cell), 0, g->n[k] - 1);
}

static void grid_build(struct grid *g, const struct gv_mesh *m)
{
    double hi[3] = {-1e300, -1e300, -1e300};
    g->m = m;
    for (int k = 0; k < 3; k++) g->lo[k] = 1e300;
    for (uint32_t i = 0; i < m->nverts; i++)
        for (int k = 0; k < 3; k++) {
            double x = m->pos[3 * (size_t)i + k];
            g->lo[k] = x < g->lo[k] ? x : g->lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    double ext = 0;
    for (int k = 0; k < 3; k++) ext = fmax(ext, hi[k] - g->lo[k]);
    if (ext <= 0) ext = 1;
    double cells = fmax(1, 2.0 * m->ntris);   /* ~ a few triangles a cell */
    double vol = 1;
    for (int k = 0; k < 3; k++) vol *= fmax(hi[k] - g->lo[k], ext * 1e-3);
    g->cell = cbrt(vol / cells);
    for (int k = 0; k < 3; k++) {
        double n = ceil((hi[k] - g->lo[k]) / g->cell) + 1;
        g->n[k] = (int)clampd(n, 1, 1024);
    }
    size_t nc = (size_t)g->n[0] * g->n[1] * g->n[2];
    g->start = calloc(nc + 1, sizeof *g->start);
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t t = 0; t < m->ntris; t++) {
            int a[3], b[3];
            for (int k = 0; k < 3; k++) {
                double mn = 1e300, mx = -1e300;
                for (int c = 0; c < 3; c++) {
                    double x = m->pos[3 * (size_t)m->tris[3 * (size_t)t + c] + k];
                    mn = fmin(mn, x);
                    mx = fmax(mx, x);
                }
                a[k] = cell_of(g, mn, k);
                b[k] = cell_of(g, mx, k);
            }
            for (int z = a[2]; z <= b[2]; z++)
                for (int y = a[1]; y <= b[1]; y++)
                    for (int x = a[0]; x <= b[0]; x++) {
                        size_t c = ((size_t)z * g->n[1] + y) * g->n[0] + x;
                        if (pass == 0)
                            g->start[c + 1]++;
                        else
                            g->items[g->start[c]++] = t;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < nc; c++) g->start[c + 1] += g->start[c];
            g->items = malloc((g->start[nc] ? g->start[nc] : 1) * sizeof *g->items);
        } else {
            for (size_t c = nc; c > 0; c--) g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
}

/* Distance from p to the nearest triangle of the grid's mesh. */
static double nearest(const struct grid *g, const double *p)
{
    int c[3];
    for (int k = 0; k < 3; k++) c[k] = cell_of(g, p[k], k);
    double best = INFINITY;
    int maxr = g->n[0] + g->n[1] + g->n[2];
    for (int r = 0; r <= maxr; r++) {
        for (int z = c[2] - r; z <= c[2] + r; z++) {
            if (z < 0 || z >= g->n[2]) continue;
            for (int y = c[1] - r; y <= c[1] + r; y++) {
                if (y < 0 || y >= g->n[1]) continue;
                for (int x = c[0] - r; x <= c[0] + r; x++) {
                    if (x < 0 || x >= g->n[0]) continue;
                    if (abs(x - c[0]) != r && abs(y - c[1]) != r &&
                        abs(z - c[2]) != r)
                        continue;   /* only the shell */
                    size_t cc = ((size_t)z * g->n[1] + y) * g->n[0] + x;
                    for (uint32_t i = g->start[cc]; i < g->start[cc + 1]; i++) {
                        const uint32_t *t = g->m->tris + 3 * (size_t)g->items[i];
                        double a[3], b[3], d[3];
                        vert(g->m, t[0], a);
                        vert(g->m, t[1], b);
                        vert(g->m, t[2], d);
                        double e = tri_dist2(p, a, b, d);
                        best = e < best ? e : best;
                    }
                }
            }
        }
        /* every unsearched cell is at least r * cell away (p clamped into
         * the grid may be outside: then this is conservative anyway) */
        double reach = r * g->cell;
        if (best < INFINITY && best <= reach * reach)
            break;
    }
    return sqrt(best);
}

static uint64_t lcg = 88172645463325252ull;
static double urand(void)
{
    lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(lcg >> 11) / 9007199254740992.0;
}

/* Sample m (vertices + n area-weighted points) against g: max and sum of
 * squares. */
static void sample(const struct gv_mesh *m, const struct grid *g, long n,
                   double *mx, double *sum2, long *count)
{
    double *cum = malloc((m->ntris + 1) * sizeof *cum);
    cum[0] = 0;
    for (uint32_t t = 0; t < m->ntris; t++) {
        double a[3], b[3], c[3], u[3], v[3];
        vert(m, m->tris[3 * (size_t)t], a);
        vert(m, m->tris[3 * (size_t)t + 1], b);
        vert(m, m->tris[3 * (size_t)t + 2], c);
        sub(u, b, a);
        sub(v, c, a);
        double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
               z = u[0] * v[1] - u[1] * v[0];
        cum[t + 1] = cum[t] + 0.5 * sqrt(x * x + y * y + z * z);
    }
    *mx = 0;
    *sum2 = 0;
    *count = 0;
    uint32_t step = n > 0 && m->nverts > n ? (uint32_t)(m->nverts / n) : 1;
    for (uint32_t i = 0; i < m->nverts; i += step) {
        double p[3];
        vert(m, i, p);
        double d = nearest(g, p);
        *mx = fmax(*mx, d);
        *sum2 += d * d;
        ++*count;
    }
    for (long s = 0; s < n && m->ntris && cum[m->ntris] > 0; s++) {
        double r = urand() * cum[m->ntris];
        uint32_t lo = 0, hi = m->ntris - 1;
        while (lo < hi) {
            uint32_t mid = (lo + hi) / 2;
            if (cum[mid + 1] < r) lo = mid + 1; else hi = mid;
        }
        double a[3], b[3], c[3], p[3];
        vert(m, m->tris[3 * (size_t)lo], a);
        vert(m, m->tris[3 * (size_t)lo + 1], b);
        vert(m, m->tris[3 * (size_t)lo + 2], c);
        double u = urand(), v = urand();
        if (u + v > 1) { u = 1 - u; v = 1 - v; }
        for (int k = 0; k < 3; k++)
            p[k] = a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]);
        double d = nearest(g, p);
        *mx = fmax(*mx, d);
        *sum2 += d * d;
        ++*count;
    }
    free(cum);
}

static int load(const char *path, struct gv_mesh *m)
{
    FILE *f = fopen(path, "rb");
    if (!f) return -1;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc(n > 0 ? (size_t)n : 1);
    size_t got = fread(b, 1, (size_t)n, f);
    fclose(f);
    struct gv_error err = {0};
    int rc = gv_mesh_read(b, got, GV_MESH_IN_AUTO, NULL, m, &err);
    if (rc < 0)
        fprintf(stderr, "mesh_distance: %s: %s\n", path, err.text);
    free(b);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: mesh_distance A B [SAMPLES]\n");
        return 2;
    }
    long n = argc > 3 ? atol(argv[3]) : 200000;
    struct gv_mesh a, b;
    if (load(argv[1], &a) < 0 || load(argv[2], &b) < 0)
        return 1;
    if (!a.ntris || !b.ntris) {
        printf("hausdorff inf rms inf a_to_b inf b_to_a inf diag 0\n");
        return 0;
    }
    struct grid ga, gb;
    grid_build(&ga, &a);
    grid_build(&gb, &b);
    double m1, s1, m2, s2;
    long c1, c2;
    sample(&a, &gb, n, &m1, &s1, &c1);
    sample(&b, &ga, n, &m2, &s2, &c2);
    double diag = 0, lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (uint32_t i = 0; i < a.nverts; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], a.pos[3 * (size_t)i + k]);
            hi[k] = fmax(hi[k], a.pos[3 * (size_t)i + k]);
        }
    for (int k = 0; k < 3; k++) diag += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    printf("hausdorff %.6g rms %.6g a_to_b %.6g b_to_a %.6g diag %.6g\n",
           fmax(m1, m2), sqrt((s1 + s2) / (double)(c1 + c2)), m1, m2, sqrt(diag));
    gv_mesh_free(&a);
    gv_mesh_free(&b);
    free(ga.start); free(ga.items); free(gb.start); free(gb.items);
    return 0;
}
