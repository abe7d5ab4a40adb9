/*
 * test_zfield.c - z-field simplification (lib/mesh/zfield.h) on the CPU
 * and, where EGL works, on the GPU (lib/gpu/gpu_zfield.h):
 *  - the level sweep's enabled set equals the recursive definition
 *    (enabled = activated or an enabled child), computed here by brute
 *    force from the activated vertices and the parent rule;
 *  - the coarse phase gives the same set as the sweep;
 *  - the GPU gives the same set, hence the same mesh triangle for
 *    triangle, in both error modes;
 *  - the mesh is conforming (every edge shared by two triangles or on the
 *    border; no vertex on another triangle's edge), covers the square,
 *    uses every enabled vertex, and in the vertical mode with threshold 0
 *    on a plane is the two root triangles.
 * Grids: a fractal terrain, a sharp peak (deep dependency chains) and a
 * plane, at several thresholds and cameras.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/zfield.h"
#include "util.h"
#ifdef GV_TEST_GPU
#include "gpu/gpu.h"
#include "gpu/gpu_zfield.h"
#endif

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static double frand(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* Midpoint displacement: a reproducible rough terrain. */
static float *terrain(uint32_t n, double rough)
{
    float *z = calloc((size_t)n * n, sizeof *z);
    for (uint32_t s = n - 1; s > 1; s /= 2) {
        const double amp = rough * s;
        for (uint32_t y = s / 2; y < n; y += s)
            for (uint32_t x = s / 2; x < n; x += s)
                z[y * n + x] = (float)((z[(y - s / 2) * n + x - s / 2] +
                                        z[(y + s / 2) * n + x + s / 2]) / 2 +
                                       amp * (frand() - 0.5));
        for (uint32_t y = 0; y < n; y += s / 2)
            for (uint32_t x = (y / (s / 2)) % 2 ? 0 : s / 2; x < n; x += s) {
                double sum = 0;
                int k = 0;
                if (x >= s / 2) sum += z[y * n + x - s / 2], k++;
                if (x + s / 2 < n) sum += z[y * n + x + s / 2], k++;
                z[y * n + x] = (float)(sum / k + amp * 0.5 * (frand() - 0.5));
            }
    }
    return z;
}

static float *peak(uint32_t n)
{
    float *z = calloc((size_t)n * n, sizeof *z);
    z[(n / 3) * n + n / 5] = 1000.0f;
    return z;
}

static float *plane(uint32_t n)
{
    float *z = malloc((size_t)n * n * sizeof *z);
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++)
            z[y * n + x] = 3.0f * (float)x - 2.0f * (float)y + 7.0f;
    return z;
}

/* The brute-force enabled set: activated vertices (per the same test as
 * the library's, re-derived here from zfield.h's rules) and all their
 * ancestors, by repeated passes until nothing changes. */
static void parents_of(uint32_t n, uint32_t x, uint32_t y, int *np, uint32_t px[2], uint32_t py[2],
                       uint32_t *ax, uint32_t *ay, uint32_t *cx, uint32_t *cy)
{
    uint32_t s = (x | y) & (~(x | y) + 1);
    int64_t p[2][2];
    if ((x / s) % 2 && (y / s) % 2) {
        uint32_t i = x / (2 * s), j = y / (2 * s);
        if ((i + j) % 2 == 0) {
            *ax = x - s, *ay = y - s, *cx = x + s, *cy = y + s;
            p[0][0] = x + s, p[0][1] = (int64_t)y - s, p[1][0] = (int64_t)x - s, p[1][1] = y + s;
        } else {
            *ax = x + s, *ay = y - s, *cx = x - s, *cy = y + s;
            p[0][0] = (int64_t)x - s, p[0][1] = (int64_t)y - s, p[1][0] = x + s, p[1][1] = y + s;
        }
    } else if ((x / s) % 2) {
        *ax = x - s, *ay = y, *cx = x + s, *cy = y;
        p[0][0] = x, p[0][1] = (int64_t)y - s, p[1][0] = x, p[1][1] = y + s;
    } else {
        *ax = x, *ay = y - s, *cx = x, *cy = y + s;
        p[0][0] = (int64_t)x - s, p[0][1] = y, p[1][0] = x + s, p[1][1] = y;
    }
    *np = 0;
    for (int k = 0; k < 2; k++)
        if (p[k][0] >= 0 && p[k][1] >= 0 && p[k][0] < n && p[k][1] < n) {
            px[*np] = (uint32_t)p[k][0], py[*np] = (uint32_t)p[k][1];
            (*np)++;
        }
}

static void brute(const float *z, uint32_t n, const struct gv_zfield_params *p, uint8_t *en)
{
    memset(en, 0, (size_t)n * n);
    const float xy = p->xy_scale > 0 ? p->xy_scale : 1.0f;
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++) {
            if ((x == 0 || x == n - 1) && (y == 0 || y == n - 1)) {
                en[y * n + x] = 1;
                continue;
            }
            int np;
            uint32_t px[2], py[2], ax, ay, cx, cy;
            parents_of(n, x, y, &np, px, py, &ax, &ay, &cx, &cy);
            const float b = z[y * n + x];
            const float t = 2.0f * b - z[ay * n + ax];
            const float d2 = fabsf(t - z[cy * n + cx]);
            int act;
            if (p->mode == GV_ZFIELD_VERTICAL) {
                act = d2 > 2.0f * p->threshold;
            } else {
                const float e = d2 * (0.5f * p->k);
                const float dx = (float)x * xy - p->eye[0], dy = (float)y * xy - p->eye[1];
                const float dz = b - p->eye[2];
                const float dd = dx * dx + dy * dy + dz * dz;
                act = e * e > (p->threshold * p->threshold) * dd;
            }
            en[y * n + x] = (uint8_t)act;
        }
    for (int changed = 1; changed;) {
        changed = 0;
        for (uint32_t y = 0; y < n; y++)
            for (uint32_t x = 0; x < n; x++) {
                if (!en[y * n + x] || ((x == 0 || x == n - 1) && (y == 0 || y == n - 1)))
                    continue;
                int np;
                uint32_t px[2], py[2], ax, ay, cx, cy;
                parents_of(n, x, y, &np, px, py, &ax, &ay, &cx, &cy);
                for (int k = 0; k < np; k++)
                    if (!en[py[k] * n + px[k]])
                        en[py[k] * n + px[k]] = 1, changed = 1;
            }
    }
}

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Conforming, covering, every enabled vertex used. */
static int mesh_ok(const struct gv_mesh *t, uint32_t n, const uint8_t *en, char *why, size_t wl)
{
    const int64_t e = n - 1;
    int64_t area2 = 0;
    uint8_t *used = calloc((size_t)n * n, 1);
    /* Each directed edge at most once; every undirected interior edge twice. */
    size_t m = (size_t)t->ntris * 3;
    uint64_t *edges = malloc(m * sizeof *edges);
    for (uint32_t i = 0; i < t->ntris; i++) {
        const uint32_t *v = &t->tris[3 * (size_t)i];
        int64_t x[3], y[3];
        for (int k = 0; k < 3; k++) {
            x[k] = gv_mesh_gx(t, v[k]), y[k] = gv_mesh_gy(t, v[k]);
            used[y[k] * n + x[k]] = 1;
        }
        const int64_t a = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        if (a <= 0) {
            snprintf(why, wl, "triangle %u not counter-clockwise", i);
            free(used), free(edges);
            return 0;
        }
        area2 += a;
        for (int k = 0; k < 3; k++) {
            uint32_t p = (uint32_t)(y[k] * n + x[k]), q = (uint32_t)(y[(k + 1) % 3] * n + x[(k + 1) % 3]);
            edges[3 * (size_t)i + k] = (uint64_t)p << 32 | q;
        }
    }
    int ok = area2 == 2 * e * e;
    if (!ok)
        snprintf(why, wl, "area %lld, not %lld", (long long)area2, (long long)(2 * e * e));
    /* Every directed edge's reverse exists unless the edge is on the border. */
    uint64_t *sorted = malloc(m * sizeof *sorted);
    memcpy(sorted, edges, m * sizeof *sorted);
    qsort(sorted, m, sizeof *sorted, cmp_u64);
    for (size_t i = 1; ok && i < m; i++)
        if (sorted[i] == sorted[i - 1]) {
            snprintf(why, wl, "a directed edge used twice: overlapping triangles");
            ok = 0;
        }
    for (size_t i = 0; ok && i < m; i++) {
        const uint32_t p = (uint32_t)(edges[i] >> 32), q = (uint32_t)edges[i];
        const uint32_t px = p % n, py = p / n, qx = q % n, qy = q / n;
        const int border = (px == qx && (px == 0 || px == n - 1)) ||
                           (py == qy && (py == 0 || py == n - 1));
        if (border)
            continue;
        const uint64_t rev = (uint64_t)q << 32 | p;
        if (!bsearch(&rev, sorted, m, sizeof *sorted, cmp_u64)) {
            snprintf(why, wl, "edge (%u,%u)-(%u,%u) has no twin: a crack", px, py, qx, qy);
            ok = 0;
        }
    }
    for (size_t i = 0; ok && i < (size_t)n * n; i++)
        if (en[i] != used[i]) {
            snprintf(why, wl, "vertex (%zu,%zu) enabled %d but used %d", i % n, i / n, en[i], used[i]);
            ok = 0;
        }
    free(used), free(edges), free(sorted);
    return ok;
}

#ifdef GV_TEST_GPU
static int same_mesh(const struct gv_mesh *a, const struct gv_mesh *b)
{
    if (a->nverts != b->nverts || a->ntris != b->ntris)
        return 0;
    return !memcmp(a->pos, b->pos, (size_t)a->nverts * 3 * sizeof *a->pos) &&
           !memcmp(a->tris, b->tris, (size_t)a->ntris * 3 * sizeof *a->tris);
}
#endif

#ifdef GV_TEST_GPU
static struct gv_gpu_zfield *gzf[2];   /* compute, fragment (WebGL2's) */
static const char *path_name[2] = {"compute", "fragment (GLSL ES 3.00)"};
#endif

static void check_case(const char *name, const float *z, uint32_t n, const struct gv_zfield_params *p,
                       int check_mesh)
{
    struct gv_error err = {0};
    const size_t cells = (size_t)n * n;
    uint8_t *sweep = malloc(cells), *coarse = malloc(cells), *bf = malloc(cells);
    struct gv_zfield_params q = *p;
    q.no_coarse = 1;
    if (gv_zfield_enable(z, n, &q, sweep, &err) < 0)
        fail("%s: %s", name, err.text);
    q.no_coarse = 0;
    if (gv_zfield_enable(z, n, &q, coarse, &err) < 0)
        fail("%s: %s", name, err.text);
    brute(z, n, p, bf);
    size_t on = 0;
    for (size_t i = 0; i < cells; i++)
        on += sweep[i];
    check(!memcmp(sweep, bf, cells), "%s: the level sweep's %zu enabled vertices are the "
          "activated ones and their ancestors", name, on);
    check(!memcmp(sweep, coarse, cells), "%s: the coarse phase enables the same vertices", name);
    struct gv_mesh t;
    if (gv_zfield_mesh(z, n, sweep, 1, &t, &err) < 0)
        fail("%s: mesh: %s", name, err.text);
    if (check_mesh) {
        char why[160] = "";
        check(mesh_ok(&t, n, sweep, why, sizeof why), "%s: %u triangles, conforming, cover "
              "the square, use every enabled vertex %s", name, t.ntris, why);
    }
#ifdef GV_TEST_GPU
    for (int path = 0; path < 2; path++) {
        if (!gzf[path])
            continue;
        uint8_t *g = malloc(cells);
        if (gv_gpu_zfield_heights(gzf[path], z, n, &err) < 0 ||
            gv_gpu_zfield_enable(gzf[path], p, g, &err) < 0)
            fail("%s: gpu: %s", name, err.text);
        size_t differ = 0;
        for (size_t i = 0; i < cells; i++)
            differ += g[i] != sweep[i];
        struct gv_mesh tg;
        if (gv_zfield_mesh(z, n, g, 0, &tg, &err) < 0)
            fail("%s: gpu mesh: %s", name, err.text);
        check(differ == 0 && same_mesh(&t, &tg), "%s: the GPU, %s, enables the same "
              "vertices (%zu differ) and gives the same mesh, triangle for triangle", name,
              path_name[path], differ);
        gv_mesh_free(&tg);
        free(g);
    }
#endif
    gv_mesh_free(&t);
    free(sweep), free(coarse), free(bf);
}

int main(void)
{
    struct gv_error err = {0};
#ifdef GV_TEST_GPU
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu)
        printf("# no EGL context (%s): CPU checks only\n", err.text);
    else if (!(gzf[0] = gv_gpu_zfield_new_path(gpu, GV_ZFIELD_COMPUTE, &err)))
        fail("gpu zfield, compute: %s", err.text);
    else if (!gv_gpu_info(gpu)->es)
        printf("# not an ES context: the fragment (WebGL2) variant is not run\n");
    else if (!(gzf[1] = gv_gpu_zfield_new_path(gpu, GV_ZFIELD_FRAGMENT, &err)))
        fail("gpu zfield, fragment: %s", err.text);
    if (gpu)
        printf("# EGL: %s\n", gv_gpu_info(gpu)->renderer);
#endif
    /* Sizes. */
    uint8_t tmp[9];
    float z9[9] = {0};
    check(gv_zfield_enable(z9, 3, &(struct gv_zfield_params){0}, tmp, &err) == 0 &&
          gv_zfield_side_ok(3) && gv_zfield_side_ok(513) && !gv_zfield_side_ok(512) &&
          !gv_zfield_side_ok(2) && !gv_zfield_side_ok(GV_ZFIELD_MAX_SIDE + 1),
          "grid sides: 2^k + 1 only");
    gv_error_clear(&err);
    check(gv_zfield_enable(z9, 4, &(struct gv_zfield_params){0}, tmp, &err) < 0 &&
          err.code == GV_EINVAL, "a 4 x 4 grid is refused (%s)", err.text);

    /* A plane: nothing but the corners, the two root triangles. */
    float *pl = plane(65);
    uint8_t *en = malloc(65 * 65);
    gv_zfield_enable(pl, 65, &(struct gv_zfield_params){.threshold = 0.0f}, en, &err);
    struct gv_mesh t;
    gv_zfield_mesh(pl, 65, en, 1, &t, &err);
    check(t.ntris == 2 && t.nverts == 4 && t.max_error < 1e-3, "a plane at threshold 0: two "
          "triangles, four vertices (%u, %u), error %g", t.ntris, t.nverts, t.max_error);
    gv_mesh_free(&t);
    free(en);
    free(pl);

    float *tr = terrain(129, 0.6);
    const float ts[] = {0.0f, 0.5f, 2.0f, 8.0f, 30.0f};
    for (size_t i = 0; i < sizeof ts / sizeof ts[0]; i++) {
        char name[96];
        snprintf(name, sizeof name, "terrain 129^2, vertical %.1f", ts[i]);
        check_case(name, tr, 129, &(struct gv_zfield_params){.threshold = ts[i]}, 1);
    }
    /* View-dependent: eyes inside, above and beside the grid. */
    const float eyes[][3] = {{64, 64, 60}, {-100, 20, 30}, {10, 120, 5}};
    for (size_t i = 0; i < 3; i++) {
        char name[96];
        snprintf(name, sizeof name, "terrain 129^2, screen 1 px, eye %zu", i);
        struct gv_zfield_params p = {.mode = GV_ZFIELD_SCREEN, .threshold = 1.0f,
                                     .k = gv_zfield_k(1080, 1.0),
                                     .eye = {eyes[i][0], eyes[i][1], eyes[i][2]}};
        check_case(name, tr, 129, &p, 1);
    }
    free(tr);
    float *pk = peak(257);
    check_case("a single peak, 257^2, vertical 1", pk, 257,
               &(struct gv_zfield_params){.threshold = 1.0f}, 1);
    free(pk);
    /* A larger grid. */
    float *big = terrain(1025, 0.5);
    check_case("terrain 1025^2, vertical 4", big, 1025,
               &(struct gv_zfield_params){.threshold = 4.0f, .xy_scale = 2.0f}, 1);
    check_case("terrain 1025^2, screen 2 px", big, 1025,
               &(struct gv_zfield_params){.mode = GV_ZFIELD_SCREEN, .threshold = 2.0f,
                                          .k = gv_zfield_k(1080, 0.8), .xy_scale = 2.0f,
                                          .eye = {300, -200, 400}}, 1);
    free(big);
#ifdef GV_TEST_GPU
    gv_gpu_zfield_free(gzf[0]);
    gv_gpu_zfield_free(gzf[1]);
    gv_gpu_close(gpu);
#endif
    return tap_done();
}
