/*
 * test_tin.c - greedy insertion TINs (lib/mesh/tin.c).
 *
 * The heap-driven algorithm III must insert exactly the vertices, in the
 * same order, that the brute-force algorithm I picks (Garland & Heckbert,
 * sections 4.1 and 4.4), on small grids of several kinds; every sample must
 * lie within the error bound, checked by an independent point location;
 * the triangulation must be Delaunay (no vertex strictly inside a
 * circumcircle, exact test) and tile the rectangle; the scans' segment
 * bounds must change no mesh, small or large; neighbours that share
 * an edge of samples must choose the same vertices on it whatever their
 * interiors hold.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/tin.h"
#include "mesh/tin_int.h"
#include "util.h"

static uint32_t rng = 12345;

static double frand(void)
{
    rng = rng * 1103515245u + 12345u;
    return (double)((rng >> 8) & 0xffff) / 65536.0;
}

/* kind 0: smooth hills plus noise; 1: integer codes (many ties);
 * 2: a step (cliff); 3: pure noise */
static float *field(uint32_t w, uint32_t h, int kind, uint32_t seed)
{
    float *f = malloc((size_t)w * h * sizeof *f);
    rng = seed;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            double v;
            if (kind == 0)
                v = 40 * sin(x * 0.21) * cos(y * 0.17) + 15 * sin(x * y * 0.01)
                    + 3 * frand();
            else if (kind == 1)
                v = (double)(int)(8 * sin(x * 0.3) + 6 * cos(y * 0.4));
            else if (kind == 2)
                v = (x + y > (w + h) / 2 ? 100.0 : 0.0) + (double)(x % 3);
            else
                v = 100 * frand();
            f[(size_t)y * w + x] = (float)v;
        }
    return f;
}

static int same_mesh(const struct gv_mesh *a, const struct gv_mesh *b)
{
    if (a->nverts != b->nverts || a->ntris != b->ntris)
        return 0;
    for (uint32_t i = 0; i < a->nverts; i++)
        if (gv_mesh_gx(a, i) != gv_mesh_gx(b, i) || gv_mesh_gy(a, i) != gv_mesh_gy(b, i))
            return 0;
    return memcmp(a->tris, b->tris, (size_t)a->ntris * 3 * 4) == 0 &&
           a->max_error == b->max_error;
}

static int64_t orient(int64_t ax, int64_t ay, int64_t bx, int64_t by,
                      int64_t cx, int64_t cy)
{
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

/* The largest |h - mesh| over every sample, each located by a linear
 * search and interpolated with barycentric weights (not tin.c's planes). */
static double independent_error(const float *f, const struct gv_mesh *t)
{
    double worst = 0;
    for (uint32_t y = 0; y < t->height; y++)
        for (uint32_t x = 0; x < t->width; x++) {
            int found = 0;
            for (uint32_t k = 0; k < t->ntris && !found; k++) {
                const uint32_t *v = t->tris + 3 * k;
                int64_t ax = gv_mesh_gx(t, v[0]), ay = gv_mesh_gy(t, v[0]);
                int64_t bx = gv_mesh_gx(t, v[1]), by = gv_mesh_gy(t, v[1]);
                int64_t cx = gv_mesh_gx(t, v[2]), cy = gv_mesh_gy(t, v[2]);
                int64_t wa = orient(bx, by, cx, cy, x, y);
                int64_t wb = orient(cx, cy, ax, ay, x, y);
                int64_t wc = orient(ax, ay, bx, by, x, y);
                if (wa < 0 || wb < 0 || wc < 0)
                    continue;
                double s = (double)(wa + wb + wc);
                double z = (wa * (double)gv_mesh_gz(t, v[0]) +
                            wb * (double)gv_mesh_gz(t, v[1]) +
                            wc * (double)gv_mesh_gz(t, v[2])) / s;
                double e = fabs(f[(size_t)y * t->width + x] - z);
                if (e > worst)
                    worst = e;
                found = 1;
            }
            if (!found)
                return INFINITY;
        }
    return worst;
}

__extension__ typedef __int128 i128;

static int delaunay_and_tiling(const struct gv_mesh *t)
{
    int64_t area = 0;
    for (uint32_t k = 0; k < t->ntris; k++) {
        const uint32_t *v = t->tris + 3 * k;
        int64_t o = orient(gv_mesh_gx(t, v[0]), gv_mesh_gy(t, v[0]), gv_mesh_gx(t, v[1]), gv_mesh_gy(t, v[1]),
                           gv_mesh_gx(t, v[2]), gv_mesh_gy(t, v[2]));
        if (o <= 0)
            return 0;
        area += o;
        for (uint32_t d = 0; d < t->nverts; d++) {
            int64_t adx = (int64_t)gv_mesh_gx(t, v[0]) - gv_mesh_gx(t, d);
            int64_t ady = (int64_t)gv_mesh_gy(t, v[0]) - gv_mesh_gy(t, d);
            int64_t bdx = (int64_t)gv_mesh_gx(t, v[1]) - gv_mesh_gx(t, d);
            int64_t bdy = (int64_t)gv_mesh_gy(t, v[1]) - gv_mesh_gy(t, d);
            int64_t cdx = (int64_t)gv_mesh_gx(t, v[2]) - gv_mesh_gx(t, d);
            int64_t cdy = (int64_t)gv_mesh_gy(t, v[2]) - gv_mesh_gy(t, d);
            i128 det = (i128)(adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) -
                       (i128)(bdx * bdx + bdy * bdy) * (adx * cdy - cdx * ady) +
                       (i128)(cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
            if (det > 0)
                return 0;
        }
    }
    return area == 2 * (int64_t)(t->width - 1) * (t->height - 1);
}

static void compare_brute(uint32_t w, uint32_t h, int kind, double e,
                          uint32_t maxt, int border)
{
    float *f = field(w, h, kind, 99 + (uint32_t)kind);
    struct gv_tin_params p = {e, maxt, border, 0};
    struct gv_mesh a, b;
    struct gv_error err = {0};
    int ra = gv_tin_build(f, w, h, w, &p, &a, &err);
    int rb = gv_tin_build_brute(f, w, h, w, &p, &b, &err);
    check(ra == 0 && rb == 0, "%ux%u kind %d E=%g N=%u border=%d: built", w, h,
          kind, e, maxt, border);
    check(same_mesh(&a, &b),
          "%ux%u kind %d E=%g N=%u border=%d: same vertex sequence and "
          "triangles as brute force (%u vs %u vertices)",
          w, h, kind, e, maxt, border, a.nverts, b.nverts);
    struct gv_mesh s;
    int rs = gv_tin_build_segs(f, w, h, w, &p, 1, &s, &err);
    check(rs == 0 && same_mesh(&s, &b), "with the scans' segment bounds: "
          "the same as brute force");
    if (rs == 0)
        gv_mesh_free(&s);
    double ie = independent_error(f, &a);
    if (e >= 0 && (!maxt || a.ntris + 2 <= maxt))
        check(ie <= e + 1e-9 && a.max_error <= e + 1e-9,
              "error bound holds on every sample (%.6g, measured %.6g, E %g)",
              ie, a.max_error, e);
    check(fabs(ie - a.max_error) <= 1e-9 * (1 + ie),
          "measured error %.9g equals an independent measure %.9g",
          a.max_error, ie);
    if (maxt)
        check(a.ntris <= maxt, "%u triangles <= %u", a.ntris, maxt);
    check(delaunay_and_tiling(&a), "Delaunay, counter-clockwise, tiles the "
          "rectangle (%u triangles)", a.ntris);
    gv_mesh_free(&a);
    gv_mesh_free(&b);
    free(f);
}

/* On grids too large for the brute force, the scans' segment bounds (on
 * by default there) change nothing: the same mesh without them. */
static void segs_large(void)
{
    static const struct {
        int kind;
        double e;
        int border;
    } cases[] = {{0, 1.0, 1}, {0, 0.25, 0}, {1, 0.0, 1}, {3, 30.0, 0}};
    const uint32_t w = 300, h = 240;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        float *f = field(w, h, cases[i].kind, 7 + (uint32_t)i);
        struct gv_tin_params p = {cases[i].e, 0, cases[i].border, 0};
        struct gv_mesh a, b;
        struct gv_error err = {0};
        int ra = gv_tin_build(f, w, h, w, &p, &a, &err);
        int rb = gv_tin_build_segs(f, w, h, w, &p, 0, &b, &err);
        check(ra == 0 && rb == 0 && same_mesh(&a, &b),
              "%ux%u kind %d E=%g border=%d: the same mesh with and without "
              "segment bounds (%u triangles)", w, h, cases[i].kind,
              cases[i].e, cases[i].border, ra == 0 ? a.ntris : 0);
        if (ra == 0) {
            check(a.max_error <= cases[i].e + 1e-9,
                  "measured error %.6g within %g", a.max_error, cases[i].e);
            gv_mesh_free(&a);
        }
        if (rb == 0)
            gv_mesh_free(&b);
        free(f);
    }
}

/* 1D greedy against a direct O(n k) greedy insertion. */
static void edge_brute(void)
{
    float s[200];
    rng = 7;
    for (int i = 0; i < 200; i++)
        s[i] = (float)(50 * sin(i * 0.07) + 10 * frand());
    uint32_t pos[200], ref[200], nref = 0;
    uint32_t n = 0;
    int got = gv_tin_edge_greedy(s, 1, 200, 2.0, pos, &n);
    uint8_t chosen[200] = {0};
    chosen[0] = chosen[199] = 1;
    for (;;) {
        double be = 0;
        uint32_t bi = 0;
        for (uint32_t i = 1; i < 199; i++) {
            if (chosen[i])
                continue;
            uint32_t l = i, r = i;
            while (!chosen[l]) l--;
            while (!chosen[r]) r++;
            double z = s[l] + ((double)s[r] - s[l]) * (double)(i - l) /
                                  (double)(r - l);
            double e = fabs(s[i] - z);
            if (e > be) {
                be = e;
                bi = i;
            }
        }
        if (be <= 2.0)
            break;
        chosen[bi] = 1;
        ref[nref++] = bi;
    }
    /* the set, sorted: greedy order does not change it */
    for (uint32_t i = 1; i < nref; i++)
        for (uint32_t k = i; k > 0 && ref[k - 1] > ref[k]; k--) {
            uint32_t t = ref[k];
            ref[k] = ref[k - 1];
            ref[k - 1] = t;
        }
    check(got == 0 && n == nref && memcmp(pos, ref, n * sizeof *pos) == 0,
          "1D greedy: %u positions, the brute force's %u", n, nref);
}

/* Two regions sharing the column x = 40 of one grid, the right one with a
 * disturbed interior: identical vertices on the shared column. */
static void crack_free(void)
{
    uint32_t W = 81, H = 57;
    float *f = field(W, H, 0, 5);
    float *g = malloc((size_t)41 * H * sizeof *g);
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < 41; x++) {
            g[(size_t)y * 41 + x] = f[(size_t)y * W + 40 + x];
            if (x > 0 && x < 40 && y > 0 && y < H - 1)
                g[(size_t)y * 41 + x] += (float)(30 * sin(x * y * 0.3));
        }
    struct gv_tin_params p = {1.5, 0, 1, 0};
    struct gv_mesh a, b, c;
    struct gv_error err = {0};
    int ok = gv_tin_build(f, 41, H, W, &p, &a, &err) == 0 &&
             gv_tin_build(f + 40, 41, H, W, &p, &b, &err) == 0 &&
             gv_tin_build(g, 41, H, 41, &p, &c, &err) == 0;
    check(ok, "three neighbouring regions built");
    /* rows of the vertices on a's east edge, b's and c's west edge */
    uint8_t ea[57] = {0}, wb[57] = {0}, wc[57] = {0};
    uint32_t n = 0;
    for (uint32_t i = 0; i < a.nverts; i++)
        if (gv_mesh_gx(&a, i) == 40) {
            ea[gv_mesh_gy(&a, i)] = 1;
            n++;
        }
    for (uint32_t i = 0; i < b.nverts; i++)
        if (gv_mesh_gx(&b, i) == 0)
            wb[gv_mesh_gy(&b, i)] = 1;
    for (uint32_t i = 0; i < c.nverts; i++)
        if (gv_mesh_gx(&c, i) == 0)
            wc[gv_mesh_gy(&c, i)] = 1;
    check(n > 2 && memcmp(ea, wb, H) == 0,
          "shared edge: the same %u vertices on both sides", n);
    check(memcmp(ea, wc, H) == 0 && !same_mesh(&b, &c),
          "a different interior changes the mesh, not the shared edge");
    check(a.max_error <= 1.5 + 1e-9 && b.max_error <= 1.5 + 1e-9 &&
          c.max_error <= 1.5 + 1e-9, "all three within the bound");
    gv_mesh_free(&a);
    gv_mesh_free(&b);
    gv_mesh_free(&c);
    free(f);
    free(g);
}

static void edge_cases(void)
{
    float flat[16 * 9];
    for (int i = 0; i < 16 * 9; i++)
        flat[i] = 7;
    struct gv_mesh t;
    struct gv_error err = {0};
    struct gv_tin_params p = {0, 0, 1, 0};
    check(gv_tin_build(flat, 16, 9, 16, &p, &t, &err) == 0 && t.ntris == 2 &&
          t.nverts == 4 && t.max_error == 0, "a flat grid is two triangles");
    gv_mesh_free(&t);
    p.max_error = -1;
    p.border_first = 0;
    gv_error_clear(&err);
    check(gv_tin_build(flat, 16, 9, 16, &p, &t, &err) < 0 &&
          err.code == GV_EINVAL, "no goal: refused (%s)", err.text);
    p.max_triangles = 10;
    gv_error_clear(&err);
    check(gv_tin_build(flat, 1, 9, 16, &p, &t, &err) < 0 &&
          err.code == GV_EINVAL, "a grid 1 wide: refused");
    flat[20] = NAN;
    gv_error_clear(&err);
    check(gv_tin_build(flat, 16, 9, 16, &p, &t, &err) < 0 &&
          err.code == GV_EINVAL, "a NaN height: refused (%s)", err.text);
    float *g = field(33, 21, 0, 99);
    struct gv_tin_params lim = {0.5, 60, 1, 0};
    gv_error_clear(&err);
    check(gv_tin_build(g, 33, 21, 33, &lim, &t, &err) < 0 &&
          err.code == GV_ELIMIT, "border beyond the triangle limit: refused "
          "(%s)", err.text);
    free(g);
    /* E = 0 reproduces every sample exactly */
    float *f = field(23, 19, 1, 3);
    struct gv_tin_params z = {0, 0, 1, 0};
    int built = gv_tin_build(f, 23, 19, 23, &z, &t, &err) == 0;
    check(built && t.max_error == 0 && independent_error(f, &t) == 0,
          "E = 0 is lossless (%u of %u samples)", t.nverts, 23 * 19);
    gv_mesh_free(&t);
    free(f);
    gv_mesh_free(NULL);
}

/* Tiles: the bound, crack-free joins (every vertex once, the triangles
 * tile the rectangle counter-clockwise), the same mesh for any thread
 * count, and the tiles' vertices on their shared edges. */
static void tiled(void)
{
    uint32_t W = 90, H = 61;
    float *f = field(W, H, 0, 11);
    struct gv_tin_params p = {2.0, 0, 1, 0};
    struct gv_mesh a, b, one;
    struct gv_error err = {0};
    int ok = gv_tin_build_tiled(f, W, H, W, &p, 32, 1, &a, &err) == 0 &&
             gv_tin_build_tiled(f, W, H, W, &p, 32, 3, &b, &err) == 0 &&
             gv_tin_build(f, 33, 33, W, &p, &one, &err) == 0;
    check(ok, "tiled: built with 1 and 3 threads");
    check(same_mesh(&a, &b), "tiled: the same mesh for 1 and 3 threads (%u "
          "triangles)", a.ntris);
    double ie = independent_error(f, &a);
    check(ie <= 2.0 + 1e-9 && fabs(ie - a.max_error) <= 1e-9 * (1 + ie),
          "tiled: bound on every sample (%.6g, measured %.6g)", ie,
          a.max_error);
    int64_t area = 0;
    int uniq = 1;
    for (uint32_t k = 0; k < a.ntris; k++) {
        const uint32_t *v = a.tris + 3 * k;
        area += orient(gv_mesh_gx(&a, v[0]), gv_mesh_gy(&a, v[0]), gv_mesh_gx(&a, v[1]), gv_mesh_gy(&a, v[1]),
                       gv_mesh_gx(&a, v[2]), gv_mesh_gy(&a, v[2]));
    }
    for (uint32_t i = 0; i < a.nverts && uniq; i++)
        for (uint32_t k = i + 1; k < a.nverts; k++)
            if (gv_mesh_gx(&a, i) == gv_mesh_gx(&a, k) && gv_mesh_gy(&a, i) == gv_mesh_gy(&a, k))
                uniq = 0;
    check(uniq && area == 2 * (int64_t)(W - 1) * (H - 1),
          "tiled: each vertex once, the triangles tile the rectangle");
    /* the first tile is the mesh of samples 0..32 built alone */
    int first = 1;
    for (uint32_t i = 0; i < one.nverts; i++) {
        int found = 0;
        for (uint32_t k = 0; k < a.nverts && !found; k++)
            found = gv_mesh_gx(&a, k) == gv_mesh_gx(&one, i) && gv_mesh_gy(&a, k) == gv_mesh_gy(&one, i);
        first &= found;
    }
    check(first, "tiled: tile (0,0) holds the vertices of its region alone");
    gv_mesh_free(&a);
    p.max_error = -1;
    p.max_triangles = 100;
    gv_error_clear(&err);
    check(gv_tin_build_tiled(f, W, H, W, &p, 32, 1, &a, &err) < 0,
          "tiled: a triangle limit is refused");
    gv_mesh_free(&b);
    gv_mesh_free(&one);
    free(f);
}

int main(void)
{
    edge_brute();
    static const struct {
        uint32_t w, h;
        int kind;
        double e;
        uint32_t maxt;
        int border;
    } cases[] = {
        {33, 33, 0, 2.0, 0, 0},   {33, 33, 0, 2.0, 0, 1},
        {41, 17, 1, 0.5, 0, 0},   {41, 17, 1, 0.0, 0, 1},
        {29, 31, 2, 1.0, 0, 1},   {25, 25, 3, 20.0, 0, 0},
        {25, 25, 3, 20.0, 0, 1},  {33, 21, 0, -1, 120, 0},
        {33, 21, 0, 0.5, 160, 1},  {2, 2, 0, 0.0, 0, 1},
        {2, 40, 0, 0.1, 0, 1},    {40, 3, 3, 1.0, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        compare_brute(cases[i].w, cases[i].h, cases[i].kind, cases[i].e,
                      cases[i].maxt, cases[i].border);
    segs_large();
    crack_free();
    tiled();
    edge_cases();
    return tap_done();
}
