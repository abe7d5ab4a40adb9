/*
 * predict.c - the integer bilinear upsample that predicts a tile from one
 * quarter of its decoded parent.
 *
 * Child pixel u (0..512) of quadrant q sits between parent pixels
 * p = 256*q + u/2 and its neighbour n = p-1 (u even) or p+1 (u odd), with
 * weights 3/4 and 1/4: the centres of a 2x2 box-filtered pyramid.  n is
 * clamped to the parent tile [0,512], so no neighbour tile is needed.  The
 * 2-D weights are the products (9,3,3,1)/16 with a single rounding:
 *
 *   pred = (9*P[q][p] + 3*P[q][n] + 3*P[m][p] + P[m][n] + 8) >> 4
 *
 * where q,m are the row counterparts of p,n.  The GLSL decoders implement
 * the same expression; docs/FORMAT.md is the normative statement.
 */
#include "geometry.h"
#include "tile.h"

static inline int clamp_tile(int i)
{
    return i < 0 ? 0 : (i > GV_TILE - 1 ? GV_TILE - 1 : i);
}

void gv_predict(const uint8_t *parent, int channels, int qx, int qy,
                uint8_t *pred)
{
    int near_x[GV_TILE], far_x[GV_TILE];
    for (int u = 0; u < GV_TILE; u++) {
        int p = 256 * qx + (u >> 1);
        near_x[u] = p * channels;
        far_x[u] = clamp_tile((u & 1) ? p + 1 : p - 1) * channels;
    }
    const size_t row = (size_t)GV_TILE * channels;
    for (int v = 0; v < GV_TILE; v++) {
        int q = 256 * qy + (v >> 1);
        int m = clamp_tile((v & 1) ? q + 1 : q - 1);
        const uint8_t *rq = parent + (size_t)q * row;
        const uint8_t *rm = parent + (size_t)m * row;
        uint8_t *out = pred + (size_t)v * row;
        for (int u = 0; u < GV_TILE; u++) {
            const int a = near_x[u], b = far_x[u];
            for (int c = 0; c < channels; c++) {
                int s = 9 * rq[a + c] + 3 * rq[b + c] + 3 * rm[a + c] +
                        rm[b + c] + 8;
                out[u * channels + c] = (uint8_t)(s >> 4);
            }
        }
    }
}
