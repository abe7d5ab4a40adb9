/*
 * tile_dct_pixels.c - layout D's pixel side (docs/FORMAT.md section 4.3):
 * the 8x8 integer inverse transform, YCoCg-R and the residual's addition
 * to the prediction, a row of blocks at a time (tile_dct_pixels.h).
 *
 * The transform is two passes of 32-bit integer sums, each rounded by an
 * arithmetic shift; sums of exact integers do not depend on their order,
 * so every way of computing them below gives the same bytes:
 * - The portable path multiplies only the rows and columns that the coded
 *   coefficients reach (most blocks end well before coefficient 64), and
 *   fills DC-only blocks at once.
 * - The AVX2 path (x86/tile_dct_pixels_avx2.c, where gv_cpu_flags() has
 *   AVX2) computes the first pass with VPMADDWD, two coefficients of a
 *   row per 32-bit lane against two matrix rows, eight outputs at once;
 *   the second pass the same way on the first pass's results, packed to
 *   16 bits in pairs of rows.  Blocks with four coded rows or more take
 *   even-odd butterflies instead (half the multiplies; 1.03 times the tile
 *   decoding speed on Picos de Europa, bench/README.md 2026-11-26).  Those
 *   results fit in 16 bits for every block an encoder writes but not for
 *   every block a buffer can hold (steps of 4095), so a block whose first
 *   pass leaves the 16-bit range is done by the portable path.  The sum
 *   with the prediction saturates to 16 bits and then clamps to 0..255,
 *   the same as clamping the exact sum, since a prediction lies in 0..255.
 * Blocks without chroma (most of a photograph's: the prediction carries
 * the colour) add Y to R, G and B, which is what YCoCg-R gives for
 * Co = Cg = 0.  Arithmetic shifts of negative numbers go through asr(), a
 * floor division, so that the result does not depend on the compiler.
 * The row function is picked from gv_cpu_flags() (base/cpu.h) into a
 * one-entry table, add_row_kernel; the portable block and the loop over a
 * row are shared with the AVX2 file through tile_dct_pixels_int.h.
 */
#include <string.h>

#include "base/cpu.h"
#include "codec/tile_dct_pixels.h"
#include "codec/tile_dct_pixels_int.h"
#include "codec/tile_layout.h"
#include "codec/x86/tile_dct_pixels_avx2.h"

const int32_t gv_dct_matrix[8][8] = {
    {64, 64, 64, 64, 64, 64, 64, 64},
    {89, 75, 50, 18, -18, -50, -75, -89},
    {83, 36, -36, -83, -83, -36, 36, 83},
    {75, -18, -89, -50, 50, 89, 18, -75},
    {64, -64, -64, 64, 64, -64, -64, 64},
    {50, -89, 18, 75, -75, -18, 89, -50},
    {36, -83, 83, -36, -36, 83, -83, 36},
    {18, -50, 75, -89, 89, -75, 50, -18},
};

const uint8_t gv_dct_zz_rows[65] = {
    0, 1, 1, 2, 3, 3, 3, 3, 3, 3, 4, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 6,
    7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 7, 8, 8, 8, 8, 8, 8, 8, 8,
    8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
};
const uint8_t gv_dct_zz_cols[65] = {
    0, 1, 2, 2, 2, 2, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 6, 6, 6, 6, 6, 6,
    6, 6, 6, 6, 6, 6, 7, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
    8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8, 8,
};

void gv_dct_inverse(const int16_t *d, int32_t *e)
{
    int32_t t[8][8];   /* t[v][i] */
    for (int v = 0; v < 8; v++) {
        const int16_t *dv = d + 8 * v;
        int any = 0;
        for (int u = 0; u < 8; u++)
            any |= dv[u];
        for (int i = 0; i < 8; i++) {
            int32_t s = 64;
            if (any)
                for (int u = 0; u < 8; u++)
                    s += gv_dct_matrix[u][i] * dv[u];
            t[v][i] = asr(s, 7);
        }
    }
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 8; i++) {
            int32_t s = 1024;
            for (int v = 0; v < 8; v++)
                s += gv_dct_matrix[v][j] * t[v][i];
            e[8 * j + i] = asr(s, 11);
        }
}

typedef void add_row_fn(gv_dct_row, const uint8_t[3][GV_DCT_BLOCKS], int, int,
                        uint8_t *);

static void add_row_c(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                      int channels, int by, uint8_t *out)
{
    gv_dct_add_row_blocks(co, eobs, channels, by, out, NULL, NULL);
}

static add_row_fn *add_row_kernel = add_row_c;
static struct gv_cpu_once add_row_once = GV_CPU_ONCE_INIT;

static void pixels_dsp_init(unsigned flags)
{
    add_row_kernel = add_row_c;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_AVX2)
        add_row_kernel = gv_dct_add_row_avx2;
#else
    (void)flags;
#endif
}

void gv_dct_add_row(gv_dct_row co, const uint8_t eobs[3][GV_DCT_BLOCKS],
                    int channels, int by, uint8_t *out)
{
    gv_cpu_once(&add_row_once, pixels_dsp_init);
    add_row_kernel(co, eobs, channels, by, out);
}
