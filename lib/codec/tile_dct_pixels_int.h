/*
 * tile_dct_pixels_int.h - what tile_dct_pixels.c shares with its SIMD
 * kernels (x86/tile_dct_pixels_*.c): the portable block (the sparse
 * inverse transform, YCoCg-R and the clamped addition) that they fall
 * back to, and the loop over a row of blocks, written once.  Not part of
 * the codec's interface.
 */
#ifndef GV_TILE_DCT_PIXELS_INT_H
#define GV_TILE_DCT_PIXELS_INT_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "codec/tile_dct_row.h"
#include "codec/tile_layout.h"

/* floor(a / 2^s).  GCC and Clang define >> of a negative number as the
 * arithmetic shift (and vectorize it); anything else gets the portable
 * form. */
static inline int32_t asr(int32_t a, int s)
{
#if defined(__GNUC__)
    return a >> s;
#else
    return a >= 0 ? a >> s : ~(~a >> s);
#endif
}

static inline uint8_t clamp_u8(int32_t v)
{
    return (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
}

/* gv_dct_inverse of a block whose coefficients past the first n in
 * zigzag order are zero (n >= 1), read from row-major storage with
 * `stride` between rows: the terms left out are zero, so the integers are
 * the same. */
static inline void inverse_sparse(const int16_t *d, size_t stride, int n,
                                  int32_t *e)
{
    const int rows = gv_dct_zz_rows[n], cols = gv_dct_zz_cols[n];
    if (n == 1) {
        const int32_t t = asr(64 * d[0] + 64, 7), v = asr(64 * t + 1024, 11);
        for (int k = 0; k < 64; k++)
            e[k] = v;
        return;
    }
    int32_t t[8][8];   /* t[v][i], rows v < `rows` */
    /* Loops over i innermost, eight lanes, so that they vectorize. */
    for (int v = 0; v < rows; v++) {
        const int16_t *dv = d + (size_t)v * stride;
        int32_t acc[8] = {64, 64, 64, 64, 64, 64, 64, 64};
        for (int u = 0; u < cols; u++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[u][i] * dv[u];
        for (int i = 0; i < 8; i++)
            t[v][i] = asr(acc[i], 7);
    }
    for (int j = 0; j < 8; j++) {
        int32_t acc[8] = {1024, 1024, 1024, 1024, 1024, 1024, 1024, 1024};
        for (int v = 0; v < rows; v++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[v][j] * t[v][i];
        for (int i = 0; i < 8; i++)
            e[8 * j + i] = asr(acc[i], 11);
    }
}

/* Set the first `rows` rows of a block's coefficients back to zero. */
static inline void clear_block(int16_t *d, int n)
{
    for (int v = 0; v < gv_dct_zz_rows[n]; v++)
        memset(d + (size_t)v * GV_DCT_PLANE, 0, 8 * sizeof *d);
}

/* Add residuals e (per channel, 8 x 8, row-major) to the pixels of a
 * block: `rows` x `cols` pixels from px, `stride` bytes between rows.
 * gray_residual: channels is 3 but e[1] and e[2] are zero (not read). */
static inline void add_block(uint8_t *px, size_t stride, int channels,
                             int rows, int cols, int gray_residual,
                             const int32_t e[3][64])
{
    for (int j = 0; j < rows; j++, px += stride) {
        const int32_t *ey = e[0] + 8 * j;
        uint8_t *p = px;
        if (channels == 1) {
            for (int i = 0; i < cols; i++)
                p[i] = clamp_u8(p[i] + ey[i]);
        } else if (gray_residual) {
            /* Co = Cg = 0: YCoCg-R gives R = G = B = Y. */
            for (int i = 0; i < 3 * cols; i++)
                p[i] = clamp_u8(p[i] + ey[i / 3]);
        } else {
            for (int i = 0; i < cols; i++, p += 3) {
                const int k = 8 * j + i;
                const int32_t y = e[0][k], co = e[1][k], cg = e[2][k];
                const int32_t t = y - asr(cg, 1);
                const int32_t g = cg + t, b = t - asr(co, 1), r = b + co;
                p[0] = clamp_u8(p[0] + r);
                p[1] = clamp_u8(p[1] + g);
                p[2] = clamp_u8(p[2] + b);
            }
        }
    }
}

/* One block by the portable path: n[c] coded coefficients of channel c
 * at d[c] (stride GV_DCT_PLANE), not all zero. */
static inline void block_portable(int16_t *const d[3], const int n[3],
                                  int channels, uint8_t *px, size_t stride,
                                  int rows, int cols)
{
    int32_t e[3][64];
    for (int c = 0; c < channels; c++) {
        if (!n[c]) {
            /* Zeros only where another channel needs them. */
            if (c > 0 || n[1] | n[2])
                memset(e[c], 0, sizeof e[c]);
            continue;
        }
        inverse_sparse(d[c], GV_DCT_PLANE, n[c], e[c]);
        clear_block(d[c], n[c]);
    }
    add_block(px, stride, channels, rows, cols,
              channels == 1 || !(n[1] | n[2]), e);
}

/* A SIMD block: one whole 8 x 8 block as block_portable would do it, or 0
 * (nothing changed) to leave it to block_portable. */
typedef int gv_dct_block_fn(const void *ctx, int16_t *const d[3],
                            const int n[3], int channels, uint8_t *px,
                            size_t stride);

/* A row of blocks (gv_dct_add_row); with simd, whole blocks by it where
 * it takes them (it returns 0 for a block it leaves to the portable path;
 * the tile's last row and column of blocks, one pixel wide, are never
 * offered).  ctx: simd's constants.  Inlined with a constant simd, so each
 * instruction set gets its own loop. */
__attribute__((always_inline)) static inline void
gv_dct_add_row_blocks(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                      int channels, int by, uint8_t *out,
                      gv_dct_block_fn *simd, const void *ctx)
{
    const size_t stride = (size_t)GV_TILE * channels;
    const int y0 = 8 * by, rows = y0 + 8 <= GV_TILE ? 8 : GV_TILE - y0;
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
        const int n[3] = {eobs[0][bx], channels == 3 ? eobs[1][bx] : 0,
                          channels == 3 ? eobs[2][bx] : 0};
        if (!(n[0] | n[1] | n[2]))
            continue;
        int16_t *const d[3] = {&co[0][0][8 * bx], &co[1][0][8 * bx],
                               &co[2][0][8 * bx]};
        const int x0 = 8 * bx, cols = x0 + 8 <= GV_TILE ? 8 : GV_TILE - x0;
        uint8_t *px = out + (size_t)y0 * stride + (size_t)x0 * channels;
        if (simd && rows == 8 && cols == 8 &&
            simd(ctx, d, n, channels, px, stride))
            continue;
        block_portable(d, n, channels, px, stride, rows, cols);
    }
}

#endif
