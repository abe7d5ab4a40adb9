/*
 * zfield.c - the CPU side of z-field simplification (zfield.h): the level
 * sweep of the paper's section 4 (the reference the GPU sweep in
 * lib/gpu/gpu_zfield.c must equal), the coarse phase over a block
 * pyramid, and the mesh of the enabled vertices.
 *
 * Two ways to the same enabled set.  The sweep (no_coarse) pulls: level by
 * level from the finest, a vertex is enabled if activated or if a child
 * is.  The coarse phase (section 3) descends a quadtree of blocks holding
 * each block's largest error (and, for the screen mode, its height range)
 * and tests vertices only in blocks that may hold an activated one; the
 * enabled set is then the ancestor closure of the activated vertices,
 * pushed up through the parents.  Both give the set "activated vertices
 * and every ancestor of one", which is what the recursive definition
 * means.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/zfield.h"

int gv_zfield_side_ok(uint32_t n)
{
    if (n < 3 || n > GV_ZFIELD_MAX_SIDE)
        return 0;
    const uint32_t m = n - 1;
    return (m & (m - 1)) == 0;
}

int gv_zfield_levels(uint32_t n)
{
    int k = 0;
    while ((1u << k) < n - 1)
        k++;
    return 2 * k;
}

float gv_zfield_k(double viewport_height, double fovy_radians)
{
    return (float)(viewport_height / (2.0 * tan(fovy_radians / 2.0)));
}

uint64_t gv_zfield_level_count(uint32_t n, int lev)
{
    const uint64_t s = 1ull << (lev / 2), w = (n - 1) / (2 * s);
    return lev % 2 ? w * w : 2 * w * (w + 1);
}

/* The error measure of vertex (x,y) with hypotenuse ends a and c:
 * |2 B - A - C|, twice delta (zfield.h). */
static inline float delta2(const float *z, uint32_t n, uint32_t x, uint32_t y,
                           uint32_t ax, uint32_t ay, uint32_t cx, uint32_t cy)
{
    const float b = z[(size_t)y * n + x];
    const float t = 2.0f * b - z[(size_t)ay * n + ax];
    return fabsf(t - z[(size_t)cy * n + cx]);
}

/* Hypotenuse ends and parents of the vertex (x,y) of spacing s; returns
 * the number of parents inside the grid (1 or 2), written to px/py. */
struct vgeo {
    uint32_t ax, ay, cx, cy;
    int np;
    uint32_t px[2], py[2];
};

static void vertex_geometry(uint32_t n, uint32_t x, uint32_t y, uint32_t s, struct vgeo *g)
{
    const int xodd = (x / s) & 1, yodd = (y / s) & 1;
    int32_t p[2][2];
    if (xodd && yodd) {           /* a block centre */
        const uint32_t i = x / (2 * s), j = y / (2 * s);
        if (((i + j) & 1) == 0) { /* "\" */
            g->ax = x - s, g->ay = y - s, g->cx = x + s, g->cy = y + s;
            p[0][0] = (int32_t)(x + s), p[0][1] = (int32_t)(y - s);
            p[1][0] = (int32_t)(x - s), p[1][1] = (int32_t)(y + s);
        } else {                  /* "/" */
            g->ax = x + s, g->ay = y - s, g->cx = x - s, g->cy = y + s;
            p[0][0] = (int32_t)(x - s), p[0][1] = (int32_t)(y - s);
            p[1][0] = (int32_t)(x + s), p[1][1] = (int32_t)(y + s);
        }
    } else if (xodd) {            /* midpoint of a horizontal edge */
        g->ax = x - s, g->ay = y, g->cx = x + s, g->cy = y;
        p[0][0] = (int32_t)x, p[0][1] = (int32_t)y - (int32_t)s;
        p[1][0] = (int32_t)x, p[1][1] = (int32_t)(y + s);
    } else {                      /* midpoint of a vertical edge */
        g->ax = x, g->ay = y - s, g->cx = x, g->cy = y + s;
        p[0][0] = (int32_t)x - (int32_t)s, p[0][1] = (int32_t)y;
        p[1][0] = (int32_t)(x + s), p[1][1] = (int32_t)y;
    }
    g->np = 0;
    for (int k = 0; k < 2; k++)
        if (p[k][0] >= 0 && p[k][1] >= 0 && p[k][0] < (int32_t)n && p[k][1] < (int32_t)n) {
            g->px[g->np] = (uint32_t)p[k][0];
            g->py[g->np] = (uint32_t)p[k][1];
            g->np++;
        }
}

/* The spacing of a non-corner vertex: the largest power of two dividing
 * both coordinates, halved unless exactly one coordinate is an odd
 * multiple of it... computed directly: s is the lowest set bit of x|y;
 * a vertex is a centre of spacing s when both x/s and y/s are odd, an
 * edge midpoint of spacing s when one is. */
static uint32_t spacing_of(uint32_t x, uint32_t y)
{
    const uint32_t v = x | y;
    return v & (~v + 1);
}

struct view {
    enum gv_zfield_mode mode;
    float thr2;          /* VERTICAL: 2 tau */
    float tau2, halfk;   /* SCREEN: tau^2, K / 2 */
    float ex, ey, ez, xy;
};

static void view_init(struct view *v, const struct gv_zfield_params *p)
{
    v->mode = p->mode;
    v->thr2 = 2.0f * p->threshold;
    v->tau2 = p->threshold * p->threshold;
    v->halfk = 0.5f * p->k;
    v->ex = p->eye[0], v->ey = p->eye[1], v->ez = p->eye[2];
    v->xy = p->xy_scale > 0 ? p->xy_scale : 1.0f;
}

/* Is a vertex with error measure d2 (|2B - A - C|) at (x,y,zb) activated?
 * The GPU sweep (shaders/zfield_sweep.comp.glsl) computes the same
 * operations in the same order. */
static inline int activated(const struct view *v, float d2, uint32_t x, uint32_t y, float zb)
{
    if (v->mode == GV_ZFIELD_VERTICAL)
        return d2 > v->thr2;
    const float e = d2 * v->halfk;
    const float dx = (float)x * v->xy - v->ex;
    const float dy = (float)y * v->xy - v->ey;
    const float dz = zb - v->ez;
    const float dd = dx * dx + dy * dy + dz * dz;
    return e * e > v->tau2 * dd;
}

/* ---- the level sweep (the GPU's reference) ---- */

static int child_enabled(const uint8_t *en, uint32_t n, uint32_t x, uint32_t y, uint32_t s,
                         int centre)
{
    if (centre) {                 /* children: the 4 edge midpoints of spacing s */
        return (x >= s && en[(size_t)y * n + x - s]) || (x + s < n && en[(size_t)y * n + x + s]) ||
               (y >= s && en[(size_t)(y - s) * n + x]) || (y + s < n && en[(size_t)(y + s) * n + x]);
    }
    if (s == 1)
        return 0;                 /* level 0: leaves */
    const uint32_t h = s / 2;     /* children: centres of spacing s/2 naming (x,y) */
    for (int k = 0; k < 4; k++) {
        const int64_t cx = (int64_t)x + (k & 1 ? h : -(int64_t)h);
        const int64_t cy = (int64_t)y + (k & 2 ? h : -(int64_t)h);
        if (cx < 0 || cy < 0 || cx >= n || cy >= n || !en[(size_t)cy * n + (size_t)cx])
            continue;
        struct vgeo g;
        vertex_geometry(n, (uint32_t)cx, (uint32_t)cy, h, &g);
        for (int q = 0; q < g.np; q++)
            if (g.px[q] == x && g.py[q] == y)
                return 1;
    }
    return 0;
}

static void sweep(const float *z, uint32_t n, const struct view *v, uint8_t *en)
{
    const int levels = gv_zfield_levels(n);
    for (int lev = 0; lev < levels; lev++) {
        const uint32_t s = 1u << (lev / 2);
        const int centre = lev % 2;
        for (uint32_t y = 0; y < n; y += s)
            for (uint32_t x = 0; x < n; x += s) {
                const int xo = (x / s) & 1, yo = (y / s) & 1;
                if (centre ? !(xo && yo) : (xo == yo))
                    continue;
                struct vgeo g;
                vertex_geometry(n, x, y, s, &g);
                const float d2 = delta2(z, n, x, y, g.ax, g.ay, g.cx, g.cy);
                en[(size_t)y * n + x] =
                    (uint8_t)(activated(v, d2, x, y, z[(size_t)y * n + x]) ||
                              child_enabled(en, n, x, y, s, centre));
            }
    }
}

/* ---- the coarse phase ---- */

struct blocks {
    int levels;                   /* m = 1 .. k: blocks of side 2^m */
    uint32_t side[32];            /* blocks per row at m */
    float *maxd[32], *zmin[32], *zmax[32];
};

static void blocks_free(struct blocks *b)
{
    for (int m = 1; m <= b->levels; m++) {
        free(b->maxd[m]);
        free(b->zmin[m]);
        free(b->zmax[m]);
    }
}

/* Largest error measure and height range of every block of side 2^m,
 * boundary samples included (so blocks overlap on their edges). */
static int blocks_build(const float *z, uint32_t n, struct blocks *b)
{
    memset(b, 0, sizeof *b);
    b->levels = gv_zfield_levels(n) / 2;
    for (int m = 1; m <= b->levels; m++) {
        const uint32_t w = (n - 1) >> m;
        b->side[m] = w;
        b->maxd[m] = calloc((size_t)w * w, sizeof(float));
        b->zmin[m] = malloc((size_t)w * w * sizeof(float));
        b->zmax[m] = malloc((size_t)w * w * sizeof(float));
        if (!b->maxd[m] || !b->zmin[m] || !b->zmax[m]) {
            b->levels = m;
            blocks_free(b);
            return -1;
        }
    }
    /* m = 1: the 3x3 samples of each block. */
    const uint32_t w1 = b->side[1];
    for (uint32_t by = 0; by < w1; by++)
        for (uint32_t bx = 0; bx < w1; bx++) {
            float md = 0, lo = INFINITY, hi = -INFINITY;
            for (uint32_t y = 2 * by; y <= 2 * by + 2; y++)
                for (uint32_t x = 2 * bx; x <= 2 * bx + 2; x++) {
                    const float zz = z[(size_t)y * n + x];
                    lo = zz < lo ? zz : lo;
                    hi = zz > hi ? zz : hi;
                    if ((x == 0 || x == n - 1) && (y == 0 || y == n - 1))
                        continue;     /* grid corners: always enabled */
                    struct vgeo g;
                    vertex_geometry(n, x, y, spacing_of(x, y), &g);
                    const float d = delta2(z, n, x, y, g.ax, g.ay, g.cx, g.cy);
                    md = d > md ? d : md;
                }
            const size_t i = (size_t)by * w1 + bx;
            b->maxd[1][i] = md, b->zmin[1][i] = lo, b->zmax[1][i] = hi;
        }
    for (int m = 2; m <= b->levels; m++) {
        const uint32_t w = b->side[m], wc = b->side[m - 1];
        for (uint32_t by = 0; by < w; by++)
            for (uint32_t bx = 0; bx < w; bx++) {
                float md = 0, lo = INFINITY, hi = -INFINITY;
                for (int k = 0; k < 4; k++) {
                    const size_t c = (size_t)(2 * by + (k >> 1)) * wc + 2 * bx + (k & 1);
                    md = b->maxd[m - 1][c] > md ? b->maxd[m - 1][c] : md;
                    lo = b->zmin[m - 1][c] < lo ? b->zmin[m - 1][c] : lo;
                    hi = b->zmax[m - 1][c] > hi ? b->zmax[m - 1][c] : hi;
                }
                const size_t i = (size_t)by * w + bx;
                b->maxd[m][i] = md, b->zmin[m][i] = lo, b->zmax[m][i] = hi;
            }
    }
    return 0;
}

/* Distance from a to the interval [lo, hi] (0 inside), in the vertex
 * test's own operations so that it bounds every vertex's from below. */
static inline float gap(float a, float lo, float hi)
{
    return a < lo ? lo - a : (a > hi ? a - hi : 0.0f);
}

/* Could the block hold an activated vertex?  Conservative: no when every
 * vertex's test must fail (zfield.h, "coarse phase"). */
static int block_may(const struct view *v, const struct blocks *b, int m, uint32_t bx,
                     uint32_t by)
{
    const size_t i = (size_t)by * b->side[m] + bx;
    const float md = b->maxd[m][i];
    if (v->mode == GV_ZFIELD_VERTICAL)
        return md > v->thr2;
    const float e = md * v->halfk;
    const uint32_t x0 = bx << m, y0 = by << m, sz = 1u << m;
    const float dx = gap(v->ex, (float)x0 * v->xy, (float)(x0 + sz) * v->xy);
    const float dy = gap(v->ey, (float)y0 * v->xy, (float)(y0 + sz) * v->xy);
    const float dz = gap(v->ez, b->zmin[m][i], b->zmax[m][i]);
    const float dd = dx * dx + dy * dy + dz * dz;
    return e * e > v->tau2 * dd;
}

struct stack {
    uint32_t *p;
    size_t n, cap;
    int oom;
};

static void push(struct stack *st, uint32_t x, uint32_t y)
{
    if (st->n + 2 > st->cap) {
        size_t c = st->cap ? 2 * st->cap : 1024;
        uint32_t *q = realloc(st->p, c * sizeof *q);
        if (!q) {
            st->oom = 1;
            return;
        }
        st->p = q, st->cap = c;
    }
    st->p[st->n++] = x;
    st->p[st->n++] = y;
}

/* Enable (x,y) and, through the stack, every ancestor not yet enabled. */
static void enable_up(uint8_t *en, uint32_t n, uint32_t x, uint32_t y, struct stack *st)
{
    if (en[(size_t)y * n + x])
        return;
    en[(size_t)y * n + x] = 1;
    push(st, x, y);
    while (st->n > 0 && !st->oom) {
        const uint32_t yy = st->p[--st->n], xx = st->p[--st->n];
        if ((xx == 0 || xx == n - 1) && (yy == 0 || yy == n - 1))
            continue;
        struct vgeo g;
        vertex_geometry(n, xx, yy, spacing_of(xx, yy), &g);
        for (int q = 0; q < g.np; q++) {
            uint8_t *e = &en[(size_t)g.py[q] * n + g.px[q]];
            if (!*e) {
                *e = 1;
                push(st, g.px[q], g.py[q]);
            }
        }
    }
}

static int descend(const float *z, uint32_t n, const struct view *v, const struct blocks *b,
                   int m, uint32_t bx, uint32_t by, uint8_t *en, struct stack *st)
{
    if (!block_may(v, b, m, bx, by))
        return 0;
    if (m > 1) {
        for (int k = 0; k < 4; k++)
            descend(z, n, v, b, m - 1, 2 * bx + (uint32_t)(k & 1), 2 * by + (uint32_t)(k >> 1),
                    en, st);
        return st->oom ? -1 : 0;
    }
    for (uint32_t y = 2 * by; y <= 2 * by + 2; y++)
        for (uint32_t x = 2 * bx; x <= 2 * bx + 2; x++) {
            if ((x == 0 || x == n - 1) && (y == 0 || y == n - 1))
                continue;
            struct vgeo g;
            vertex_geometry(n, x, y, spacing_of(x, y), &g);
            const float d = delta2(z, n, x, y, g.ax, g.ay, g.cx, g.cy);
            if (activated(v, d, x, y, z[(size_t)y * n + x]))
                enable_up(en, n, x, y, st);
        }
    return st->oom ? -1 : 0;
}

int gv_zfield_enable(const float *z, uint32_t n, const struct gv_zfield_params *p,
                     uint8_t *enabled, struct gv_error *err)
{
    if (!gv_zfield_side_ok(n))
        return gv_fail(err, GV_EINVAL, "zfield: the grid must be (2^k+1) x (2^k+1) "
                       "samples, 3 to %u, not %u", GV_ZFIELD_MAX_SIDE, n);
    if (!(p->threshold >= 0) || !isfinite(p->threshold) ||
        (p->mode == GV_ZFIELD_SCREEN && !(p->k > 0 && isfinite(p->k))))
        return gv_fail(err, GV_EINVAL, "zfield: bad threshold or camera");
    struct view v;
    view_init(&v, p);
    memset(enabled, 0, (size_t)n * n);
    if (p->no_coarse) {
        sweep(z, n, &v, enabled);
    } else {
        struct blocks b;
        if (blocks_build(z, n, &b) < 0)
            return gv_fail(err, GV_ENOMEM, "zfield: out of memory");
        struct stack st = {0};
        const int rc = descend(z, n, &v, &b, b.levels, 0, 0, enabled, &st);
        free(st.p);
        blocks_free(&b);
        if (rc < 0)
            return gv_fail(err, GV_ENOMEM, "zfield: out of memory");
    }
    enabled[0] = enabled[n - 1] = 1;
    enabled[(size_t)(n - 1) * n] = enabled[(size_t)(n - 1) * n + n - 1] = 1;
    return 0;
}

/* ---- the mesh ---- */

struct builder {
    const float *z;
    uint32_t n;
    const uint8_t *en;
    uint32_t *index;              /* n*n: vertex number + 1, 0 = unused */
    struct gv_mesh *t;
    uint32_t vcap, tcap;
    int oom;
};

static uint32_t vertex(struct builder *b, uint32_t x, uint32_t y)
{
    uint32_t *slot = &b->index[(size_t)y * b->n + x];
    if (*slot)
        return *slot - 1;
    struct gv_mesh *t = b->t;
    if (t->nverts == b->vcap) {
        const uint32_t c = b->vcap ? 2 * b->vcap : 256;
        float *pos = realloc(t->pos, (size_t)c * 3 * sizeof *pos);
        if (!pos) {
            b->oom = 1;
            return 0;
        }
        t->pos = pos;
        b->vcap = c;
    }
    float *p = t->pos + 3 * (size_t)t->nverts;
    p[0] = (float)x;
    p[1] = (float)y;
    p[2] = b->z[(size_t)y * b->n + x];
    *slot = ++t->nverts;
    return t->nverts - 1;
}

static void emit(struct builder *b, uint32_t ax, uint32_t ay, uint32_t px, uint32_t py,
                 uint32_t cx, uint32_t cy)
{
    struct gv_mesh *t = b->t;
    if (t->ntris == b->tcap) {
        const uint32_t c = b->tcap ? 2 * b->tcap : 256;
        uint32_t *q = realloc(t->tris, (size_t)c * 3 * sizeof *q);
        if (!q) {
            b->oom = 1;
            return;
        }
        t->tris = q;
        b->tcap = c;
    }
    /* Counter-clockwise with y as a math axis (the grid mesh's convention). */
    const int64_t o = ((int64_t)px - ax) * ((int64_t)cy - ay) -
                      ((int64_t)py - ay) * ((int64_t)cx - ax);
    uint32_t va = vertex(b, ax, ay), vp = vertex(b, px, py), vc = vertex(b, cx, cy);
    if (b->oom)
        return;
    uint32_t *tri = &t->tris[(size_t)t->ntris * 3];
    tri[0] = va;
    tri[1] = o > 0 ? vp : vc;
    tri[2] = o > 0 ? vc : vp;
    t->ntris++;
}

/* Triangle with apex p and hypotenuse a-c: split at the hypotenuse's
 * midpoint when it is a grid vertex and enabled (depth first, explicit
 * stack: the depth is 2k). */
static void refine(struct builder *b, uint32_t ax, uint32_t ay, uint32_t px, uint32_t py,
                   uint32_t cx, uint32_t cy)
{
    struct tri6 { uint32_t v[6]; } st[2 * 32 + 2];
    int top = 0;
    st[top++] = (struct tri6){{ax, ay, px, py, cx, cy}};
    while (top > 0 && !b->oom) {
        const uint32_t *q = st[--top].v;
        const uint32_t a0 = q[0], a1 = q[1], p0 = q[2], p1 = q[3], c0 = q[4], c1 = q[5];
        const uint32_t sx = a0 + c0, sy = a1 + c1;
        if ((sx | sy) & 1 || !b->en[(size_t)(sy / 2) * b->n + sx / 2]) {
            emit(b, a0, a1, p0, p1, c0, c1);
            continue;
        }
        const uint32_t mx = sx / 2, my = sy / 2;
        /* Children (m; c, p) then (m; p, a), pushed so that (m; p, a) is
         * first out. */
        st[top++] = (struct tri6){{c0, c1, mx, my, p0, p1}};
        st[top++] = (struct tri6){{p0, p1, mx, my, a0, a1}};
    }
}

/* Largest |z - mesh| over every sample, each triangle scanned over its
 * bounding box with exact inclusion tests. */
static double measure(const float *z, uint32_t n, const struct gv_mesh *t)
{
    double worst = 0;
    for (uint32_t i = 0; i < t->ntris; i++) {
        const uint32_t *v = &t->tris[(size_t)i * 3];
        const int64_t x0 = gv_mesh_gx(t, v[0]), y0 = gv_mesh_gy(t, v[0]);
        const int64_t x1 = gv_mesh_gx(t, v[1]), y1 = gv_mesh_gy(t, v[1]);
        const int64_t x2 = gv_mesh_gx(t, v[2]), y2 = gv_mesh_gy(t, v[2]);
        const double z0 = gv_mesh_gz(t, v[0]), z1 = gv_mesh_gz(t, v[1]);
        const double z2 = gv_mesh_gz(t, v[2]);
        const int64_t area = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0);
        int64_t lx = x0 < x1 ? x0 : x1, hx = x0 > x1 ? x0 : x1;
        int64_t ly = y0 < y1 ? y0 : y1, hy = y0 > y1 ? y0 : y1;
        lx = x2 < lx ? x2 : lx, hx = x2 > hx ? x2 : hx;
        ly = y2 < ly ? y2 : ly, hy = y2 > hy ? y2 : hy;
        for (int64_t y = ly; y <= hy; y++)
            for (int64_t x = lx; x <= hx; x++) {
                const int64_t w0 = (x1 - x) * (y2 - y) - (y1 - y) * (x2 - x);
                const int64_t w1 = (x2 - x) * (y0 - y) - (y2 - y) * (x0 - x);
                const int64_t w2 = area - w0 - w1;
                if (w0 < 0 || w1 < 0 || w2 < 0)
                    continue;
                const double m = (w0 * z0 + w1 * z1 + w2 * z2) / (double)area;
                const double e = fabs(z[(size_t)y * n + (size_t)x] - m);
                worst = e > worst ? e : worst;
            }
    }
    return worst;
}

int gv_zfield_mesh(const float *z, uint32_t n, const uint8_t *enabled, int measure_error,
                   struct gv_mesh *out, struct gv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!gv_zfield_side_ok(n))
        return gv_fail(err, GV_EINVAL, "zfield: the grid must be (2^k+1) x (2^k+1) samples");
    struct builder b = {.z = z, .n = n, .en = enabled, .t = out};
    b.index = calloc((size_t)n * n, sizeof *b.index);
    if (!b.index)
        return gv_fail(err, GV_ENOMEM, "zfield: out of memory");
    out->width = out->height = n;
    const uint32_t e = n - 1;
    /* The corners first, as gv_tin_build numbers them. */
    vertex(&b, 0, 0);
    vertex(&b, e, 0);
    vertex(&b, e, e);
    vertex(&b, 0, e);
    /* The root triangles on the diagonal (0,0)-(e,e): apexes (e,0), (0,e). */
    refine(&b, 0, 0, e, 0, e, e);
    refine(&b, e, e, 0, e, 0, 0);
    free(b.index);
    if (b.oom) {
        gv_mesh_free(out);
        return gv_fail(err, GV_ENOMEM, "zfield: out of memory");
    }
    out->zmin = INFINITY, out->zmax = -INFINITY;
    for (uint32_t i = 0; i < out->nverts; i++) {
        const float vz = gv_mesh_gz(out, i);
        out->zmin = vz < out->zmin ? vz : out->zmin;
        out->zmax = vz > out->zmax ? vz : out->zmax;
    }
    out->max_error = measure_error ? measure(z, n, out) : -1;
    return 0;
}
