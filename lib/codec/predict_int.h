/*
 * predict_int.h - what predict.c shares with its SIMD kernels
 * (x86/predict_*.c): the cubic's weights and constants, and the portable
 * loops written once and instantiated by every instruction set (the
 * interior filter, the clamped edge children, the row of horizontal sums
 * around them, the residual's clamped addition).  Not part of the codec's
 * interface; predict.c's design comment explains the arithmetic.
 */
#ifndef GV_PREDICT_INT_H
#define GV_PREDICT_INT_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "codec/tile_layout.h"

static const int W_EVEN[4] = {-3, 29, 111, -9};  /* taps at p-2 .. p+1 */
static const int W_ODD[4] = {-9, 111, 29, -3};   /* taps at p-1 .. p+2 */

/* h - OFFSET fits in int16_t; sum(w) * OFFSET returns in the vertical sum. */
#define OFFSET 16384
#define ROUND (8192 + 128 * OFFSET)
#define SUM_MAX (255 * 16384 + 16383)

static inline int clamp_tile(int i)
{
    return i < 0 ? 0 : (i > GV_TILE - 1 ? GV_TILE - 1 : i);
}

/* The plain C loops are written once, always inlined, and instantiated
 * per instruction set (predict.c for the portable C, x86/predict_avx2.c
 * and x86/predict_avx512.c compiled for theirs); the integers are the
 * same on every path. */
#define HOT_LOOP __attribute__((always_inline)) static inline

/* Even and odd horizontal sums (minus OFFSET) of children k0 <= k < k1,
 * whose taps all lie inside the row: parent pixels p0 + k - k0 onwards,
 * p0 = 256*qx - 2 + k0.  Exact in wrapping 16-bit arithmetic because the
 * true value fits. */
HOT_LOOP void filter_interior(const uint8_t *restrict src, int C,
                                     uint16_t *restrict even,
                                     uint16_t *restrict odd, int n)
{
    const uint8_t *s0 = src, *s1 = src + C, *s2 = src + 2 * C,
                  *s3 = src + 3 * C, *s4 = src + 4 * C;
    for (int i = 0; i < n; i++) {
        even[i] = (uint16_t)(W_EVEN[0] * s0[i] + W_EVEN[1] * s1[i] +
                             W_EVEN[2] * s2[i] + W_EVEN[3] * s3[i] - OFFSET);
        odd[i] = (uint16_t)(W_ODD[0] * s1[i] + W_ODD[1] * s2[i] +
                            W_ODD[2] * s3[i] + W_ODD[3] * s4[i] - OFFSET);
    }
}

/* The same for one child k near the tile's edge, every tap clamped. */
static inline void filter_edge(const uint8_t *src, int C, int base, int k,
                               uint16_t *even, uint16_t *odd)
{
    for (int c = 0; c < C; c++) {
        int e = 0, o = 0;
        for (int j = 0; j < 4; j++) {
            e += W_EVEN[j] * src[clamp_tile(base + k + j) * C + c];
            o += W_ODD[j] * src[clamp_tile(base + k + 1 + j) * C + c];
        }
        even[k * C + c] = (uint16_t)(e - OFFSET);
        odd[k * C + c] = (uint16_t)(o - OFFSET);
    }
}

/*
 * Horizontal sums (minus OFFSET) of one parent row for every child column
 * u = 0..512 of quadrant qx, interleaved as dst[u * C + c].  Child 2k
 * ("even") reads parent pixels base+k .. base+k+3 and child 2k+1 ("odd")
 * base+k+1 .. base+k+4, base = 256*qx - 2: only children 0 and 1 (qx = 0)
 * or 255 and 256 (qx = 1) reach outside the tile and are clamped; the
 * rest is a straight filter over the row.
 */
typedef void interior_fn(const uint8_t *restrict, int, uint16_t *restrict,
                         uint16_t *restrict, int);
typedef void interleave3_fn(const uint16_t *, const uint16_t *, int16_t *);

static inline void interleave3_c(const uint16_t *even, const uint16_t *odd,
                                 int16_t *dst)
{
    /* Three samples per pixel: copies of four, each spare sample
     * overwritten by the next copy (even[] and odd[] have spare room). */
    for (int k = 0; k < 256; k++) {
        memcpy(dst + 6 * k, even + 3 * k, 4 * sizeof *dst);
        memcpy(dst + 6 * k + 3, odd + 3 * k, 4 * sizeof *dst);
    }
    memcpy(dst + 6 * 256, even + 3 * 256, 3 * sizeof *dst);
}

__attribute__((always_inline)) static inline void
filter_row(const uint8_t *src, int C, int qx, int16_t *dst,
           interior_fn *interior, interleave3_fn *interleave3)
{
    uint16_t even[257 * 3 + 16], odd[257 * 3 + 16];   /* spare for wide loads */
    const int base = 256 * qx - 2;
    const int k0 = qx ? 0 : 2, k1 = qx ? 255 : 257;   /* interior [k0, k1) */
    interior(src + (size_t)(base + k0) * C, C, even + k0 * C, odd + k0 * C,
             (k1 - k0) * C);
    for (int k = 0; k < k0; k++)
        filter_edge(src, C, base, k, even, odd);
    for (int k = k1; k < 257; k++)
        filter_edge(src, C, base, k, even, odd);
    /* Interleave: child 2k from even[k], 2k+1 from odd[k]. */
    if (C == 1) {
        for (int k = 0; k < 256; k++) {
            dst[2 * k] = (int16_t)even[k];
            dst[2 * k + 1] = (int16_t)odd[k];
        }
        dst[512] = (int16_t)even[256];
        return;
    }
    interleave3(even, odd, dst);
}

/* row[i] = clamp(row[i] + res[i], 0, 255). */
HOT_LOOP void add_clamped_c(uint8_t *restrict row,
                                   const int8_t *restrict res, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        int v = row[i] + res[i];
        row[i] = (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
    }
}

/* Weights w[k] and w[k + 1] as a VPMADDWD operand: two 16-bit values in a
 * 32-bit lane, w[k] in the low half. */
static inline int32_t weight_pair(const int *w, int k)
{
    return (int32_t)((uint32_t)(uint16_t)w[k] | (uint32_t)(uint16_t)w[k + 1] << 16);
}

#endif
