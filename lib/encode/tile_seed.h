/*
 * tile_seed.h - the seed of each tile's sampling (gv_tile_params.seed):
 * one rule for pass 2 (stream_encoder.c) and the lambda trial
 * (lambda_trial.c), which must code a tile to the same bytes.
 */
#ifndef GV_TILE_SEED_H
#define GV_TILE_SEED_H

#include <stdint.h>

/* The seed of tile (tx, ty) of `level`. */
static inline uint64_t gv_encode_tile_seed(int level, uint32_t tx, uint32_t ty)
{
    return ((uint64_t)(unsigned)level << 56) ^ ((uint64_t)tx << 28) ^ ty ^
           0x6a09e667f3bcc909ull;
}

#endif
