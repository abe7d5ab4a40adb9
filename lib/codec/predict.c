/*
 * predict.c - the integer cubic upsample that predicts a tile from one
 * quarter of its decoded parent.
 *
 * Child pixel u (0..512) of quadrant q sits a quarter pixel before
 * (u even) or after (u odd) parent pixel p = 256*q + u/2, the sample
 * centres of a 2x2 box-filtered pyramid.  It is interpolated with the
 * Catmull-Rom cubic at that offset, whose weights are exact in 1/128ths:
 *
 *   u even: parent p-2, p-1, p, p+1 with weights -3, 29, 111, -9
 *   u odd:  parent p-1, p, p+1, p+2 with weights -9, 111, 29, -3
 *
 * Parent indices are clamped to the parent tile [0,512], so no neighbour
 * tile is ever needed.  Rows are done the same way, and the 2-D result is
 * the product of the two, with a single rounding and a clamp:
 *
 *   s    = sum_j wy[j] * sum_i wx[i] * P[row_j][col_i]     (exact integer)
 *   pred = clamp(s + 8192, 0, 255*16384 + 16383) >> 14
 *
 * Compared with the bilinear (3,1)/4 kernel this lowered the bits needed
 * for the same PSNR by 5 to 10 % on the benchmark photographs (FORMAT.md,
 * section 3).  Here the horizontal sums of each parent row are computed
 * once (exact, no rounding) and combined vertically, which gives the same
 * integers as the double sum above.  The GLSL
 * decoders compute the same expression; docs/FORMAT.md is normative.
 */
#include "codec/tile_layout.h"
#include "codec/tile.h"

static const int W_EVEN[4] = {-3, 29, 111, -9};  /* taps at p-2 .. p+1 */
static const int W_ODD[4] = {-9, 111, 29, -3};   /* taps at p-1 .. p+2 */

static inline int clamp_tile(int i)
{
    return i < 0 ? 0 : (i > GV_TILE - 1 ? GV_TILE - 1 : i);
}

/* First tap of child coordinate u in quadrant q. */
static inline int first_tap(int q, int u)
{
    int p = 256 * q + (u >> 1);
    return (u & 1) ? p - 1 : p - 2;
}

/* Where the compiler and CPU allow, the two hot loops are also compiled
 * for AVX2 (32-bit multiplies in vector registers need SSE4.1 or later;
 * the baseline x86-64 target has none), chosen at load time.  The integers
 * are the same on every path. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define HOT_LOOP __attribute__((target_clones("avx2", "default")))
#else
#define HOT_LOOP
#endif

/* Largest padded parent segment: 258 quadrant pixels + 2 + 2 of clamp. */
#define SEG (258 + 4)

/*
 * Horizontal sums of one parent row for every child column u = 0..512 of
 * quadrant qx, written interleaved as dst[u * C + c].  The parent pixels
 * the quadrant reads, 256*qx - 2 .. 256*qx + 258, are first copied with
 * clamping into a padded segment, so that the filter loops have no
 * branches: "even" children (u = 2k) and "odd" ones (u = 2k + 1) are each
 * a straight 4-tap filter over the segment, which compilers vectorize.
 */
HOT_LOOP static void filter_row(const uint8_t *src, int channels, int qx,
                                int32_t *dst)
{
    int32_t seg[SEG * 3], even[257 * 3], odd[257 * 3];
    const int base = 256 * qx - 2;
    for (int i = 0; i < SEG; i++) {
        const uint8_t *px = src + clamp_tile(base + i) * channels;
        for (int c = 0; c < channels; c++)
            seg[i * channels + c] = px[c];
    }
    /* Child 2k reads parent p-2..p+1 and child 2k+1 parent p-1..p+2, with
     * p = 256*qx + k, i.e. segment positions k..k+3 and k+1..k+4. */
    const int n = 257 * channels, C = channels;
    const int32_t *s0 = seg, *s1 = seg + C, *s2 = seg + 2 * C, *s3 = seg + 3 * C,
                  *s4 = seg + 4 * C;
    for (int i = 0; i < n; i++) {
        even[i] = W_EVEN[0] * s0[i] + W_EVEN[1] * s1[i] + W_EVEN[2] * s2[i] +
                  W_EVEN[3] * s3[i];
        odd[i] = W_ODD[0] * s1[i] + W_ODD[1] * s2[i] + W_ODD[2] * s3[i] +
                 W_ODD[3] * s4[i];
    }
    for (int k = 0; k < 257; k++)
        for (int c = 0; c < C; c++) {
            dst[(2 * k) * C + c] = even[k * C + c];
            if (k < 256)
                dst[(2 * k + 1) * C + c] = odd[k * C + c];
        }
}

#define RING 8   /* parent rows kept filtered: a child row needs 4 */

/* One child row from the four filtered parent rows it reads. */
HOT_LOOP static void vertical(const int32_t *restrict h0, const int32_t *restrict h1,
                     const int32_t *restrict h2, const int32_t *restrict h3,
                     const int *w, size_t n, uint8_t *restrict out)
{
    const int32_t w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3];
    const int32_t hi = 255 * 16384 + 16383;
    for (size_t i = 0; i < n; i++) {
        int32_t s = w0 * h0[i] + w1 * h1[i] + w2 * h2[i] + w3 * h3[i] + 8192;
        s = s < 0 ? 0 : s;
        s = s > hi ? hi : s;
        out[i] = (uint8_t)(s >> 14);
    }
}

void gv_predict(const uint8_t *parent, int channels, int qx, int qy,
                uint8_t *pred)
{
    const size_t row = (size_t)GV_TILE * channels;
    /* Filtered parent rows, tagged with their row number; child rows walk
     * the parent downwards, so a small ring holds the ones in use. */
    int32_t ring[RING][GV_TILE * 3];
    int tag[RING];
    for (int k = 0; k < RING; k++)
        tag[k] = -1;
    for (int v = 0; v < GV_TILE; v++) {
        const int *w = (v & 1) ? W_ODD : W_EVEN;
        int t = first_tap(qy, v);
        const int32_t *h[4];
        for (int k = 0; k < 4; k++) {
            int pr = clamp_tile(t + k), slot = pr % RING;
            if (tag[slot] != pr) {
                filter_row(parent + (size_t)pr * row, channels, qx, ring[slot]);
                tag[slot] = pr;
            }
            h[k] = ring[slot];
        }
        vertical(h[0], h[1], h[2], h[3], w, row, pred + (size_t)v * row);
    }
}
