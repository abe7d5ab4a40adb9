/*
 * tin.c - greedy insertion with an incremental Delaunay triangulation
 * (Garland & Heckbert, CMU-CS-95-181, section 4.4, algorithm III).
 *
 * The mesh is a half-edge array: triangle t owns half-edges 3t, 3t+1,
 * 3t+2; half-edge e runs from vertex tv[e] to tv[next(e)], and he[e] is the
 * opposite half-edge or -1 on the hull.  Triangle slots are reused in place
 * by splits and flips, never freed, so the slot count is the triangle
 * count.
 *
 * Each triangle holds its candidate (section 4.3): the unused sample of
 * largest error inside it, found by scan converting it row by row with
 * exact integer edge functions (samples on an edge belong to both sides, as
 * the paper allows in 4.3.1).  The candidates live in a binary max-heap
 * keyed on (error, -sample index).  Inserting a point splits its triangle
 * (or the two triangles of the edge it lies on), then Lawson's flips restore
 * the Delaunay property (section 4.2.1, figure 4); every triangle created
 * or flipped is queued and scanned once after the insertion, which is the
 * update region of section 4.2.2.
 *
 * The plane of a triangle is computed from its vertices in a canonical
 * rotation (the smallest sample index first), so its errors depend on the
 * triangle only.  A sample on an edge is offered by both triangles and
 * counts with the larger of their two errors, in the heap and in the
 * brute-force reference (tin_int.h) alike, which therefore see the same
 * errors bit for bit.
 */
#include "mesh/tin.h"
#include "mesh/tin_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

__extension__ typedef __int128 gv_i128;

struct tin {
    const float *h;
    uint32_t w, hgt;
    size_t stride;
    uint8_t *used;           /* w*hgt: a vertex, or a border sample in
                                border-first mode */
    uint32_t nv, capv;
    int32_t *vx, *vy;
    float *vz;
    int32_t *vhe;            /* a half-edge starting at each vertex */
    uint32_t nt, capt;
    int32_t *tv, *he;        /* 3 per triangle */
    double *cerr;            /* candidate error per triangle */
    int64_t *cidx;           /* candidate sample index, -1: none */
    int32_t *hpos;           /* position in heap, -1: not there */
    int32_t *heap;
    uint32_t nheap;
    int32_t *pend;           /* triangles to scan after this insertion */
    uint8_t *pflag;
    uint32_t npend;
    int32_t *stack;          /* half-edges to legalize */
    uint32_t nstack, capstack;
};

struct plane {
    double z0, gx, gy;
    int32_t x0, y0;
};

static inline int next_he(int e) { return e % 3 == 2 ? e - 2 : e + 1; }
static inline int prev_he(int e) { return e % 3 == 0 ? e + 2 : e - 1; }

static inline int64_t orient(int64_t ax, int64_t ay, int64_t bx, int64_t by,
                             int64_t cx, int64_t cy)
{
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

static inline float hat(const struct tin *m, int32_t x, int32_t y)
{
    return m->h[(size_t)y * m->stride + (size_t)x];
}

/* ------------------------------------------------------------ storage */

static int grow(void **p, uint32_t *cap, uint32_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    uint32_t c = *cap ? *cap : 64;
    while (c < need)
        c *= 2;
    void *q = realloc(*p, (size_t)c * elem);
    if (!q)
        return -1;
    *p = q;
    *cap = c;
    return 0;
}

static int reserve_tris(struct tin *m, uint32_t need)
{
    if (need <= m->capt)
        return 0;
    uint32_t c = m->capt ? m->capt : 64;
    while (c < need)
        c *= 2;
    int32_t *tv = realloc(m->tv, (size_t)c * 3 * sizeof *tv);
    if (!tv)
        return -1;
    m->tv = tv;
    int32_t *he = realloc(m->he, (size_t)c * 3 * sizeof *he);
    if (!he)
        return -1;
    m->he = he;
    double *ce = realloc(m->cerr, (size_t)c * sizeof *ce);
    if (!ce)
        return -1;
    m->cerr = ce;
    int64_t *ci = realloc(m->cidx, (size_t)c * sizeof *ci);
    if (!ci)
        return -1;
    m->cidx = ci;
    int32_t *hp = realloc(m->hpos, (size_t)c * sizeof *hp);
    if (!hp)
        return -1;
    m->hpos = hp;
    int32_t *hh = realloc(m->heap, (size_t)c * sizeof *hh);
    if (!hh)
        return -1;
    m->heap = hh;
    int32_t *pe = realloc(m->pend, (size_t)c * sizeof *pe);
    if (!pe)
        return -1;
    m->pend = pe;
    uint8_t *pf = realloc(m->pflag, (size_t)c);
    if (!pf)
        return -1;
    memset(pf + m->capt, 0, c - m->capt);
    m->pflag = pf;
    m->capt = c;
    return 0;
}

static int add_vertex(struct tin *m, int32_t x, int32_t y)
{
    if (m->nv == m->capv) {
        uint32_t c = m->capv ? m->capv * 2 : 64;
        int32_t *vx = realloc(m->vx, (size_t)c * sizeof *vx);
        if (!vx)
            return -1;
        m->vx = vx;
        int32_t *vy = realloc(m->vy, (size_t)c * sizeof *vy);
        if (!vy)
            return -1;
        m->vy = vy;
        float *vz = realloc(m->vz, (size_t)c * sizeof *vz);
        if (!vz)
            return -1;
        m->vz = vz;
        int32_t *vhe = realloc(m->vhe, (size_t)c * sizeof *vhe);
        if (!vhe)
            return -1;
        m->vhe = vhe;
        m->capv = c;
    }
    m->vx[m->nv] = x;
    m->vy[m->nv] = y;
    m->vz[m->nv] = hat(m, x, y);
    m->used[(size_t)y * m->w + (size_t)x] = 1;
    return (int)m->nv++;
}

/* ------------------------------------------------------------ the heap */

static inline int better(const struct tin *m, int32_t a, int32_t b)
{
    return m->cerr[a] > m->cerr[b] ||
           (m->cerr[a] == m->cerr[b] && m->cidx[a] < m->cidx[b]);
}

static void heap_swap(struct tin *m, uint32_t i, uint32_t j)
{
    int32_t a = m->heap[i], b = m->heap[j];
    m->heap[i] = b;
    m->heap[j] = a;
    m->hpos[b] = (int32_t)i;
    m->hpos[a] = (int32_t)j;
}

static void heap_up(struct tin *m, uint32_t i)
{
    while (i > 0) {
        uint32_t p = (i - 1) / 2;
        if (!better(m, m->heap[i], m->heap[p]))
            break;
        heap_swap(m, i, p);
        i = p;
    }
}

static void heap_down(struct tin *m, uint32_t i)
{
    for (;;) {
        uint32_t l = 2 * i + 1, r = l + 1, b = i;
        if (l < m->nheap && better(m, m->heap[l], m->heap[b]))
            b = l;
        if (r < m->nheap && better(m, m->heap[r], m->heap[b]))
            b = r;
        if (b == i)
            break;
        heap_swap(m, i, b);
        i = b;
    }
}

static void heap_remove(struct tin *m, int32_t t)
{
    int32_t i = m->hpos[t];
    if (i < 0)
        return;
    m->hpos[t] = -1;
    uint32_t last = --m->nheap;
    if ((uint32_t)i == last)
        return;
    int32_t moved = m->heap[last];
    m->heap[i] = moved;
    m->hpos[moved] = i;
    heap_up(m, (uint32_t)i);
    heap_down(m, (uint32_t)m->hpos[moved]);
}

static void heap_push(struct tin *m, int32_t t)
{
    m->heap[m->nheap] = t;
    m->hpos[t] = (int32_t)m->nheap;
    heap_up(m, m->nheap++);
}

/* ------------------------------------------------------------ planes */

/* The plane of triangle t from its vertices rotated so that the smallest
 * sample index comes first: the same plane whichever half-edge order the
 * slot holds. */
static void plane_of(const struct tin *m, int32_t t, struct plane *pl)
{
    int32_t v[3] = {m->tv[3 * t], m->tv[3 * t + 1], m->tv[3 * t + 2]};
    int k = 0;
    for (int i = 1; i < 3; i++) {
        int64_t ki = (int64_t)m->vy[v[i]] * m->w + m->vx[v[i]];
        int64_t kk = (int64_t)m->vy[v[k]] * m->w + m->vx[v[k]];
        if (ki < kk)
            k = i;
    }
    int32_t a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
    double dx1 = m->vx[b] - m->vx[a], dy1 = m->vy[b] - m->vy[a];
    double dx2 = m->vx[c] - m->vx[a], dy2 = m->vy[c] - m->vy[a];
    double dz1 = (double)m->vz[b] - m->vz[a];
    double dz2 = (double)m->vz[c] - m->vz[a];
    double det = dx1 * dy2 - dx2 * dy1;
    pl->x0 = m->vx[a];
    pl->y0 = m->vy[a];
    pl->z0 = m->vz[a];
    pl->gx = (dz1 * dy2 - dz2 * dy1) / det;
    pl->gy = (dx1 * dz2 - dx2 * dz1) / det;
}

/* The plane's value on row y at x = 0; plane_at adds gx * x.  Scan
 * conversion hoists row_at out of its inner loop, and every other caller
 * goes through plane_at, so all see the same bits. */
static inline double row_at(const struct plane *pl, int32_t y)
{
    return pl->z0 + pl->gy * (double)(y - pl->y0) - pl->gx * (double)pl->x0;
}

static inline double plane_at(const struct plane *pl, int32_t x, int32_t y)
{
    return row_at(pl, y) + pl->gx * (double)x;
}

static inline int64_t floordiv(int64_t a, int64_t b)
{
    int64_t q = a / b;
    if ((a % b != 0) && ((a < 0) != (b < 0)))
        q--;
    return q;
}

/*
 * Scan convert triangle t (edges included) row by row: for each row the
 * span where all three edge functions are >= 0, exact in integers.  With
 * all = 0, used samples are skipped.  The sample of largest error (the
 * first in raster order on ties) comes back in *best_err / *best_idx
 * (index -1 and error 0 when there is none).
 */
static void scan_tri(const struct tin *m, int32_t t, int all,
                     double *best_err, int64_t *best_idx)
{
    struct plane pl;
    plane_of(m, t, &pl);
    int32_t v[3] = {m->tv[3 * t], m->tv[3 * t + 1], m->tv[3 * t + 2]};
    int64_t px[3], py[3];
    for (int i = 0; i < 3; i++) {
        px[i] = m->vx[v[i]];
        py[i] = m->vy[v[i]];
    }
    int64_t miny = py[0], maxy = py[0], minx = px[0], maxx = px[0];
    for (int i = 1; i < 3; i++) {
        if (py[i] < miny) miny = py[i];
        if (py[i] > maxy) maxy = py[i];
        if (px[i] < minx) minx = px[i];
        if (px[i] > maxx) maxx = px[i];
    }
    double be = 0;
    int64_t bi = -1;
    for (int64_t y = miny; y <= maxy; y++) {
        int64_t lo = minx, hi = maxx;
        for (int i = 0; i < 3 && lo <= hi; i++) {
            int j = (i + 1) % 3;
            /* orient(p_i, p_j, (x, y)) = A x + B >= 0 */
            int64_t A = -(py[j] - py[i]);
            int64_t B = (px[j] - px[i]) * (y - py[i]) + (py[j] - py[i]) * px[i];
            if (A > 0) {
                int64_t x0 = -floordiv(B, A); /* ceil(-B / A) */
                if (x0 > lo) lo = x0;
            } else if (A < 0) {
                int64_t x1 = floordiv(B, -A);
                if (x1 < hi) hi = x1;
            } else if (B < 0) {
                hi = lo - 1;
            }
        }
        const float *row = m->h + (size_t)y * m->stride;
        const uint8_t *urow = m->used + (size_t)y * m->w;
        double zr = row_at(&pl, (int32_t)y), gx = pl.gx;
        int64_t bx = -1;
        double xd = (double)lo; /* exact: x < 2^16 */
        for (int64_t x = lo; x <= hi; x++, xd += 1.0) {
            double e = fabs((double)row[x] - (zr + gx * xd));
            /* used samples are skipped only where they would win: the
             * same maximum, one load and branch less per sample */
            if (e > be && (all || !urow[x])) {
                be = e;
                bx = x;
            }
        }
        if (bx >= 0)
            bi = y * (int64_t)m->w + bx;
    }
    *best_err = be;
    *best_idx = bi;
}

/* Queue triangle t for a scan.  It may stay in the heap with a stale key
 * until flush() updates it: nothing is selected in between. */
static void mark(struct tin *m, int32_t t)
{
    if (!m->pflag[t]) {
        m->pflag[t] = 1;
        m->pend[m->npend++] = t;
    }
}

/* Scan the queued triangles and put those with a candidate in the heap. */
static void flush(struct tin *m, int use_heap)
{
    for (uint32_t i = 0; i < m->npend; i++) {
        int32_t t = m->pend[i];
        m->pflag[t] = 0;
        if (!use_heap)
            continue;
        scan_tri(m, t, 0, &m->cerr[t], &m->cidx[t]);
        int has = m->cidx[t] >= 0 && m->cerr[t] > 0;
        if (m->hpos[t] < 0) {
            if (has)
                heap_push(m, t);
        } else if (!has) {
            heap_remove(m, t);
        } else { /* the new key, either way */
            heap_up(m, (uint32_t)m->hpos[t]);
            heap_down(m, (uint32_t)m->hpos[t]);
        }
    }
    m->npend = 0;
}

/* ------------------------------------------------------------ the mesh */

/* Write triangle (a, b, c) with opposite half-edges (ab, bc, ca) into slot
 * e/3 (e < 0: a new slot).  Returns its first half-edge. */
static int add_tri(struct tin *m, int32_t a, int32_t b, int32_t c, int ab,
                   int bc, int ca, int e)
{
    if (e < 0) {
        e = (int)(3 * m->nt++);
        m->hpos[e / 3] = -1;
        m->pflag[e / 3] = 0;
    }
    m->tv[e] = a;
    m->tv[e + 1] = b;
    m->tv[e + 2] = c;
    m->he[e] = ab;
    m->he[e + 1] = bc;
    m->he[e + 2] = ca;
    if (ab >= 0) m->he[ab] = e;
    if (bc >= 0) m->he[bc] = e + 1;
    if (ca >= 0) m->he[ca] = e + 2;
    /* every split and flip rewrites each vertex it touches, so these stay
     * valid */
    m->vhe[a] = e;
    m->vhe[b] = e + 1;
    m->vhe[c] = e + 2;
    mark(m, e / 3);
    return e;
}

static int incircle(const struct tin *m, int32_t a, int32_t b, int32_t c,
                    int32_t d)
{
    int64_t adx = m->vx[a] - m->vx[d], ady = m->vy[a] - m->vy[d];
    int64_t bdx = m->vx[b] - m->vx[d], bdy = m->vy[b] - m->vy[d];
    int64_t cdx = m->vx[c] - m->vx[d], cdy = m->vy[c] - m->vy[d];
    gv_i128 al = (gv_i128)(adx * adx + ady * ady);
    gv_i128 bl = (gv_i128)(bdx * bdx + bdy * bdy);
    gv_i128 cl = (gv_i128)(cdx * cdx + cdy * cdy);
    gv_i128 det = al * (gv_i128)(bdx * cdy - cdx * bdy) -
                  bl * (gv_i128)(adx * cdy - cdx * ady) +
                  cl * (gv_i128)(adx * bdy - bdx * ady);
    return det > 0; /* d strictly inside the circle of CCW a, b, c */
}

static int push_edge(struct tin *m, int e)
{
    if (m->nstack == m->capstack &&
        grow((void **)&m->stack, &m->capstack, m->nstack + 1,
             sizeof *m->stack) < 0)
        return -1;
    m->stack[m->nstack++] = e;
    return 0;
}

/* Lawson's flips from half-edge a0, whose triangle holds the new point
 * opposite it (section 4.2.1). */
static int legalize(struct tin *m, int a0)
{
    if (push_edge(m, a0) < 0)
        return -1;
    while (m->nstack) {
        int a = m->stack[--m->nstack];
        int b = m->he[a];
        if (b < 0)
            continue;
        int ta = a - a % 3, tb = b - b % 3;
        int al = ta + (a + 1) % 3, ar = ta + (a + 2) % 3;
        int bl = tb + (b + 2) % 3, br = tb + (b + 1) % 3;
        int32_t p0 = m->tv[ar], pr = m->tv[a], pl = m->tv[al];
        int32_t p1 = m->tv[bl];
        if (!incircle(m, pr, pl, p0, p1))
            continue;
        int hal = m->he[al], har = m->he[ar];
        int hbl = m->he[bl], hbr = m->he[br];
        int t0 = add_tri(m, p0, p1, pl, -1, hbl, hal, ta);
        int t1 = add_tri(m, p1, p0, pr, t0, har, hbr, tb);
        if (push_edge(m, t1 + 2) < 0 || push_edge(m, t0 + 1) < 0)
            return -1;
    }
    return 0;
}

/*
 * Insert sample (x, y), which lies in triangle t (edges included), as a new
 * vertex.  A point on an edge splits both triangles of the edge; the one
 * in the smaller slot is split from, so that the result does not depend on
 * which of the two offered the point.
 */
static int insert_point(struct tin *m, int32_t t, int32_t x, int32_t y)
{
    if (reserve_tris(m, m->nt + 3) < 0)
        return -1;
    int on = -1;
    for (int k = 0; k < 3; k++) {
        int32_t a = m->tv[3 * t + k], b = m->tv[3 * t + (k + 1) % 3];
        if (orient(m->vx[a], m->vy[a], m->vx[b], m->vy[b], x, y) == 0)
            on = 3 * t + k;
    }
    if (on >= 0 && m->he[on] >= 0 && m->he[on] / 3 < t) {
        on = m->he[on];
        t = on / 3;
    }
    int p = add_vertex(m, x, y);
    if (p < 0)
        return -1;
    if (on < 0) {
        int e0 = 3 * t;
        int32_t a = m->tv[e0], b = m->tv[e0 + 1], c = m->tv[e0 + 2];
        int hab = m->he[e0], hbc = m->he[e0 + 1], hca = m->he[e0 + 2];
        int t0 = add_tri(m, a, b, p, hab, -1, -1, e0);
        int t1 = add_tri(m, b, c, p, hbc, -1, t0 + 1, -1);
        int t2 = add_tri(m, c, a, p, hca, t0 + 2, t1 + 1, -1);
        if (legalize(m, t0) < 0 || legalize(m, t1) < 0 ||
            legalize(m, t2) < 0)
            return -1;
        return 0;
    }
    int e = on, h = m->he[on];
    int32_t a = m->tv[e], b = m->tv[next_he(e)], c = m->tv[prev_he(e)];
    int hbc = m->he[next_he(e)], hca = m->he[prev_he(e)];
    if (h < 0) {
        int t0 = add_tri(m, c, a, p, hca, -1, -1, e - e % 3);
        int t1 = add_tri(m, b, c, p, hbc, t0 + 2, -1, -1);
        if (legalize(m, t0) < 0 || legalize(m, t1) < 0)
            return -1;
        return 0;
    }
    int32_t d = m->tv[prev_he(h)];
    int had = m->he[next_he(h)], hdb = m->he[prev_he(h)];
    int t0 = add_tri(m, c, a, p, hca, -1, -1, e - e % 3);
    int t1 = add_tri(m, b, c, p, hbc, t0 + 2, -1, -1);
    int t2 = add_tri(m, a, d, p, had, -1, t0 + 1, h - h % 3);
    int t3 = add_tri(m, d, b, p, hdb, t1 + 2, t2 + 1, -1);
    if (legalize(m, t0) < 0 || legalize(m, t1) < 0 || legalize(m, t2) < 0 ||
        legalize(m, t3) < 0)
        return -1;
    return 0;
}

/* The hull half-edge leaving hull vertex v: turn around v across the
 * half-edges that leave it until one has no twin. */
static int hull_out(const struct tin *m, int32_t v)
{
    int e = m->vhe[v];
    while (m->he[e] >= 0)
        e = next_he(m->he[e]);
    return e;
}

/* ------------------------------------------------------------ 1D border */

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

int gv_tin_edge_greedy(const float *s, size_t step, uint32_t n,
                       double max_error, uint32_t *pos, uint32_t *count_out)
{
    /* Greedy insertion on a polyline splits a segment at its sample of
     * largest error, and no insertion elsewhere changes that segment: the
     * chosen set is the recursive split of every segment whose largest
     * error exceeds max_error, whatever the order.  A stack of segments
     * (at most one per chosen sample, plus one) finds it. */
    uint32_t *stk = malloc(2 * ((size_t)n + 1) * sizeof *stk);
    uint32_t count = 0, top = 0;
    *count_out = 0;
    if (!stk)
        return -1;
    stk[top++] = 0;
    stk[top++] = n - 1;
    while (top) {
        uint32_t r = stk[--top], l = stk[--top];
        double zl = s[(size_t)l * step], zr = s[(size_t)r * step];
        double be = 0;
        uint32_t bi = 0;
        for (uint32_t i = l + 1; i < r; i++) {
            double z = zl + (zr - zl) * (double)(i - l) / (double)(r - l);
            double e = fabs((double)s[(size_t)i * step] - z);
            if (e > be) { /* in position order: ties keep the first */
                be = e;
                bi = i;
            }
        }
        if (be <= max_error || be == 0)
            continue;
        pos[count++] = bi;
        stk[top++] = l;
        stk[top++] = bi;
        stk[top++] = bi;
        stk[top++] = r;
    }
    free(stk);
    qsort(pos, count, sizeof *pos, cmp_u32);
    *count_out = count;
    return 0;
}

/* ------------------------------------------------------------ driver */

static void tin_release(struct tin *m)
{
    free(m->used);
    free(m->vx);
    free(m->vy);
    free(m->vz);
    free(m->vhe);
    free(m->tv);
    free(m->he);
    free(m->cerr);
    free(m->cidx);
    free(m->hpos);
    free(m->heap);
    free(m->pend);
    free(m->pflag);
    free(m->stack);
}

/* Algorithm I's selection: every unused sample, located by a linear search
 * over the triangles; the largest error, the smaller index on ties. */
static void brute_select(const struct tin *m, double *be_out, int64_t *bi_out,
                         int32_t *bt_out)
{
    double be = 0;
    int64_t bi = -1;
    int32_t bt = -1;
    for (uint32_t y = 0; y < m->hgt; y++)
        for (uint32_t x = 0; x < m->w; x++) {
            int64_t idx = (int64_t)y * m->w + x;
            if (m->used[idx])
                continue;
            for (uint32_t t = 0; t < m->nt; t++) {
                const int32_t *v = m->tv + 3 * t;
                int in = 1;
                for (int k = 0; k < 3 && in; k++) {
                    int32_t a = v[k], b = v[(k + 1) % 3];
                    in = orient(m->vx[a], m->vy[a], m->vx[b], m->vy[b], x,
                                y) >= 0;
                }
                if (!in)
                    continue;
                struct plane pl;
                plane_of(m, (int32_t)t, &pl);
                double e = fabs((double)hat(m, (int32_t)x, (int32_t)y) -
                                plane_at(&pl, (int32_t)x, (int32_t)y));
                if (e > be) {
                    be = e;
                    bi = idx;
                    bt = (int32_t)t;
                }
                /* a sample on an edge is seen from both triangles, as in
                 * the scan conversion, and keeps the larger error */
            }
        }
    *be_out = be;
    *bi_out = bi;
    *bt_out = bt;
}

/* Border-first insertion: the vertices of the 1D greedy insertion along
 * each side (gv_tin_edge_greedy to error goal), inserted on the hull.
 * bpos has room for the longer side.  Returns 0, or -1 out of memory. */
static int insert_border(struct tin *m, double goal, uint32_t *bpos)
{
    const float *h = m->h;
    size_t stride = m->stride;
    uint32_t w = m->w, hgt = m->hgt;
    int32_t W = (int32_t)w - 1, H = (int32_t)hgt - 1;
    /* Each side in the hull's direction (counter-clockwise: +x along
     * the top, +y down the right, -x along the bottom, -y up the
     * left), from its first corner: each sample lies on the hull edge
     * leaving the one inserted before it. */
    struct {
        const float *s;
        size_t step;
        uint32_t n;
        int32_t x0, y0, dx, dy;
        int reverse;
        int32_t corner;
    } edge[4] = {
        {h, 1, w, 0, 0, 1, 0, 0, 0},
        {h + W, stride, hgt, W, 0, 0, 1, 0, 1},
        {h + (size_t)H * stride, 1, w, 0, H, 1, 0, 1, 2},
        {h, stride, hgt, 0, 0, 0, 1, 1, 3},
    };
    for (int k = 0; k < 4; k++) {
        uint32_t n;
        if (gv_tin_edge_greedy(edge[k].s, edge[k].step, edge[k].n, goal,
                               bpos, &n) < 0)
            return -1;
        int32_t prev = edge[k].corner;
        for (uint32_t i = 0; i < n; i++) {
            uint32_t q = bpos[edge[k].reverse ? n - 1 - i : i];
            int32_t x = edge[k].x0 + edge[k].dx * (int32_t)q;
            int32_t y = edge[k].y0 + edge[k].dy * (int32_t)q;
            if (insert_point(m, hull_out(m, prev) / 3, x, y) < 0)
                return -1;
            prev = (int32_t)m->nv - 1;
        }
    }
    return 0;
}

/* The measured error of the mesh, over every sample (clears used). */
static double measured_error(struct tin *m)
{
    double me = 0;
    memset(m->used, 0, (size_t)m->w * m->hgt);
    for (uint32_t t = 0; t < m->nt; t++) {
        double e;
        int64_t i;
        scan_tri(m, (int32_t)t, 1, &e, &i);
        if (e > me)
            me = e;
    }
    return me;
}

/* The result of the private state: the one mesh type (mesh/mesh.h), the
 * vertices as grid coordinates in floats.  Returns 0, or -1 out of
 * memory (*out then empty). */
static int hand_out(const struct tin *m, uint32_t w, uint32_t hgt, double me,
                    struct gv_mesh *out)
{
    out->width = w;
    out->height = hgt;
    out->nverts = m->nv;
    out->ntris = m->nt;
    out->max_error = me;
    out->pos = malloc((size_t)m->nv * 3 * sizeof *out->pos);
    out->tris = malloc((size_t)m->nt * 3 * sizeof *out->tris);
    if (!out->pos || !out->tris) {
        gv_mesh_free(out);
        return -1;
    }
    out->zmin = out->zmax = m->vz[0];
    for (uint32_t i = 0; i < m->nv; i++) {
        out->pos[3 * (size_t)i] = (float)m->vx[i];
        out->pos[3 * (size_t)i + 1] = (float)m->vy[i];
        out->pos[3 * (size_t)i + 2] = m->vz[i];
        if (m->vz[i] < out->zmin) out->zmin = m->vz[i];
        if (m->vz[i] > out->zmax) out->zmax = m->vz[i];
    }
    for (uint32_t i = 0; i < 3 * m->nt; i++)
        out->tris[i] = (uint32_t)m->tv[i];
    return 0;
}

static int build(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                 const struct gv_tin_params *p, int brute, struct gv_mesh *out,
                 struct gv_error *err)
{
    struct tin m;
    uint32_t *bpos = NULL;
    int rc = -1;
    memset(&m, 0, sizeof m);
    memset(out, 0, sizeof *out);
    if (w < 2 || hgt < 2 || w > GV_TIN_MAX_SIDE || hgt > GV_TIN_MAX_SIDE)
        return gv_fail(err, GV_EINVAL, "mesh: grid %ux%u outside 2..%u", w,
                       hgt, GV_TIN_MAX_SIDE);
    if (stride < w)
        return gv_fail(err, GV_EINVAL, "mesh: stride %zu < width %u", stride,
                       w);
    if (!(p->max_error >= 0) && p->max_triangles == 0)
        return gv_fail(err, GV_EINVAL,
                       "mesh: needs a maximum error or a triangle limit");
    if (p->border_first && !(p->max_error >= 0))
        return gv_fail(err, GV_EINVAL,
                       "mesh: border-first insertion needs a maximum error");
    m.h = h;
    m.w = w;
    m.hgt = hgt;
    m.stride = stride;
    double goal = p->max_error >= 0 ? p->max_error : -1;
    m.used = calloc((size_t)w * hgt, 1);
    bpos = malloc((size_t)(w > hgt ? w : hgt) * sizeof *bpos);
    if (!m.used || !bpos || reserve_tris(&m, 64) < 0)
        goto nomem;
    for (uint32_t y = 0; y < hgt; y++)
        for (uint32_t x = 0; x < w; x++)
            if (!isfinite(h[(size_t)y * stride + x])) {
                gv_fail(err, GV_EINVAL, "mesh: height at (%u,%u) is not finite",
                        x, y);
                goto out;
            }
    int32_t W = (int32_t)w - 1, H = (int32_t)hgt - 1;
    if (add_vertex(&m, 0, 0) < 0 || add_vertex(&m, W, 0) < 0 ||
        add_vertex(&m, W, H) < 0 || add_vertex(&m, 0, H) < 0)
        goto nomem;
    int t0 = add_tri(&m, 0, 1, 2, -1, -1, -1, -1);
    add_tri(&m, 0, 2, 3, t0 + 2, -1, -1, -1);

    if (p->border_first) {
        if (insert_border(&m, goal, bpos) < 0)
            goto nomem;
        if (p->max_triangles && m.nt > p->max_triangles) {
            gv_fail(err, GV_ELIMIT, "mesh: the border alone needs %u "
                    "triangles at error %g, over the limit of %u", m.nt,
                    goal, p->max_triangles);
            goto out;
        }
        for (uint32_t x = 0; x < w; x++)
            m.used[x] = m.used[(size_t)H * w + x] = 1;
        for (uint32_t y = 0; y < hgt; y++)
            m.used[(size_t)y * w] = m.used[(size_t)y * w + (size_t)W] = 1;
    }
    flush(&m, !brute);

    struct timespec t0s;
    clock_gettime(CLOCK_MONOTONIC, &t0s);
    for (uint32_t step = 1;; step++) {
        if (p->time_limit > 0 && step % 1024 == 0) {
            struct timespec now;
            clock_gettime(CLOCK_MONOTONIC, &now);
            double el = (double)(now.tv_sec - t0s.tv_sec) +
                        (double)(now.tv_nsec - t0s.tv_nsec) * 1e-9;
            if (el > p->time_limit) {
                gv_fail(err, GV_ETIMEOUT, "mesh: over the time limit of "
                        "%g s after %u vertices", p->time_limit, m.nv);
                goto out;
            }
        }
        double be;
        int64_t bi;
        int32_t bt;
        if (brute) {
            brute_select(&m, &be, &bi, &bt);
        } else {
            if (m.nheap == 0)
                break;
            bt = m.heap[0];
            be = m.cerr[bt];
            bi = m.cidx[bt];
        }
        if (bi < 0 || be <= 0 || (goal >= 0 && be <= goal))
            break;
        if (p->max_triangles && m.nt + 2 > p->max_triangles)
            break;
        if (insert_point(&m, bt, (int32_t)(bi % w), (int32_t)(bi / w)) < 0)
            goto nomem;
        flush(&m, !brute);
    }

    /* the measured error, over every sample */
    if (hand_out(&m, w, hgt, measured_error(&m), out) < 0)
        goto nomem;
    rc = 0;
    goto out;
nomem:
    gv_fail(err, GV_ENOMEM, "mesh: out of memory (%u vertices)", m.nv);
out:
    free(bpos);
    tin_release(&m);
    return rc;
}

int gv_tin_build(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                 const struct gv_tin_params *p, struct gv_mesh *out,
                 struct gv_error *err)
{
    return build(h, w, hgt, stride, p, 0, out, err);
}

int gv_tin_build_brute(const float *h, uint32_t w, uint32_t hgt,
                       size_t stride, const struct gv_tin_params *p,
                       struct gv_mesh *out, struct gv_error *err)
{
    return build(h, w, hgt, stride, p, 1, out, err);
}
