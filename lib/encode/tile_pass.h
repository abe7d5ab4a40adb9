/*
 * tile_pass.h - how pass 2 (stream_encoder.c) and the lambda trial
 * (lambda_trial.c) code and measure a tile, written once: the trial's
 * tiles stand in for pass 2's byte for byte, and its level-0 errors make
 * the store's PSNR, so the two must not drift apart.
 */
#ifndef GV_TILE_PASS_H
#define GV_TILE_PASS_H

#include <stdint.h>

#include "codec/sse.h"
#include "codec/tile_layout.h"
#include "store/geometry.h"

/* The seed of tile (tx, ty) of `level` (gv_tile_params.seed). */
static inline uint64_t gv_encode_tile_seed(int level, uint32_t tx, uint32_t ty)
{
    return ((uint64_t)(unsigned)level << 56) ^ ((uint64_t)tx << 28) ^ ty ^
           0x6a09e667f3bcc909ull;
}

/* Pixels of tile t inside a level side `size` pixels long: GV_TILE, fewer
 * in the last tile (the tile's valid width or height). */
static inline uint32_t gv_tile_span(uint32_t size, uint32_t t)
{
    const uint32_t left = size - t * GV_STEP;
    return left < GV_TILE ? left : GV_TILE;
}

/* The squared error of level-0 tile (tx, ty) of level l (c channels) over
 * the pixels it is the source of: 512 x 512 (the overlap belongs to the
 * next tile), its valid span in the last column and row of tiles.  Sets
 * *samples (if not NULL) to the count of samples summed. */
static inline uint64_t gv_level0_tile_sse(const struct gv_level *l, uint32_t tx,
                                          uint32_t ty, int c, const uint8_t *orig,
                                          const uint8_t *recon, uint64_t *samples)
{
    const uint32_t cw = tx + 1 == l->tiles_x ? gv_tile_span(l->width, tx) : GV_STEP;
    const uint32_t ch = ty + 1 == l->tiles_y ? gv_tile_span(l->height, ty) : GV_STEP;
    if (samples)
        *samples = (uint64_t)cw * ch * (uint64_t)c;
    return gv_sse_u8(orig, recon, cw * (uint32_t)c, ch, (size_t)GV_TILE * c);
}

#endif
