/*
 * edt_int.h - what edt_cpu.c shares with its kernels (edt_kernel.h,
 * instantiated in edt_cpu.c for the portable C and in x86/edt_*.c for
 * SSE2, AVX2 and AVX-512): the vector types, the scalar rules the
 * kernels fall back to at line ends and tails, and the table of one
 * layout's kernels.  Not part of the filters' interface.
 */
#ifndef GV_EDT_INT_H
#define GV_EDT_INT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define EDT_NONE_U 0xffffffffu   /* GV_EDT_NONE as uint32, and packed */
#define EDT_VL 16                /* lanes of the kernels */

typedef uint32_t edt_vu32 __attribute__((vector_size(64)));
typedef float edt_vf32 __attribute__((vector_size(64)));

/* ---------------------------------------------------------------- scalar */

/* The key of site (a, b) for the pixel (i, k); none is UINT32_MAX, which
 * no sum of two squares modulo 2^32 equals. */
static inline uint32_t edt_key(uint32_t a, uint32_t b, uint32_t i,
                               uint32_t k)
{
    uint32_t da = a - i, db = b - k;
    return da * da + db * db;
}

/* Site of element x of a line, unpacked ("a" along the line). */
static inline void edt_get(const uint32_t *pa, const uint32_t *pb, size_t x,
                           int packed, uint32_t *a, uint32_t *b)
{
    if (packed) {
        *a = pa[x] & 0xffffu;
        *b = pa[x] >> 16;
    } else {
        *a = pa[x];
        *b = pb[x];
    }
}

/* The rule for position i of a line of n (the scalar path of the
 * kernels: line ends, tails, and targets without vectors); x = i - base
 * indexes the arrays. */
static inline void edt_pixel(uint32_t *restrict oa, uint32_t *restrict ob,
                             const uint32_t *restrict pa,
                             const uint32_t *restrict pb, size_t x,
                             uint32_t n, uint32_t i, uint32_t k, int packed)
{
    const uint32_t *src = oa, *srcb = ob;
    size_t at = x;
    uint32_t a, b, bd;
    edt_get(oa, ob, x, packed, &a, &b);
    bd = oa[x] == EDT_NONE_U ? UINT32_MAX : edt_key(a, b, i, k);
    for (int c = 0; c < 3; c++) {
        size_t y = c == 0 ? x : c == 1 ? x - 1 : x + 1;
        if ((c == 1 && i == 0) || (c == 2 && i + 1 >= n) ||
            pa[y] == EDT_NONE_U)
            continue;
        edt_get(pa, pb, y, packed, &a, &b);
        uint32_t d = edt_key(a, b, i, k);
        if (d < bd) {
            bd = d;
            src = pa;
            srcb = pb;
            at = y;
        }
    }
    uint32_t va = src[at], vb = packed ? 0 : srcb[at];
    oa[x] = va;
    if (!packed)
        ob[x] = vb;
}

/* Distance of the site in element x of row y (its column is x too). */
static inline float edt_pixel_dist(const uint32_t *sx, const uint32_t *sy,
                                   uint32_t x, uint32_t y, int packed)
{
    uint32_t a, b;
    if (sx[x] == EDT_NONE_U)
        return INFINITY;
    edt_get(sx, sy, x, packed, &a, &b);
    return sqrtf((float)edt_key(a, b, x, y));
}

static inline uint32_t edt_swap16(uint32_t v)
{
    return v >> 16 | v << 16;
}

/* The scalar strip transposes: rows [ya, yb), strip columns c0 .. nc-1
 * (edt_kernel.h's edt_load and edt_store do the 16 x 16 blocks).  Load and
 * store are mirror images on purpose (same walk, opposite direction of
 * copy), kept as two plain loops so each compiles to straight code. */
static inline void edt_load_scalar(const uint32_t *restrict ids,
                                   const uint32_t *restrict px,
                                   const uint32_t *restrict py, size_t w,
                                   uint32_t x0, uint32_t nc, int dir,
                                   uint32_t ya, uint32_t yb, uint32_t c0,
                                   uint32_t base, uint32_t *const *sa,
                                   uint32_t *const *sb, int packed)
{
    for (uint32_t y = ya; y < yb; y++) {
        size_t p = (size_t)y * w + x0;
        for (uint32_t c = c0; c < nc; c++) {
            uint32_t j = dir > 0 ? c + 1 : nc - c;
            int site = ids && ids[p + c] != 0;
            if (packed)
                sa[j][y - base] = ids ? site ? y | (x0 + c) << 16 : EDT_NONE_U
                                      : edt_swap16(px[p + c]);
            else if (ids) {
                sa[j][y - base] = site ? y : EDT_NONE_U;
                sb[j][y - base] = site ? x0 + c : EDT_NONE_U;
            } else {
                sa[j][y - base] = py[p + c];
                sb[j][y - base] = px[p + c];
            }
        }
    }
}

static inline void edt_store_scalar(uint32_t *restrict px,
                                    uint32_t *restrict py, size_t w,
                                    uint32_t x0, uint32_t nc, int dir,
                                    uint32_t ya, uint32_t yb, uint32_t c0,
                                    uint32_t base, uint32_t *const *sa,
                                    uint32_t *const *sb, int packed)
{
    for (uint32_t y = ya; y < yb; y++) {
        size_t p = (size_t)y * w + x0;
        for (uint32_t c = c0; c < nc; c++) {
            uint32_t j = dir > 0 ? c + 1 : nc - c;
            if (packed) {
                px[p + c] = edt_swap16(sa[j][y - base]);
            } else {
                py[p + c] = sa[j][y - base];
                px[p + c] = sb[j][y - base];
            }
        }
    }
}

/* One layout's kernels on one instruction set. */
struct edt_kernels {
    void (*line)(uint32_t *restrict, uint32_t *restrict,
                 const uint32_t *restrict, const uint32_t *restrict,
                 uint32_t, uint32_t, uint32_t, uint32_t, uint32_t);
    void (*dist)(const uint32_t *restrict, const uint32_t *restrict,
                 uint32_t, uint32_t, uint32_t, float *restrict);
    void (*load)(const uint32_t *restrict, const uint32_t *restrict,
                 const uint32_t *restrict, size_t, uint32_t, uint32_t, int,
                 uint32_t, uint32_t, uint32_t, uint32_t *const *,
                 uint32_t *const *);
    void (*store)(uint32_t *restrict, uint32_t *restrict, size_t, uint32_t,
                  uint32_t, int, uint32_t, uint32_t, uint32_t,
                  uint32_t *const *, uint32_t *const *);
};

/* The kernels of x86/edt_sse2.c, edt_avx2.c and edt_avx512.c, each for
 * the wide (two planes) and the packed layout; only where gv_cpu_flags()
 * has GV_CPU_SSE2, GV_CPU_AVX2 or GV_CPU_AVX512. */
extern const struct edt_kernels gv_edt_sse2_wide, gv_edt_sse2_packed;
extern const struct edt_kernels gv_edt_avx2_wide, gv_edt_avx2_packed;
extern const struct edt_kernels gv_edt_avx512_wide, gv_edt_avx512_packed;

#endif
