/*
 * edt_cpu.h - the CPU path of the distance transform and Voronoi diagram
 * (thesis section 7.8): 2D vector propagation with the modified
 * four-sweep templates of fig. 7.14, which reach the Moore neighbourhood.
 *
 * The result is defined exactly, so that the GPU propagation template can
 * be compared with it bit for bit:
 *
 *  - State per pixel: the nearest site found so far as absolute
 *    coordinates (sx, sy), or "none".  Initially a pixel whose id is not 0
 *    is its own site; every other pixel is none.
 *  - Four sweeps, in this order:
 *      +x: columns x = 1 .. w-1,   candidates own, (x-1,y), (x-1,y-1), (x-1,y+1)
 *      -x: columns x = w-2 .. 0,   candidates own, (x+1,y), (x+1,y-1), (x+1,y+1)
 *      +y: rows    y = 1 .. h-1,   candidates own, (x,y-1), (x-1,y-1), (x+1,y-1)
 *      -y: rows    y = h-2 .. 0,   candidates own, (x,y+1), (x-1,y+1), (x+1,y+1)
 *    Neighbours outside the image are skipped.  The previous line is read
 *    with its value already updated by this sweep; "own" is the pixel's
 *    value from before this sweep.
 *  - A candidate's key is d2 = dx*dx + dy*dy, dx = sx - x, dy = sy - y,
 *    computed in uint32 arithmetic (wrapping modulo 2^32).  It is the
 *    exact squared distance for distances below 46341 px (46341^2 > 2^31:
 *    below that it also fits a signed 32-bit int, so GPU code computing in
 *    int or uint gets the same bits; in uint32 it stays exact up to
 *    65535 px).  Farther candidates wrap, identically on CPU and GPU.  A
 *    wrapped value can never equal 0xffffffff (a sum of two squares is
 *    never 3 mod 4), so "none" acts as the key 0xffffffff and is never
 *    chosen over a site.
 *  - The candidates are taken in the order above; a later one replaces the
 *    best so far only if its key is strictly smaller.  Ties go to the
 *    earliest candidate.
 *  - Output per pixel: the site's coordinates, the site's id (the input id
 *    at the site), and the distance as float: sqrtf((float)d2), the
 *    uint32 converted to float with round-to-nearest-even and an IEEE
 *    correctly rounded square root (what GLSL's sqrt(float(d2)) computes
 *    when the driver's sqrt is correctly rounded).  A pixel with no site
 *    (only when the image has no site at all) gets site (-1, -1), id 0 and
 *    distance +infinity.
 *
 * The implementation is SIMD (AVX-512, AVX2 or SSE2, chosen at run time;
 * plain C elsewhere) and multi-threaded, and produces exactly the result
 * of the rules above for any thread count.  Memory: 4 bytes per pixel of
 * state (8 when the image is wider or higher than 65535 pixels and the
 * caller does not give site_x and site_y), plus 260 bytes per image row
 * (520 with two planes) of column buffers for the x-sweeps.
 */
#ifndef GV_EDT_CPU_H
#define GV_EDT_CPU_H

#include <stdint.h>

#include "base/error.h"

/* Site coordinate of a pixel that has no site. */
#define GV_EDT_NONE (-1)

/* Largest width or height accepted (coordinates and the -1 sentinel fit
 * in int32 with room to spare). */
#define GV_EDT_MAX_DIM (1u << 30)

/*
 * Where the results go.  Each array holds w*h values, rows packed, top
 * row first; any of them may be NULL when that result is not wanted.
 * When site_x and site_y are both given they are also used as the
 * working state (no other w*h allocation is made).
 */
struct gv_edt_out {
    int32_t *site_x;    /* nearest site's x, or GV_EDT_NONE */
    int32_t *site_y;    /* nearest site's y, or GV_EDT_NONE */
    uint32_t *site_id;  /* ids[site_y * w + site_x], or 0 */
    float *dist;        /* sqrtf((float)d2), or +INFINITY */
};

/*
 * Compute the propagation distance transform of the w x h id image `ids`
 * (rows packed; a pixel is a site when its id is not 0).  threads >= 1 is
 * the most threads to use (the calling thread is one of them); fewer run
 * on small images.  The result does not depend on `threads`.
 *
 * Returns 0, or -1 with *err: GV_EINVAL for a zero or too large size
 * (> GV_EDT_MAX_DIM, or w*h overflowing size_t), GV_ENOMEM.  Thread-safe:
 * concurrent calls share nothing.
 */
int gv_edt_cpu(const uint32_t *ids, uint32_t w, uint32_t h, int threads,
               const struct gv_edt_out *out, struct gv_error *err);

/* The instruction set the kernels use on this machine: "avx512", "avx2",
 * "sse2" or "c".  For benchmarks and logs. */
const char *gv_edt_cpu_isa(void);

/*
 * For tests and benchmarks: force an instruction set ("avx512", "avx2",
 * "sse2", "c"; NULL, unknown or unsupported: the best one available), the
 * fewest pixels per thread (0: the default, 524288; 1 lets small images
 * use threads too) and, with wide != 0, the two-plane state layout that
 * images over 65535 pixels wide or high use (instead of the packed
 * 2 x 16-bit one).  Returns the instruction set selected.  Not
 * thread-safe: call while no gv_edt_cpu runs.
 */
const char *gv_edt_cpu_configure(const char *isa, uint32_t min_pixels,
                                 int wide);

#endif
