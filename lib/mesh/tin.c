/*
 * tin.c - greedy insertion with an incremental Delaunay triangulation
 * (Garland & Heckbert, CMU-CS-95-181, section 4.4, algorithm III).
 *
 * The mesh is a half-edge array: triangle t owns half-edges 3t, 3t+1,
 * 3t+2; half-edge e runs from corner TC(e) to TC(next(e)), and HE(e) is
 * the opposite half-edge or -1 on the hull.  A corner is its sample's
 * coordinates, not a vertex id: flips and scans read no vertex record,
 * and the output maps corners to vertex ids once (hand_out).  Triangle
 * slots are reused in place by splits and flips, never freed, so the slot
 * count is the triangle count.
 *
 * Each triangle holds its candidate (section 4.3): the unused sample of
 * largest error inside it, found by scan converting it row by row with
 * exact edge functions (samples on an edge belong to both sides, as the
 * paper allows in 4.3.1).  The candidates over the error goal live in an
 * indexed 4-ary max-heap keyed on (error, -sample index); the others can
 * never be chosen and stay out of it.  Inserting a point splits its
 * triangle (or the two triangles of the edge it lies on), then Lawson's
 * flips restore the Delaunay property (section 4.2.1, figure 4); every
 * triangle created or flipped is queued and scanned once after the
 * insertion, which is the update region of section 4.2.2.
 *
 * The cost (profiled on 1025^2 ETOPO5 grids, bench/tin-speed.sh) is memory
 * latency and branches as much as the rescans: a split or flip touches
 * one 32-byte triangle record (corners' coordinates, twins, candidate
 * error; the corners' heights come from the grid, whose rows the scan
 * reads anyway), heap entries carry their keys and four siblings
 * share a cache line (a sift down asks for the grandchildren's lines a
 * level ahead, and picks the best child with selects: a quarter of all
 * mispredicted branches were the heap's), the heap places lie apart from the records, the
 * arrays are reserved once (in huge pages where they reach 2 MiB: the
 * random walks over them miss the TLB less, and fault 512 times less
 * often; 4 to 12 % of the single mesh's CPU time), a half-edge from
 * each border sample is kept up only while the border is inserted
 * (hull_out), the in-circle test runs in 64 bits on grids up to 16384 a side, and no
 * row of a scan divides.  With coordinates in the records the flips
 * miss no line (cachegrind, andes E=50: L1 data misses 11.3 -> 10.6 x
 * 10^6, last-level 2.39 -> 2.12 x 10^6); 0.82 to 1.01 times the CPU time.
 *
 * A scan reads as few heights as it can.  The used samples inside a
 * triangle are its corners, which end the spans of their rows, and in
 * border-first mode the border, outside the scanned box: no sample is
 * looked up in the used map.  A triangle of twice area 1 holds no other
 * sample (Pick's theorem): many scans end there; one of twice area 2 or
 * 3 (40 % of the rest) holds one to two, found from its corners without
 * a scan (small_tri; 5.6 % fewer instructions).  The rows run in two
 * parts split at the middle corner, with one bounding edge each side.
 * Each row goes by runs within segments of SEG samples, whose lowest and
 * highest heights are kept (segmm, SEGROWS rows of a segment to a cache
 * line, so that a narrow triangle reads few lines of them): a run whose
 * bound, from those and the plane at its ends, cannot reach the best
 * error so far is skipped.  The bound has a slack far over the rounding,
 * so the skipped samples could not have won and the candidate is the
 * same sample: the meshes are bit for bit those of before.  A quarter of
 * the heights are read.  With the record and heap changes above, in
 * cachegrind (andes, a 1 MiB last-level cache) the last-level data misses
 * drop by 39 % at E = 200 and 27 % at E = 50, for 6 % fewer and 1 % more
 * instructions; in one process, interleaved, the single mesh takes 0.81
 * to 1.04 times the CPU time of before, 0.97 in the median (the load of
 * the machine blurs it).  A
 * grid of up to SEG_GRID samples (64^2 tiles) stays in cache, where the
 * bounds cost more instructions than the samples they skip: its scans
 * take whole spans.
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
#include <sys/mman.h>
#include <time.h>

__extension__ typedef __int128 gv_i128;

/* A vertex: its sample and height, 8 bytes (sides < 2^16). */
struct vert {
    uint16_t x, y;
    float z;
};

/* A heap entry carries its key, so that sifting reads the heap alone:
 * larger error first, then the smaller sample index. */
struct hent {
    double err;
    uint32_t idx;
    int32_t t;
};

/* A corner: its sample's coordinates, y << 16 | x (sides < 2^16), which
 * order as (y, x) do. */
#define CX(c) ((int32_t)((c) & 0xffffu))
#define CY(c) ((int32_t)((c) >> 16))
#define CORNER(x, y) ((uint32_t)(y) << 16 | (uint32_t)(x))

/* A triangle: half-edge 3t + k runs from corner c[k] to c[k + 1 mod 3],
 * he[k] is its opposite half-edge or -1 on the hull.  What a split, a flip
 * and a scan touch shares one 32-byte record: the corners are coordinates,
 * not vertex ids, so that neither loads a vertex (hand_out finds the ids).
 * The heap's places are apart (the heap moves write them, many to a
 * line). */
struct tri {
    uint32_t c[3];
    int32_t he[3];
    double cerr;             /* its candidate's error (the largest over its
                                unused samples, 0: none); -1 while queued
                                in pend for a scan */
};

#define TC(m, e) ((m)->t[(unsigned)(e) / 3].c[(unsigned)(e) % 3])
#define HE(m, e) ((m)->t[(unsigned)(e) / 3].he[(unsigned)(e) % 3])

struct tin {
    const float *h;
    uint32_t w, hgt;
    size_t stride;
    double goal;             /* candidates at or below it never enter the
                                heap; -1 with no error goal */
    int small;               /* sides <= 16384: incircle in 64 bits */
    int inner;               /* border-first: candidates off the border */
    float *segmm;            /* min and max height of each row's segments
                                of SEG samples (nseg a row), SEGROWS rows
                                of a segment to a cache line (seg_row);
                                NULL up to SEG_GRID samples: whole spans */
    uint32_t nseg;
    double habs;             /* the largest |height| */
    uint8_t *used;           /* w*hgt: a vertex, or a border sample in
                                border-first mode (the brute force's) */
    uint32_t nv, capv;
    struct vert *v;
    int track;               /* keep vhe (border insertion only) */
    int32_t *vhe;            /* a half-edge leaving each border sample
                                (border_at) */
    uint32_t nt, capt;
    struct tri *t;           /* 64-byte aligned, 2 a cache line */
    struct hent *heap;       /* heapmem + HEAP_OFF */
    struct hent *heapmem;    /* 64-byte aligned */
    uint32_t nheap;
    int32_t *hpos;           /* place of each triangle in heap, -1: none */
    int32_t *pend;           /* triangles to scan after this insertion */
    uint32_t npend;
    int32_t *stack;          /* half-edges to legalize */
    uint32_t nstack, capstack;
};

#define NONE UINT32_MAX
#define SEG 16
#define SEGROWS 8
#define SEG_GRID 65536 /* samples: a grid up to this stays in cache, where
                          segmm costs more than it skips (64^2 tiles) */
#define HEAP_OFF 3u /* see the heap */

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

#define HUGE_PAGE ((size_t)1 << 21)

/* n bytes aligned to a cache line; from HUGE_PAGE up, aligned to and
 * rounded to huge pages, which the kernel is asked to use: the random
 * walks over the triangles and the heap would miss the TLB on every
 * access with 4 KiB pages (and fault 512 times as often).  Free with
 * free(). */
static void *big_alloc(size_t n)
{
    if (n < HUGE_PAGE)
        return aligned_alloc(64, (n + 63) / 64 * 64);
    n = (n + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE;
    void *p = aligned_alloc(HUGE_PAGE, n);
#ifdef MADV_HUGEPAGE
    if (p)
        madvise(p, n, MADV_HUGEPAGE); /* advice: failure is harmless */
#endif
    return p;
}

static int reserve_tris(struct tin *m, uint32_t need)
{
    if (need <= m->capt)
        return 0;
    uint32_t c = m->capt ? m->capt : 64;
    while (c < need)
        c *= 2;
    struct tri *nt = big_alloc((size_t)c * sizeof *nt);
    if (!nt)
        return -1;
    if (m->nt)
        memcpy(nt, m->t, (size_t)m->nt * sizeof *nt);
    free(m->t);
    m->t = nt;
    /* c + 4 entries from a line: the heap proper starts HEAP_OFF in */
    struct hent *hh = big_alloc(((size_t)c + 4) * sizeof *hh);
    if (!hh)
        return -1;
    if (m->nheap)
        memcpy(hh + HEAP_OFF, m->heap, (size_t)m->nheap * sizeof *hh);
    free(m->heapmem);
    m->heapmem = hh;
    m->heap = hh + HEAP_OFF;
    int32_t *pe = big_alloc((size_t)c * sizeof *pe);
    if (!pe)
        return -1;
    if (m->npend)
        memcpy(pe, m->pend, (size_t)m->npend * sizeof *pe);
    free(m->pend);
    m->pend = pe;
    int32_t *hpo = big_alloc((size_t)c * sizeof *hpo);
    if (!hpo)
        return -1;
    if (m->nt)
        memcpy(hpo, m->hpos, (size_t)m->nt * sizeof *hpo);
    free(m->hpos);
    m->hpos = hpo;
    m->capt = c;
    return 0;
}

/* Frees what reserve_tris holds (before any triangle), to try again. */
static void release_tris(struct tin *m)
{
    free(m->t);
    free(m->heapmem);
    free(m->pend);
    free(m->hpos);
    m->t = NULL;
    m->heapmem = m->heap = NULL;
    m->pend = NULL;
    m->hpos = NULL;
    m->capt = 0;
}

/* Adds vertex (x, y).  Returns 0, or -1 out of memory. */
static int add_vertex(struct tin *m, int32_t x, int32_t y)
{
    if (m->nv == m->capv &&
        grow((void **)&m->v, &m->capv, m->nv + 1, sizeof *m->v) < 0)
        return -1;
    m->v[m->nv].x = (uint16_t)x;
    m->v[m->nv].y = (uint16_t)y;
    m->v[m->nv].z = hat(m, x, y);
    if (m->used)
        m->used[(size_t)y * m->w + (size_t)x] = 1;
    m->nv++;
    return 0;
}

/* The place of border sample c in vhe: along the top, down the right,
 * along the bottom, up the left. */
static inline uint32_t border_at(const struct tin *m, uint32_t c)
{
    uint32_t x = (uint32_t)CX(c), y = (uint32_t)CY(c);
    if (y == 0)
        return x;
    if (x == m->w - 1)
        return m->w + y;
    if (y == m->hgt - 1)
        return m->w + m->hgt + x;
    return 2 * m->w + m->hgt + y;
}

/* ------------------------------------------------------------ the heap */

/* An indexed 4-ary max-heap of the triangles whose candidate is over the
 * goal (section 4.3): hpos[t] is t's place, so a rescanned triangle moves
 * to its new key and a replaced one leaves; no stale entries.  Sifting
 * moves a hole instead of swapping.  Four children of 16 bytes share one
 * cache line (the array starts HEAP_OFF entries before a 64-byte line, so
 * that entry 4i + 1 begins one): half the depth of a binary heap, and one
 * line missed per level.  The order is strict and total on the keys, so
 * the top does not depend on the arity. */
static inline int better(const struct hent *a, const struct hent *b)
{
    return a->err > b->err || (a->err == b->err && a->idx < b->idx);
}

/* Of places i and j, i if its entry is better() than j's, else j: the
 * errors are >= 0, whose bits order as the numbers do, so the test is on
 * integers and the choice a mask, without a branch. */
static inline uint32_t better_sel(const struct hent *hp, uint32_t i,
                                  uint32_t j)
{
    uint64_t a, b;
    memcpy(&a, &hp[i].err, sizeof a);
    memcpy(&b, &hp[j].err, sizeof b);
    uint32_t w = (a > b) | ((a == b) & (hp[i].idx < hp[j].idx));
    return j ^ ((i ^ j) & -w);
}

static void heap_place(struct tin *m, uint32_t i, struct hent e)
{
    struct hent *hp = m->heap;
    while (i > 0) {
        uint32_t p = (i - 1) / 4;
        if (!better(&e, &hp[p]))
            break;
        hp[i] = hp[p];
        m->hpos[hp[i].t] = (int32_t)i;
        i = p;
    }
    for (;;) {
        uint32_t l = 4 * i + 1, b;
        if (l >= m->nheap)
            break;
        b = l;
        /* the grandchildren's four lines, one of which comes next */
        if (4 * l + 13 < m->nheap)
            for (int g = 0; g < 4; g++)
                __builtin_prefetch(&hp[4 * l + 1 + 4 * (uint32_t)g]);
        uint32_t end = l + 4 < m->nheap ? l + 4 : m->nheap;
        if (end == l + 4) {
            /* four children: a knockout of selects, not branches (which
             * child wins is a coin toss), the first of equals winning */
            uint32_t b0 = better_sel(hp, l + 1, l);
            uint32_t b1 = better_sel(hp, l + 3, l + 2);
            b = better_sel(hp, b1, b0);
        } else {
            for (uint32_t c = l + 1; c < end; c++)
                if (better(&hp[c], &hp[b]))
                    b = c;
        }
        if (!better(&hp[b], &e))
            break;
        hp[i] = hp[b];
        m->hpos[hp[i].t] = (int32_t)i;
        i = b;
    }
    hp[i] = e;
    m->hpos[e.t] = (int32_t)i;
}

static void heap_remove(struct tin *m, int32_t t)
{
    int32_t i = m->hpos[t];
    if (i < 0)
        return;
    m->hpos[t] = -1;
    uint32_t last = --m->nheap;
    if ((uint32_t)i != last)
        heap_place(m, (uint32_t)i, m->heap[last]);
}

/* Put t in the heap with key (err, idx), or move it there. */
static void heap_set(struct tin *m, int32_t t, double err, uint32_t idx)
{
    struct hent e = {err, idx, t};
    if (m->hpos[t] < 0)
        heap_place(m, m->nheap++, e);
    else
        heap_place(m, (uint32_t)m->hpos[t], e);
}

/* ------------------------------------------------------------ planes */

/* The plane through corners c[0..2] of a triangle, from its corners
 * rotated so that the smallest sample index comes first: the same plane
 * whichever half-edge order the slot holds.  The heights come from the
 * grid (a scan reads those rows anyway). */
static void plane_from(const struct tin *m, const uint32_t c[3],
                       struct plane *pl)
{
    /* the smallest (y, x): the smallest corner, no branch */
    int k = c[1] < c[0];
    uint32_t kk = k ? c[1] : c[0];
    k = c[2] < kk ? 2 : k;
    static const uint8_t n1[3] = {1, 2, 0}, n2[3] = {2, 0, 1};
    uint32_t a = c[k], b = c[n1[k]], d = c[n2[k]];
    int32_t ax = CX(a), ay = CY(a), bx = CX(b), by = CY(b);
    int32_t dx = CX(d), dy = CY(d);
    float az = hat(m, ax, ay), bz = hat(m, bx, by), dz = hat(m, dx, dy);
    double dx1 = bx - ax, dy1 = by - ay;
    double dx2 = dx - ax, dy2 = dy - ay;
    double dz1 = (double)bz - az;
    double dz2 = (double)dz - az;
    double det = dx1 * dy2 - dx2 * dy1;
    pl->x0 = ax;
    pl->y0 = ay;
    pl->z0 = az;
    pl->gx = (dz1 * dy2 - dz2 * dy1) / det;
    pl->gy = (dx1 * dz2 - dx2 * dz1) / det;
}

static void plane_of(const struct tin *m, int32_t t, struct plane *pl)
{
    plane_from(m, m->t[t].c, pl);
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

/*
 * floor(b / a) for integers |b| < 2^34 and 0 < a < 2^17, as b * (1 / a)
 * in doubles, clamped to +-2^17 (beyond any coordinate).  Exact: the
 * quotient's fraction is 0 or at least 1 / a >= 2^-17, the product's
 * rounding error below 2^-33 where it matters (|b / a| < 2^18), and the
 * nudge of 2^-20 lies between the two.  No integer division per row.
 */
#define FLOOR_OFF 262144.0 /* 2^18: truncation is floor above 0 */
static inline int32_t floor_q(double b, double inv)
{
    double q = b * inv + 0x1p-20;
    q = q < -131072.0 ? -131072.0 : q > 131072.0 ? 131072.0 : q;
    return (int32_t)(q + FLOOR_OFF) - (int32_t)FLOOR_OFF;
}

/* Row y's bounds of segment k: seg_row(m, y)[2 SEGROWS k], the lowest,
 * and the next float, the highest.  The SEGROWS rows of a band share a
 * line per segment, so a narrow triangle reads a line or two of them. */
static inline const float *seg_row(const struct tin *m, int32_t y)
{
    uint32_t u = (uint32_t)y;
    return m->segmm + 2 * ((size_t)(u / SEGROWS) * m->nseg * SEGROWS +
                           u % SEGROWS);
}

/* The samples x0 .. x1 of a row against the plane's row value zr: the
 * first of largest error over *be goes to *be, *bx. */
static inline void scan_run(const float *row, double zr, double gx,
                            int32_t x0, int32_t x1, double *be, int32_t *bx)
{
    double b = *be;
    int32_t bb = *bx;
    double xd = (double)x0; /* exact: x < 2^16 */
    for (int32_t x = x0; x <= x1; x++, xd += 1.0) {
        double e = fabs((double)row[x] - (zr + gx * xd));
        if (e > b) {
            b = e;
            bb = x;
        }
    }
    *be = b;
    *bx = bb;
}

/* Row samples x0 .. x1 as scan_run, by runs within segments of SEG
 * samples (mm: the row's bounds, seg_row): a run is skipped where no
 * sample of its segment can reach *be (over the segment's heights and the
 * plane's values at the run's ends, and slack). */
static inline void scan_segs(const float *mm, const float *row, double zr,
                             double gx, double slack, int32_t x0, int32_t x1,
                             double *be, int32_t *bx)
{
    for (int32_t x = x0; x <= x1;) {
        int32_t k = x / SEG, xe = k * SEG + SEG - 1;
        xe = xe < x1 ? xe : x1;
        double pa = zr + gx * (double)x, pb = zr + gx * (double)xe;
        double pmin = pa < pb ? pa : pb, pmax = pa < pb ? pb : pa;
        double u = (double)mm[2 * SEGROWS * k + 1] - pmin;
        double d = pmax - (double)mm[2 * SEGROWS * k];
        if ((u > d ? u : d) + slack >= *be)
            scan_run(row, zr, gx, x, xe, be, bx);
        x = xe + 1;
    }
}

/* What scan_part needs of a triangle: its corners and plane, the box of
 * its candidates, and the slack of scan_part's bounds. */
struct scan {
    const struct tin *m;
    int32_t px[3], py[3];
    struct plane pl;
    int32_t minx, maxx;
    int all;
    double slack;
};

/*
 * Rows y0 .. y1 of a triangle, where edges ea and eb (edge k runs from
 * corner k to corner k + 1) both cross every row: one bounds x from below
 * and the other from above.  Edge k: orient(p_k, p_j, (x, y)) = A x + B(y)
 * >= 0, B(y) = (xj - xk) (y - yk) + (yj - yk) xk, stepped by xj - xk a
 * row; A > 0 bounds x from below (x >= -floor(B / A)), A < 0 from above
 * (x <= floor(B / -A)).  The third edge's half-plane holds the span these
 * two cut (its ends lie on the triangle), so the span is exact.  Updates
 * *be, *bi as scan_tri says.
 */
static void scan_part(const struct scan *sc, int ea, int eb, int32_t y0,
                      int32_t y1, double *be_io, uint32_t *bi_io)
{
    const struct tin *m = sc->m;
    const int32_t *px = sc->px, *py = sc->py;
    double b[2], dx[2], inv[2];
    int lower = 0;
    for (int n = 0; n < 2; n++) {
        int k = n ? eb : ea, j = k == 2 ? 0 : k + 1;
        int32_t A = py[k] - py[j];
        dx[n] = (double)(px[j] - px[k]);
        b[n] = dx[n] * (double)(y0 - py[k]) +
               (double)(py[j] - py[k]) * (double)px[k];
        inv[n] = 1.0 / (double)(A > 0 ? A : -A);
        if (A > 0)
            lower = n;
    }
    int upper = !lower;
    double bl = b[lower], dl = dx[lower], il = inv[lower];
    double bu = b[upper], du = dx[upper], iu = inv[upper];
    double be = *be_io;
    uint32_t bi = *bi_io;
    const double gx = sc->pl.gx, slack = sc->slack;
    for (int32_t y = y0; y <= y1; y++) {
        int32_t lo = -floor_q(bl, il), hi = floor_q(bu, iu);
        bl += dl;
        bu += du;
        lo = lo > sc->minx ? lo : sc->minx;
        hi = hi < sc->maxx ? hi : sc->maxx;
        /* the used samples inside a triangle are its corners (and the
         * border, out of the box in border-first mode): corners lie on
         * the first or last row of a part, and a corner, an extreme
         * point, ends the exact span of its row */
        if (!sc->all && (y == y0 || y == y1))
            for (int k = 0; k < 3; k++)
                if (py[k] == y) {
                    if (px[k] == lo)
                        lo++;
                    else if (px[k] == hi)
                        hi--;
                }
        const float *row = m->h + (size_t)y * m->stride;
        double zr = row_at(&sc->pl, y);
        int32_t bx = -1;
        if (m->segmm)
            scan_segs(seg_row(m, y), row, zr, gx, slack, lo, hi, &be, &bx);
        else
            scan_run(row, zr, gx, lo, hi, &be, &bx);
        if (bx >= 0)
            bi = (uint32_t)y * m->w + (uint32_t)bx;
    }
    *be_io = be;
    *bi_io = bi;
}

/* Sample (x, y) against the plane, for small_tri: the error as scan_part
 * computes it, the larger error or on a tie the smaller index wins (the
 * first in raster order, as in a scan). */
static inline void offer(const struct scan *sc, int32_t x, int32_t y,
                         double *be, uint32_t *bi)
{
    const struct tin *m = sc->m;
    if (m->inner && (x < 1 || y < 1 || x > (int32_t)m->w - 2 ||
                     y > (int32_t)m->hgt - 2))
        return; /* the border: used */
    double e = fabs((double)hat(m, x, y) -
                    (row_at(&sc->pl, y) + sc->pl.gx * (double)x));
    uint32_t i = (uint32_t)y * m->w + (uint32_t)x;
    if (e > *be || (e == *be && e > 0 && i < *bi)) {
        *be = e;
        *bi = i;
    }
}

/*
 * The samples of a triangle of twice area a2 = 2 or 3 other than its
 * corners, without a scan (Pick: a2 = 2 I + B - 2, I samples inside and B
 * on the edges, the corners among them; an edge of vector (dx, dy) holds
 * gcd(dx, dy) - 1 samples between its ends).  a2 = 2: I = 0, B = 4, the
 * midpoint of the one edge of even components.  a2 = 3: I = 0, B = 5,
 * the samples of edges of gcd 2 or 3; or I = 1, B = 3, the centroid (all
 * such triangles are unimodular images of (-1, -1), (1, 0), (0, 1)).
 * Updates *be, *bi as scan_tri says.
 */
static void small_tri(const struct scan *sc, int64_t a2, double *be,
                      uint32_t *bi)
{
    const int32_t *px = sc->px, *py = sc->py;
    int found = 0;
    for (int k = 0; k < 3; k++) {
        int j = k == 2 ? 0 : k + 1;
        int32_t dx = px[j] - px[k], dy = py[j] - py[k];
        if (((dx | dy) & 1) == 0) {
            offer(sc, px[k] + dx / 2, py[k] + dy / 2, be, bi);
            found = 1;
        } else if (a2 == 3 && dx % 3 == 0 && dy % 3 == 0) {
            offer(sc, px[k] + dx / 3, py[k] + dy / 3, be, bi);
            offer(sc, px[k] + 2 * dx / 3, py[k] + 2 * dy / 3, be, bi);
            found = 1;
        }
    }
    if (a2 == 3 && !found)
        offer(sc, (px[0] + px[1] + px[2]) / 3, (py[0] + py[1] + py[2]) / 3,
              be, bi);
}

/*
 * Scan convert triangle t (edges included) row by row: for each row the
 * span where all three edge functions are >= 0, exact (floor_q), in two
 * parts split at the middle corner's row.  With all = 0, used samples
 * are skipped.  The sample of largest error (the first in raster order
 * on ties) comes back in *best_err / *best_idx (index NONE and error 0
 * when there is none).
 */
static void scan_tri(const struct tin *m, int32_t t, int all,
                     double *best_err, uint32_t *best_idx)
{
    const uint32_t *tc = m->t[t].c;
    struct scan sc;
    for (int i = 0; i < 3; i++) {
        sc.px[i] = CX(tc[i]);
        sc.py[i] = CY(tc[i]);
    }
    const int32_t *px = sc.px, *py = sc.py;
    *best_err = 0;
    *best_idx = NONE;
    /* Pick: twice the area is 2 I + B - 2 (I samples inside, B on the
     * edges, the corners among them), so a triangle of twice area 1 holds
     * its corners alone: nothing to offer (half the scans of a mesh) */
    int64_t a2 = orient(px[0], py[0], px[1], py[1], px[2], py[2]);
    if (!all && a2 == 1)
        return;
    sc.m = m;
    sc.all = all;
    plane_from(m, tc, &sc.pl);
    if (!all && a2 <= 3) {
        small_tri(&sc, a2, best_err, best_idx);
        return;
    }
    /* far over the rounding of an error and of a bound: both are within
     * a few ulps of |zr| + |gx x| + |height| < slack * 2^40 */
    sc.slack = (fabs(sc.pl.z0) + m->habs +
                (fabs(sc.pl.gy) + 2 * fabs(sc.pl.gx)) * 65536.0) * 0x1p-40;
    /* corners by row: top a, middle b, bottom c */
    int a = 0, b = 1, c = 2, s;
    if (py[b] < py[a]) { s = a; a = b; b = s; }
    if (py[c] < py[b]) { s = b; b = c; c = s; }
    if (py[b] < py[a]) { s = a; a = b; b = s; }
    int32_t minx = px[0], maxx = px[0], ytop = py[a], ybot = py[c];
    for (int i = 1; i < 3; i++) {
        minx = px[i] < minx ? px[i] : minx;
        maxx = px[i] > maxx ? px[i] : maxx;
    }
    /* the candidates' box: the border rows and columns go in border-first
     * mode (they are all used) */
    if (!all && m->inner) {
        ytop = ytop < 1 ? 1 : ytop;
        ybot = ybot > (int32_t)m->hgt - 2 ? (int32_t)m->hgt - 2 : ybot;
        minx = minx < 1 ? 1 : minx;
        maxx = maxx > (int32_t)m->w - 2 ? (int32_t)m->w - 2 : maxx;
    }
    sc.minx = minx;
    sc.maxx = maxx;
    /* edge k runs from corner k to k + 1: the edge of corners u, v */
#define EDGE(u, v) ((v) == ((u) + 1) % 3 ? (u) : (v))
    /* rows to the middle corner's (edges a-b and a-c), then the rest
     * (b-c and a-c); one call site, so that scan_part is inlined */
    int32_t ymid = py[b];
    for (int part = ymid > py[a] ? 0 : 1; part < 2; part++) {
        int32_t y0 = ytop, y1 = ybot;
        if (part == 0)
            y1 = ymid < ybot ? ymid : ybot;
        else if (py[c] == ymid)
            break;
        else
            y0 = py[a] < ymid && ymid + 1 > ytop ? ymid + 1 : ytop;
        scan_part(&sc, part ? EDGE(b, c) : EDGE(a, b), EDGE(a, c), y0, y1,
                  best_err, best_idx);
    }
#undef EDGE
}

/* Queue triangle t for a scan.  It may stay in the heap with a stale key
 * until flush() updates it: nothing is selected in between. */
static void mark(struct tin *m, int32_t t)
{
    if (m->t[t].cerr >= 0) {
        m->t[t].cerr = -1;
        m->pend[m->npend++] = t;
    }
}

/* Scan the queued triangles; those with a candidate over the goal go in
 * the heap (or move in it), the others leave it. */
static void flush(struct tin *m, int use_heap)
{
    for (uint32_t i = 0; i < m->npend; i++) {
        int32_t t = m->pend[i];
        double e = 0;
        uint32_t idx = NONE;
        if (use_heap)
            scan_tri(m, t, 0, &e, &idx);
        m->t[t].cerr = e;
        if (!use_heap)
            continue;
        if (idx != NONE && e > 0 && e > m->goal)
            heap_set(m, t, e, idx);
        else
            heap_remove(m, t);
    }
    m->npend = 0;
}

/* ------------------------------------------------------------ the mesh */

/* Write triangle (a, b, c) (corners) with opposite half-edges (ab, bc,
 * ca) into slot e/3 (e < 0: a new slot).  Returns its first half-edge. */
static int add_tri(struct tin *m, uint32_t a, uint32_t b, uint32_t c, int ab,
                   int bc, int ca, int e)
{
    if (e < 0) {
        e = (int)(3 * m->nt++);
        m->hpos[e / 3] = -1;
        m->t[e / 3].cerr = 0;
    }
    struct tri *T = &m->t[e / 3]; /* e is 3 t: no remainder below */
    T->c[0] = a;
    T->c[1] = b;
    T->c[2] = c;
    T->he[0] = ab;
    T->he[1] = bc;
    T->he[2] = ca;
    if (ab >= 0) HE(m, ab) = e;
    if (bc >= 0) HE(m, bc) = e + 1;
    if (ca >= 0) HE(m, ca) = e + 2;
    /* every split and flip rewrites each vertex it touches, so these stay
     * valid */
    if (m->track) {
        m->vhe[border_at(m, a)] = e;
        m->vhe[border_at(m, b)] = e + 1;
        m->vhe[border_at(m, c)] = e + 2;
    }
    mark(m, e / 3);
    return e;
}

/* d strictly inside the circle of counter-clockwise a, b, c (exact).
 * With sides <= 16384 every term fits 64 bits (|d| < 2^14: lifts and
 * cross products < 2^29, the determinant < 2^61). */
static int incircle(const struct tin *m, uint32_t a, uint32_t b, uint32_t c,
                    uint32_t d)
{
    int64_t adx = CX(a) - CX(d), ady = CY(a) - CY(d);
    int64_t bdx = CX(b) - CX(d), bdy = CY(b) - CY(d);
    int64_t cdx = CX(c) - CX(d), cdy = CY(c) - CY(d);
    int64_t al = adx * adx + ady * ady;
    int64_t bl = bdx * bdx + bdy * bdy;
    int64_t cl = cdx * cdx + cdy * cdy;
    int64_t bc = bdx * cdy - cdx * bdy;
    int64_t ac = adx * cdy - cdx * ady;
    int64_t ab = adx * bdy - bdx * ady;
    if (m->small)
        return al * bc - bl * ac + cl * ab > 0;
    gv_i128 det = (gv_i128)al * bc - (gv_i128)bl * ac + (gv_i128)cl * ab;
    return det > 0;
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
    static const uint8_t nx[3] = {1, 2, 0}, pv[3] = {2, 0, 1};
    while (m->nstack) {
        int a = m->stack[--m->nstack];
        uint32_t ia = (uint32_t)a / 3, ka = (uint32_t)a - 3 * ia;
        struct tri *A = &m->t[ia];
        int b = A->he[ka];
        if (b < 0)
            continue;
        uint32_t ib = (uint32_t)b / 3, kb = (uint32_t)b - 3 * ib;
        struct tri *B = &m->t[ib];
        int ta = (int)(3 * ia), tb = (int)(3 * ib);
        /* al, ar: a's next and previous; bl, br: b's previous and next */
        uint32_t kal = nx[ka], kar = pv[ka], kbl = pv[kb], kbr = nx[kb];
        uint32_t p0 = A->c[kar], pr = A->c[ka], pl = A->c[kal];
        uint32_t p1 = B->c[kbl];
        if (!incircle(m, pr, pl, p0, p1))
            continue;
        int hal = A->he[kal], har = A->he[kar];
        int hbl = B->he[kbl], hbr = B->he[kbr];
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
        uint32_t a = TC(m, 3 * t + k), b = TC(m, 3 * t + (k + 1) % 3);
        if (orient(CX(a), CY(a), CX(b), CY(b), x, y) == 0)
            on = 3 * t + k;
    }
    if (on >= 0 && HE(m, on) >= 0 && HE(m, on) / 3 < t) {
        on = HE(m, on);
        t = on / 3;
    }
    if (add_vertex(m, x, y) < 0)
        return -1;
    uint32_t p = CORNER(x, y);
    if (on < 0) {
        int e0 = 3 * t;
        uint32_t a = TC(m, e0), b = TC(m, e0 + 1), c = TC(m, e0 + 2);
        int hab = HE(m, e0), hbc = HE(m, e0 + 1), hca = HE(m, e0 + 2);
        int t0 = add_tri(m, a, b, p, hab, -1, -1, e0);
        int t1 = add_tri(m, b, c, p, hbc, -1, t0 + 1, -1);
        int t2 = add_tri(m, c, a, p, hca, t0 + 2, t1 + 1, -1);
        if (legalize(m, t0) < 0 || legalize(m, t1) < 0 ||
            legalize(m, t2) < 0)
            return -1;
        return 0;
    }
    int e = on, h = HE(m, on);
    uint32_t a = TC(m, e), b = TC(m, next_he(e)), c = TC(m, prev_he(e));
    int hbc = HE(m, next_he(e)), hca = HE(m, prev_he(e));
    if (h < 0) {
        int t0 = add_tri(m, c, a, p, hca, -1, -1, e - e % 3);
        int t1 = add_tri(m, b, c, p, hbc, t0 + 2, -1, -1);
        if (legalize(m, t0) < 0 || legalize(m, t1) < 0)
            return -1;
        return 0;
    }
    uint32_t d = TC(m, prev_he(h));
    int had = HE(m, next_he(h)), hdb = HE(m, prev_he(h));
    int t0 = add_tri(m, c, a, p, hca, -1, -1, e - e % 3);
    int t1 = add_tri(m, b, c, p, hbc, t0 + 2, -1, -1);
    int t2 = add_tri(m, a, d, p, had, -1, t0 + 1, h - h % 3);
    int t3 = add_tri(m, d, b, p, hdb, t1 + 2, t2 + 1, -1);
    if (legalize(m, t0) < 0 || legalize(m, t1) < 0 || legalize(m, t2) < 0 ||
        legalize(m, t3) < 0)
        return -1;
    return 0;
}

/* The hull half-edge leaving hull vertex c (a corner): turn around c
 * across the half-edges that leave it until one has no twin. */
static int hull_out(const struct tin *m, uint32_t c)
{
    int e = m->vhe[border_at(m, c)];
    while (HE(m, e) >= 0)
        e = next_he(HE(m, e));
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

/* The heights' bounds per row segment for scan_tri (after the check that
 * they are finite).  Returns 0, or -1 out of memory. */
static int seg_bounds(struct tin *m)
{
    m->nseg = (m->w + SEG - 1) / SEG;
    size_t rows = ((size_t)m->hgt + SEGROWS - 1) / SEGROWS * SEGROWS;
    m->segmm = aligned_alloc(64, 2 * (size_t)m->nseg * rows *
                                     sizeof *m->segmm);
    if (!m->segmm)
        return -1;
    float habs = 0;
    for (uint32_t y = 0; y < m->hgt; y++) {
        const float *row = m->h + (size_t)y * m->stride;
        float *mm = (float *)seg_row(m, (int32_t)y);
        for (uint32_t k = 0; k < m->nseg; k++) {
            uint32_t x0 = k * SEG, x1 = x0 + SEG < m->w ? x0 + SEG : m->w;
            float lo = row[x0], hi = row[x0];
            for (uint32_t x = x0 + 1; x < x1; x++) {
                lo = row[x] < lo ? row[x] : lo;
                hi = row[x] > hi ? row[x] : hi;
            }
            mm[2 * SEGROWS * k] = lo;
            mm[2 * SEGROWS * k + 1] = hi;
            float a = fabsf(lo) > fabsf(hi) ? fabsf(lo) : fabsf(hi);
            habs = a > habs ? a : habs;
        }
    }
    m->habs = habs;
    return 0;
}

static void tin_release(struct tin *m)
{
    free(m->used);
    free(m->v);
    free(m->vhe);
    free(m->segmm);
    free(m->t);
    free(m->heapmem);
    free(m->pend);
    free(m->hpos);
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
                const uint32_t *c = m->t[t].c;
                int in = 1;
                for (int k = 0; k < 3 && in; k++) {
                    uint32_t a = c[k], b = c[(k + 1) % 3];
                    in = orient(CX(a), CY(a), CX(b), CY(b), x, y) >= 0;
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
        uint32_t corner;
    } edge[4] = {
        {h, 1, w, 0, 0, 1, 0, 0, CORNER(0, 0)},
        {h + W, stride, hgt, W, 0, 0, 1, 0, CORNER(W, 0)},
        {h + (size_t)H * stride, 1, w, 0, H, 1, 0, 1, CORNER(W, H)},
        {h, stride, hgt, 0, 0, 0, 1, 1, CORNER(0, H)},
    };
    for (int k = 0; k < 4; k++) {
        uint32_t n;
        if (gv_tin_edge_greedy(edge[k].s, edge[k].step, edge[k].n, goal,
                               bpos, &n) < 0)
            return -1;
        uint32_t prev = edge[k].corner;
        for (uint32_t i = 0; i < n; i++) {
            uint32_t q = bpos[edge[k].reverse ? n - 1 - i : i];
            int32_t x = edge[k].x0 + edge[k].dx * (int32_t)q;
            int32_t y = edge[k].y0 + edge[k].dy * (int32_t)q;
            if (insert_point(m, hull_out(m, prev) / 3, x, y) < 0)
                return -1;
            prev = CORNER(x, y);
        }
    }
    return 0;
}

/*
 * The measured error of the mesh, over every sample: each triangle scanned
 * in full.  After the heap's scans (scanned != 0) most of that is known:
 * cerr is a triangle's largest error over its unused samples, and the used
 * samples in it are its corners and, on a hull edge, border samples; so
 * only the hull triangles are scanned again, and the others add their
 * corners' errors on their plane.  The same values either way, and so the
 * same maximum.
 */
static double measured_error(const struct tin *m, int scanned)
{
    double me = 0;
    for (uint32_t t = 0; t < m->nt; t++) {
        const int32_t *he = m->t[t].he;
        double e;
        if (!scanned || he[0] < 0 || he[1] < 0 || he[2] < 0) {
            uint32_t i;
            scan_tri(m, (int32_t)t, 1, &e, &i);
        } else {
            struct plane pl;
            plane_of(m, (int32_t)t, &pl);
            e = m->t[t].cerr;
            for (int k = 0; k < 3; k++) {
                uint32_t c = TC(m, 3 * (size_t)t + k);
                double d = fabs((double)hat(m, CX(c), CY(c)) -
                                plane_at(&pl, CX(c), CY(c)));
                if (d > e)
                    e = d;
            }
        }
        if (e > me)
            me = e;
    }
    return me;
}

/* The result of the private state: the one mesh type (mesh/mesh.h), the
 * vertices as grid coordinates in floats, each triangle's corners mapped
 * to their vertex ids through a map of the grid.  Returns 0, or -1 out of
 * memory (*out then empty). */
static int hand_out(const struct tin *m, uint32_t w, uint32_t hgt, double me,
                    struct gv_mesh *out)
{
    uint32_t *id = big_alloc((size_t)w * hgt * sizeof *id);
    if (!id)
        return -1;
    out->width = w;
    out->height = hgt;
    out->nverts = m->nv;
    out->ntris = m->nt;
    out->max_error = me;
    out->pos = malloc((size_t)m->nv * 3 * sizeof *out->pos);
    out->tris = malloc((size_t)m->nt * 3 * sizeof *out->tris);
    if (!out->pos || !out->tris) {
        free(id);
        gv_mesh_free(out);
        return -1;
    }
    out->zmin = out->zmax = m->v[0].z;
    for (uint32_t i = 0; i < m->nv; i++) {
        out->pos[3 * (size_t)i] = (float)m->v[i].x;
        out->pos[3 * (size_t)i + 1] = (float)m->v[i].y;
        out->pos[3 * (size_t)i + 2] = m->v[i].z;
        if (m->v[i].z < out->zmin) out->zmin = m->v[i].z;
        if (m->v[i].z > out->zmax) out->zmax = m->v[i].z;
        id[(size_t)m->v[i].y * w + m->v[i].x] = i;
    }
    for (uint32_t i = 0; i < 3 * m->nt; i++) {
        uint32_t c = TC(m, i);
        out->tris[i] = id[(size_t)CY(c) * w + (size_t)CX(c)];
    }
    free(id);
    return 0;
}

static int build(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                 const struct gv_tin_params *p, int brute, int segs,
                 struct gv_mesh *out, struct gv_error *err)
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
    m.goal = goal;
    m.small = w <= 16384 && hgt <= 16384;
    if (brute && !(m.used = calloc((size_t)w * hgt, 1)))
        goto nomem;
    /* a half-edge for each border sample, 2 (w + hgt) */
    m.vhe = malloc(2 * ((size_t)w + hgt) * sizeof *m.vhe);
    bpos = malloc((size_t)(w > hgt ? w : hgt) * sizeof *bpos);
    /* Room for every triangle the grid can have (2 per sample, up to
     * 2^22: the pages untouched stay unmapped), so that the arrays are
     * not copied as they grow; the doubling from 64 if that fails. */
    uint64_t guess = 2 * (uint64_t)w * hgt;
    if (p->max_triangles && guess > (uint64_t)p->max_triangles + 4)
        guess = (uint64_t)p->max_triangles + 4;
    if (guess > (1u << 22))
        guess = 1u << 22;
    if (m.vhe && bpos && reserve_tris(&m, (uint32_t)guess) < 0)
        release_tris(&m);
    if (!m.vhe || !bpos || reserve_tris(&m, 64) < 0)
        goto nomem;
    for (uint32_t y = 0; y < hgt; y++)
        for (uint32_t x = 0; x < w; x++)
            if (!isfinite(h[(size_t)y * stride + x])) {
                gv_fail(err, GV_EINVAL, "mesh: height at (%u,%u) is not finite",
                        x, y);
                goto out;
            }
    if (segs < 0)
        segs = (size_t)w * hgt > SEG_GRID;
    if (segs && seg_bounds(&m) < 0)
        goto nomem;
    int32_t W = (int32_t)w - 1, H = (int32_t)hgt - 1;
    m.track = 1;
    if (add_vertex(&m, 0, 0) < 0 || add_vertex(&m, W, 0) < 0 ||
        add_vertex(&m, W, H) < 0 || add_vertex(&m, 0, H) < 0)
        goto nomem;
    uint32_t c0 = CORNER(0, 0), c1 = CORNER(W, 0), c2 = CORNER(W, H);
    uint32_t c3 = CORNER(0, H);
    int t0 = add_tri(&m, c0, c1, c2, -1, -1, -1, -1);
    add_tri(&m, c0, c2, c3, t0 + 2, -1, -1, -1);

    if (p->border_first) {
        if (insert_border(&m, goal, bpos) < 0)
            goto nomem;
        if (p->max_triangles && m.nt > p->max_triangles) {
            gv_fail(err, GV_ELIMIT, "mesh: the border alone needs %u "
                    "triangles at error %g, over the limit of %u", m.nt,
                    goal, p->max_triangles);
            goto out;
        }
        if (m.used) {
            for (uint32_t x = 0; x < w; x++)
                m.used[x] = m.used[(size_t)H * w + x] = 1;
            for (uint32_t y = 0; y < hgt; y++)
                m.used[(size_t)y * w] = m.used[(size_t)y * w + (size_t)W] = 1;
        }
        m.inner = 1;
    }
    m.track = 0;
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
            bt = m.heap[0].t;
            be = m.heap[0].err;
            bi = (int64_t)m.heap[0].idx;
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
    if (hand_out(&m, w, hgt, measured_error(&m, !brute), out) < 0)
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
    return build(h, w, hgt, stride, p, 0, -1, out, err);
}

int gv_tin_build_brute(const float *h, uint32_t w, uint32_t hgt,
                       size_t stride, const struct gv_tin_params *p,
                       struct gv_mesh *out, struct gv_error *err)
{
    return build(h, w, hgt, stride, p, 1, 0, out, err);
}

int gv_tin_build_segs(const float *h, uint32_t w, uint32_t hgt,
                      size_t stride, const struct gv_tin_params *p, int segs,
                      struct gv_mesh *out, struct gv_error *err)
{
    return build(h, w, hgt, stride, p, 0, segs, out, err);
}
