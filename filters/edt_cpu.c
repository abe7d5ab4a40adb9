/*
 * edt_cpu.c - the CPU distance transform by 2D vector propagation with
 * the four-sweep Moore-neighbourhood templates (edt_cpu.h has the exact
 * rules; thesis section 7.8).
 *
 * Design.
 *
 *  - State: the nearest site so far of every pixel, rows packed.  Up to
 *    65535 x 65535 it is one plane of packed sites, x | y << 16 (4 bytes
 *    per pixel, like the thesis's 2 x 16-bit textures: half the memory
 *    traffic); wider images use two uint32 planes, x and y.
 *  - Every sweep is a sequence of "line" updates and one kernel
 *    (edt_kernel.h) serves all four: a line is a row (y-sweeps) or a
 *    column (x-sweeps), and each of its positions takes the best of own,
 *    prev[i], prev[i-1], prev[i+1].  The kernel runs 16 lanes along the
 *    line (AVX-512, AVX2 or SSE2 picked by gv_cpu_flags(), base/cpu.h).
 *  - y-sweeps run in place on the rows.  x-sweeps need columns as
 *    contiguous lines: a strip of K = 64 columns is transposed (16 x 16
 *    blocks in registers) into K + 1 column lines ("slots"; slot 0 is the
 *    column before the strip), swept there while it stays in L2, and
 *    transposed back.  The first x-sweep builds the state from the ids as
 *    it loads its strips, and the -y sweep writes the outputs of each
 *    block of rows as soon as they are final: no pass of their own.
 *  - Threads split every line into contiguous shares.  A sweep runs in
 *    blocks of lines (a few strips of columns, or up to 256 rows); in a
 *    block each thread first sweeps its share as a trapezoid that shrinks
 *    by one position per line at each boundary with a neighbour (it needs
 *    nothing from the neighbours), then, after a barrier, fills the small
 *    triangle left at its lower or right boundary, and a second barrier
 *    ends the block.  Every position is computed from exactly the values
 *    the sequential order gives it, so the result does not depend on the
 *    thread count.
 */
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "base/cpu.h"
#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#endif

#include "edt_cpu.h"
#include "edt_int.h"

#define EDT_PACK_MAX 65535u      /* packed layout: w, h at most this, so
                                    0xffff is never a coordinate */
#define EDT_STRIP 64             /* K: columns per x-sweep strip: 65
                                    packed column lines of 4 bytes per
                                    row stay in L2 (2 MB) up to ~7000 rows
                                    per thread; 64 beat 32 by ~10% here */
#define EDT_XSTRIPS 2            /* strips per x-sweep block (one pair of
                                    barriers each) */
#define EDT_YBLOCK_MIN 64        /* rows per y-sweep block: at least ... */
#define EDT_YBLOCK 256           /* ... and at most */
#define EDT_MIN_PIXELS_PER_THREAD (1u << 19)  /* below, threads cost more
                                                 than they bring: at 512^2
                                                 2 threads took 2x the CPU
                                                 time of 1 and no less
                                                 wall time */
#define EDT_SPINS 500            /* barrier: ~25 us of pauses, then sleep */

/* ---------------------------------------------------------------- kernels */

/* The portable C instantiation of edt_kernel.h (the SIMD ones are in
 * x86/edt_sse2.c, edt_avx2.c and edt_avx512.c, each compiled with its
 * own flags). */
#define EDT_ISA 0
#define EDT_PACKED 0
#define EDT_SUFFIX c_w
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#define EDT_PACKED 1
#define EDT_SUFFIX c_p
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#undef EDT_ISA

static const struct edt_kernels edt_c_wide = {edt_line_c_w, edt_dist_c_w,
                                              edt_load_c_w, edt_store_c_w};
static const struct edt_kernels edt_c_packed = {edt_line_c_p, edt_dist_c_p,
                                                edt_load_c_p, edt_store_c_p};

/* One instruction set's kernels, and the flags of gv_cpu_flags() (base/cpu.h)
 * they need. */
struct edt_isa {
    const char *name;
    const struct edt_kernels *wide, *packed;
    unsigned needs;
};

/* Best first. */
static const struct edt_isa edt_isas[] = {
#if GV_HAVE_X86_SIMD
    {"avx512", &gv_edt_avx512_wide, &gv_edt_avx512_packed, GV_CPU_AVX512},
    {"avx2", &gv_edt_avx2_wide, &gv_edt_avx2_packed, GV_CPU_AVX2},
    {"sse2", &gv_edt_sse2_wide, &gv_edt_sse2_packed, GV_CPU_SSE2},
#endif
    {"c", &edt_c_wide, &edt_c_packed, 0},
};
#define EDT_NISA (sizeof edt_isas / sizeof edt_isas[0])

static const struct edt_isa *edt_forced;
static uint32_t edt_min_pixels = EDT_MIN_PIXELS_PER_THREAD;
static int edt_force_wide;

/* The table: the best instruction set of the flags, filled once per mask
 * (gv_cpu_once). */
static const struct edt_isa *edt_best;
static struct gv_cpu_once edt_once = GV_CPU_ONCE_INIT;

static void edt_dsp_init(unsigned flags)
{
    edt_best = &edt_isas[EDT_NISA - 1];
    for (size_t i = 0; i < EDT_NISA; i++)
        if ((flags & edt_isas[i].needs) == edt_isas[i].needs) {
            edt_best = &edt_isas[i];
            return;
        }
}

static const struct edt_isa *edt_pick(void)
{
    if (edt_forced)
        return edt_forced;
    gv_cpu_once(&edt_once, edt_dsp_init);
    return edt_best;
}

const char *gv_edt_cpu_isa(void)
{
    return edt_pick()->name;
}

const char *gv_edt_cpu_configure(const char *name, uint32_t min_pixels,
                                 int wide)
{
    edt_min_pixels = min_pixels ? min_pixels : EDT_MIN_PIXELS_PER_THREAD;
    edt_force_wide = wide;
    edt_forced = NULL;
    for (size_t i = 0; name && i < EDT_NISA; i++)
        if (strcmp(edt_isas[i].name, name) == 0 &&
            (gv_cpu_flags() & edt_isas[i].needs) == edt_isas[i].needs)
            edt_forced = &edt_isas[i];
    return gv_edt_cpu_isa();
}

/* ---------------------------------------------------------------- barrier */

/* A barrier that spins first (a block takes tens of microseconds, a
 * futex wake-up about as long) and then sleeps, so that more threads than
 * cores still make progress.  The last thread to arrive takes the mutex
 * only when someone sleeps: it publishes the new generation before it
 * reads `sleepers`, and a sleeper counts itself before it reads the
 * generation, so one of the two always sees the other (sequentially
 * consistent atomics). */
struct edt_barrier {
    atomic_uint count;
    atomic_uint gen;
    atomic_uint sleepers;
    unsigned n;
    unsigned spins;          /* EDT_SPINS, or 0 with more threads than CPUs */
    pthread_mutex_t lock;
    pthread_cond_t wake;
};

static void edt_barrier_wait(struct edt_barrier *b)
{
    if (b->n <= 1)
        return;
    unsigned gen = atomic_load(&b->gen);
    if (atomic_fetch_add(&b->count, 1) == b->n - 1) {
        atomic_store(&b->count, 0);
        atomic_fetch_add(&b->gen, 1);
        if (atomic_load(&b->sleepers) > 0) {
            pthread_mutex_lock(&b->lock);
            pthread_cond_broadcast(&b->wake);
            pthread_mutex_unlock(&b->lock);
        }
        return;
    }
    for (unsigned spins = 0; spins < b->spins; spins++) {
        if (atomic_load(&b->gen) != gen)
            return;
#if GV_HAVE_X86_SIMD
        _mm_pause();
#endif
    }
    pthread_mutex_lock(&b->lock);
    atomic_fetch_add(&b->sleepers, 1);
    while (atomic_load(&b->gen) == gen)
        pthread_cond_wait(&b->wake, &b->lock);
    atomic_fetch_sub(&b->sleepers, 1);
    pthread_mutex_unlock(&b->lock);
}

/* ---------------------------------------------------------------- run */

/* A thread's column lines for the x-sweeps: rows [base, base + rows). */
struct edt_slots {
    uint32_t *buf;            /* EDT_STRIP + 1 lines, twice if not packed */
    size_t stride;            /* elements from one line to the next */
    uint32_t base;
};

struct edt_run {
    const uint32_t *ids;
    uint32_t w, h;
    int packed;
    uint32_t *sx, *sy;        /* the state planes (packed: sx alone) */
    const struct gv_edt_out *out;
    int nthreads;             /* threads running (barrier count) */
    int ntx, nty;             /* of which working in x- and y-sweeps */
    uint32_t xblock, yblock;  /* lines per block of the x- and y-sweeps */
    struct edt_slots *slots;  /* one per thread working in x-sweeps */
    const struct edt_kernels *k;
    struct edt_barrier bar;
    atomic_int gate;          /* 0: wait, 1: work, 2: exit at once */
};

struct edt_worker {
    struct edt_run *run;
    int t;
    pthread_t thread;
};

/* Thread t's share [*lo, *hi) of n positions. */
static void edt_share(uint32_t n, int t, int nt, uint32_t *lo, uint32_t *hi)
{
    *lo = (uint32_t)((uint64_t)n * (uint64_t)t / (uint64_t)nt);
    *hi = (uint32_t)((uint64_t)n * (uint64_t)(t + 1) / (uint64_t)nt);
}

/* Row y of the state: the line pointers the kernels take. */
static uint32_t *edt_row_a(const struct edt_run *r, uint32_t y)
{
    return r->sx + (size_t)y * r->w;
}

static uint32_t *edt_row_b(const struct edt_run *r, uint32_t y)
{
    return r->packed ? NULL : r->sy + (size_t)y * r->w;
}

/* One pass of a thread over a block of x-sweep columns: load each strip
 * (rows ya .. yb-1), sweep its columns, store it.  q counts the block's
 * columns from 0.  Trapezoid: column q on rows [lo + q, hi - q), without
 * the shrink at the image's edges.  Gap: rows [m - q, m + q), q >= 1. */
struct edt_blockpass {
    int dir, init;
    uint32_t x_first;          /* first column of the block, sweep order */
    uint32_t ncols;            /* columns in the block */
    uint32_t ya, yb;           /* rows loaded and stored */
    int trap;                  /* 1: trapezoid, 0: gap around m */
    uint32_t lo, hi;           /* trapezoid: own rows */
    int shrink_lo, shrink_hi;  /* trapezoid: inner boundaries */
    uint32_t m;                /* gap: the boundary row */
};

static void edt_block(struct edt_run *r, const struct edt_slots *sl,
                      const struct edt_blockpass *bp)
{
    const uint32_t w = r->w, h = r->h, K = EDT_STRIP;
    const int dir = bp->dir;
    uint32_t *sa[EDT_STRIP + 1], *sb[EDT_STRIP + 1];
    for (uint32_t j = 0; j <= K; j++) {
        /* packed: one line per column (sb unused) */
        sa[j] = sl->buf + (size_t)(r->packed ? j : 2 * j) * sl->stride;
        sb[j] = r->packed ? sa[j] : sa[j] + sl->stride;
    }
    /* Slot 0: the column before the block, final on every row; only the
     * trapezoid's column q = 0 reads it. */
    if (bp->trap && bp->x_first != (dir > 0 ? 0 : w - 1)) {
        uint32_t xp = dir > 0 ? bp->x_first - 1 : bp->x_first + 1;
        uint32_t y0 = bp->lo > 0 ? bp->lo - 1 : 0;
        uint32_t y1 = bp->hi < h ? bp->hi + 1 : h;
        for (uint32_t y = y0; y < y1; y++) {
            size_t p = (size_t)y * w + xp;
            if (r->packed) {
                sa[0][y - sl->base] = edt_swap16(r->sx[p]);
            } else {
                sa[0][y - sl->base] = r->sy[p];
                sb[0][y - sl->base] = r->sx[p];
            }
        }
    }
    for (uint32_t s = 0; s < bp->ncols; s += K) {
        uint32_t nc = bp->ncols - s < K ? bp->ncols - s : K;
        uint32_t x0 = dir > 0 ? bp->x_first + s : bp->x_first - s - nc + 1;
        r->k->load(bp->init ? r->ids : NULL, r->sx, r->sy, w, x0, nc, dir,
                   bp->ya, bp->yb, sl->base, sa, sb);
        for (uint32_t j = 1; j <= nc; j++) {
            uint32_t q = s + j - 1;
            uint32_t c = dir > 0 ? x0 + j - 1 : x0 + nc - j;
            uint32_t lo, hi;
            if (dir > 0 ? c == 0 : c == w - 1)
                continue;   /* the sweep's first line is not written */
            if (bp->trap) {
                lo = bp->lo + (bp->shrink_lo ? q : 0);
                hi = bp->hi - (bp->shrink_hi ? q : 0);
            } else {
                if (q == 0)
                    continue;   /* both trapezoids did all of it */
                lo = bp->m - q;
                hi = bp->m + q;
            }
            r->k->line(sa[j], sb[j], sa[j - 1], sb[j - 1], sl->base, h, lo,
                       hi, c);
        }
        r->k->store(r->sx, r->sy, w, x0, nc, dir, bp->ya, bp->yb, sl->base,
                    sa, sb);
        /* The strip's last column is the next strip's slot 0. */
        uint32_t *ta = sa[0], *tb = sb[0];
        sa[0] = sa[nc];
        sb[0] = sb[nc];
        sa[nc] = ta;
        sb[nc] = tb;
    }
}

/* One x-sweep (dir +1 or -1) by thread t, in blocks of r->xblock
 * columns: its rows as a trapezoid, then the triangle at its lower
 * boundary m through the window of rows m - xblock .. m + xblock. */
static void edt_pass_x(struct edt_run *r, int t, int dir, int init)
{
    const uint32_t w = r->w, h = r->h, B = r->xblock;
    const int nt = r->ntx;
    uint32_t ya = 0, yb = 0, yn = 0, unused;
    if (t < nt)
        edt_share(h, t, nt, &ya, &yb);   /* else: only the barriers */
    if (t + 1 < nt)
        edt_share(h, t + 1, nt, &unused, &yn);
    for (uint32_t done = 0; done < w; done += B) {
        struct edt_blockpass bp;
        memset(&bp, 0, sizeof bp);
        bp.dir = dir;
        bp.init = init;
        bp.x_first = dir > 0 ? done : w - 1 - done;
        bp.ncols = w - done < B ? w - done : B;
        if (t < nt) {
            bp.ya = bp.lo = ya;
            bp.yb = bp.hi = yb;
            bp.trap = 1;
            bp.shrink_lo = t > 0;
            bp.shrink_hi = t < nt - 1;
            edt_block(r, &r->slots[t], &bp);
        }
        edt_barrier_wait(&r->bar);
        if (t < nt - 1) {
            bp.trap = 0;
            bp.init = 0;
            bp.m = yb;
            bp.ya = yb - B;   /* every share has at least 2 * B + 2 rows */
            bp.yb = yb + B < yn ? yb + B : yn;
            edt_block(r, &r->slots[t], &bp);
        }
        edt_barrier_wait(&r->bar);
    }
}

/* Outputs of row y, columns [x0, x1). */
static void edt_emit(const struct edt_run *r, uint32_t y, uint32_t x0,
                     uint32_t x1)
{
    const struct gv_edt_out *o = r->out;
    size_t row = (size_t)y * r->w;
    const uint32_t *sa = edt_row_a(r, y), *sb = edt_row_b(r, y);
    if (o->dist)
        r->k->dist(sa, sb, x0, x1, y, o->dist + row);
    if (r->packed) {
        /* One loop per output, so that each vectorizes. */
        if (o->site_x)
            for (uint32_t x = x0; x < x1; x++)
                o->site_x[row + x] =
                    sa[x] == EDT_NONE_U ? GV_EDT_NONE
                                        : (int32_t)(sa[x] & 0xffffu);
        if (o->site_y)
            for (uint32_t x = x0; x < x1; x++)
                o->site_y[row + x] = sa[x] == EDT_NONE_U
                                         ? GV_EDT_NONE
                                         : (int32_t)(sa[x] >> 16);
        if (o->site_id)
            for (uint32_t x = x0; x < x1; x++)
                o->site_id[row + x] =
                    sa[x] == EDT_NONE_U
                        ? 0
                        : r->ids[(size_t)(sa[x] >> 16) * r->w +
                                 (sa[x] & 0xffffu)];
        return;
    }
    if (o->site_id)
        for (uint32_t x = x0; x < x1; x++)
            o->site_id[row + x] = sa[x] == EDT_NONE_U
                                      ? 0
                                      : r->ids[(size_t)sb[x] * r->w + sa[x]];
    if (o->site_x && (uint32_t *)o->site_x != r->sx)
        memcpy(o->site_x + row + x0, sa + x0, (x1 - x0) * sizeof *sa);
    if (o->site_y && (uint32_t *)o->site_y != r->sy)
        memcpy(o->site_y + row + x0, sb + x0, (x1 - x0) * sizeof *sb);
}

/* One y-sweep by thread t over its columns, in blocks of r->yblock rows;
 * emit: write the outputs of each block once it is final (-y). */
static void edt_pass_y(struct edt_run *r, int t, int dir, int emit)
{
    const uint32_t w = r->w, h = r->h, R = r->yblock;
    const int nt = r->nty;
    const int first = t == 0, last = t == nt - 1;
    uint32_t xa = 0, xb = 0;
    if (t < nt)
        edt_share(w, t, nt, &xa, &xb);   /* else: only the barriers */
    if (emit)
        edt_emit(r, dir > 0 ? 0 : h - 1, xa, xb);
    /* Lines 1 .. h-1 of the sweep: row = line (+y) or h-1-line (-y). */
    for (uint32_t l0 = 1; l0 < h; l0 += R) {
        uint32_t nl = h - l0 < R ? h - l0 : R;
        for (uint32_t q = 0; t < nt && q < nl; q++) {
            uint32_t y = dir > 0 ? l0 + q : h - 1 - (l0 + q);
            uint32_t py = dir > 0 ? y - 1 : y + 1;
            uint32_t lo = xa + (first ? 0 : q), hi = xb - (last ? 0 : q);
            r->k->line(edt_row_a(r, y), edt_row_b(r, y), edt_row_a(r, py),
                       edt_row_b(r, py), 0, w, lo, hi, y);
        }
        edt_barrier_wait(&r->bar);
        if (t < nt - 1) {
            for (uint32_t q = 1; q < nl; q++) {
                uint32_t y = dir > 0 ? l0 + q : h - 1 - (l0 + q);
                uint32_t py = dir > 0 ? y - 1 : y + 1;
                r->k->line(edt_row_a(r, y), edt_row_b(r, y),
                           edt_row_a(r, py), edt_row_b(r, py), 0, w, xb - q,
                           xb + q, y);
            }
        }
        edt_barrier_wait(&r->bar);
        if (emit && t < nt)
            for (uint32_t q = 0; q < nl; q++)
                edt_emit(r, dir > 0 ? l0 + q : h - 1 - (l0 + q), xa, xb);
    }
}

static void edt_work(struct edt_run *r, int t)
{
    edt_pass_x(r, t, +1, 1);
    edt_barrier_wait(&r->bar);
    edt_pass_x(r, t, -1, 0);
    edt_barrier_wait(&r->bar);
    edt_pass_y(r, t, +1, 0);
    edt_barrier_wait(&r->bar);
    edt_pass_y(r, t, -1, 1);
}

static void *edt_thread(void *arg)
{
    struct edt_worker *wk = arg;
    int g;
    while ((g = atomic_load(&wk->run->gate)) == 0)
        sched_yield();
    if (g == 1)
        edt_work(wk->run, wk->t);
    return NULL;
}

/* Large buffers: ask for transparent huge pages (fewer page faults, and
 * the x-sweeps touch every row of a strip: with 4 KB pages that is a TLB
 * miss per row). */
static void *edt_alloc(size_t bytes)
{
    const size_t huge = (size_t)2 << 20;
    void *p;
    if (bytes >= huge) {
        size_t rounded = (bytes + huge - 1) / huge * huge;
        p = aligned_alloc(huge, rounded);
#ifdef MADV_HUGEPAGE
        if (p)
            madvise(p, rounded, MADV_HUGEPAGE);
#endif
    } else {
        p = aligned_alloc(64, (bytes + 63) / 64 * 64);
    }
    return p;
}

/* Threads worth using: each thread gets enough pixels, and each share of
 * a line holds two blocks' worth of lines (a trapezoid and the gap
 * windows) in the sweeps where the thread works.  Sets the block sizes. */
static void edt_threads(struct edt_run *r, int threads)
{
    const uint32_t K = EDT_STRIP;
    uint64_t n = (uint64_t)r->w * r->h;
    int t = threads < 1 ? 1 : threads > 256 ? 256 : threads;
    while (t > 1 && (uint64_t)t * edt_min_pixels > n)
        t--;
    r->ntx = t;
    while (r->ntx > 1 && r->h / (uint32_t)r->ntx < 2 * K + 2)
        r->ntx--;
    r->nty = t;
    while (r->nty > 1 && r->w / (uint32_t)r->nty < 2 * EDT_YBLOCK_MIN + 2)
        r->nty--;
    r->nthreads = r->ntx > r->nty ? r->ntx : r->nty;
    uint32_t strips = EDT_XSTRIPS;
    if (r->ntx > 1 && (r->h / (uint32_t)r->ntx - 2) / (2 * K) < strips)
        strips = (r->h / (uint32_t)r->ntx - 2) / (2 * K);
    r->xblock = K * strips;
    r->yblock = EDT_YBLOCK;
    if (r->nty > 1 && (r->w / (uint32_t)r->nty - 2) / 2 < r->yblock)
        r->yblock = (r->w / (uint32_t)r->nty - 2) / 2;
}

/* Each x-sweep thread's column lines: its rows, one row above, and the gap
 * window below (rows up to its last + xblock); one allocation. */
static int edt_slots_alloc(struct edt_run *r)
{
    size_t total = 0, planes = r->packed ? 1 : 2;
    uint32_t *buf;
    r->slots = calloc((size_t)r->ntx, sizeof *r->slots);
    if (!r->slots)
        return -1;
    for (int t = 0; t < r->ntx; t++) {
        struct edt_slots *sl = &r->slots[t];
        uint32_t ya, yb;
        edt_share(r->h, t, r->ntx, &ya, &yb);
        uint64_t end = (uint64_t)yb + r->xblock + 1;
        sl->base = ya > 0 ? ya - 1 : 0;
        size_t rows = (size_t)(end < r->h ? end : r->h) - sl->base;
        /* Lines 64-byte aligned, and 64 bytes more than a multiple of
         * 4 KB apart: lines at a 4 KB multiple would share the few ways
         * of one L1 set while a strip is transposed. */
        sl->stride = rows >= 1024 ? (rows + 1023) / 1024 * 1024 + 16
                                  : (rows + 15) / 16 * 16 + 16;
        total += sl->stride * planes * (EDT_STRIP + 1);
    }
    buf = edt_alloc(total * sizeof *buf);
    if (!buf)
        return -1;
    for (int t = 0; t < r->ntx; t++) {
        r->slots[t].buf = buf;
        buf += r->slots[t].stride * planes * (EDT_STRIP + 1);
    }
    return 0;
}

static void edt_slots_free(struct edt_run *r)
{
    if (r->slots)
        free(r->slots[0].buf);
    free(r->slots);
}

int gv_edt_cpu(const uint32_t *ids, uint32_t w, uint32_t h, int threads,
               const struct gv_edt_out *out, struct gv_error *err)
{
    struct edt_run r;
    struct edt_worker *wk = NULL;
    uint32_t *state = NULL;
    int started = 0, rc = -1;

    if (w == 0 || h == 0 || w > GV_EDT_MAX_DIM || h > GV_EDT_MAX_DIM)
        return gv_fail(err, GV_EINVAL, "edt: bad size %ux%u", w, h);
    if ((uint64_t)w * h > SIZE_MAX / (2 * sizeof(uint32_t)))
        return gv_fail(err, GV_EINVAL, "edt: %ux%u is too large", w, h);
    memset(&r, 0, sizeof r);
    r.ids = ids;
    r.w = w;
    r.h = h;
    r.out = out;
    r.packed = w <= EDT_PACK_MAX && h <= EDT_PACK_MAX && !edt_force_wide;
    r.k = r.packed ? edt_pick()->packed : edt_pick()->wide;
    edt_threads(&r, threads);
    if (!r.packed && out->site_x && out->site_y) {
        r.sx = (uint32_t *)out->site_x;   /* the outputs are the state */
        r.sy = (uint32_t *)out->site_y;
    } else {
        size_t planes = r.packed ? 1 : 2;
        state = edt_alloc((size_t)w * h * planes * sizeof *state);
        if (!state) {
            gv_fail(err, GV_ENOMEM, "edt: no memory for %ux%u", w, h);
            goto out;
        }
        r.sx = state;
        r.sy = r.packed ? NULL : state + (size_t)w * h;
    }
    if (edt_slots_alloc(&r) != 0) {
        gv_fail(err, GV_ENOMEM, "edt: no memory for %u rows", h);
        goto out;
    }
    if (r.nthreads > 1) {
        wk = calloc((size_t)r.nthreads, sizeof *wk);
        if (!wk) {
            gv_fail(err, GV_ENOMEM, "edt: no memory for threads");
            goto out;
        }
    }
    for (int t = 1; t < r.nthreads; t++) {
        wk[t].run = &r;
        wk[t].t = t;
    }
    atomic_init(&r.bar.count, 0);
    atomic_init(&r.bar.gen, 0);
    atomic_init(&r.bar.sleepers, 0);
    pthread_mutex_init(&r.bar.lock, NULL);
    pthread_cond_init(&r.bar.wake, NULL);
    atomic_init(&r.gate, 0);
    /* Every thread is created before any starts working (a thread's share
     * depends on the final count); if one cannot be created, the others
     * are sent home and the caller does the whole job alone (the block
     * sizes suit any smaller count). */
    for (int t = 1; t < r.nthreads; t++) {
        if (pthread_create(&wk[t].thread, NULL, edt_thread, &wk[t]) != 0)
            break;
        started++;
    }
    if (started != r.nthreads - 1) {
        atomic_store(&r.gate, 2);
        for (int t = 1; t <= started; t++)
            pthread_join(wk[t].thread, NULL);
        started = 0;
        edt_slots_free(&r);
        edt_threads(&r, 1);
        if (edt_slots_alloc(&r) != 0) {
            gv_fail(err, GV_ENOMEM, "edt: no memory for %u rows", h);
            goto out_sync;
        }
    }
    r.bar.n = (unsigned)r.nthreads;
    r.bar.spins = r.nthreads <= sysconf(_SC_NPROCESSORS_ONLN) ? EDT_SPINS : 0;
    atomic_store(&r.gate, 1);
    edt_work(&r, 0);
    for (int t = 1; t <= started; t++)
        pthread_join(wk[t].thread, NULL);
    rc = 0;
out_sync:
    pthread_mutex_destroy(&r.bar.lock);
    pthread_cond_destroy(&r.bar.wake);
out:
    free(wk);
    edt_slots_free(&r);
    free(state);
    return rc;
}
