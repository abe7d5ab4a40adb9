/*
 * tile_layout.h - the fixed shape of a tile (thesis section 7.4): 513x513
 * pixels, coded as 257x257 blocks of 2x2 pixels with one VQ index each of
 * at most GV_MAX_RATE bits.  The codec needs nothing else of the pyramid;
 * store/geometry.h builds levels and pages on these.
 */
#ifndef GV_TILE_LAYOUT_H
#define GV_TILE_LAYOUT_H

#include <stdint.h>

#define GV_TILE 513          /* tile edge in pixels (section 7.4: N = 513) */
#define GV_BLOCKS 257        /* 2x2 blocks per tile edge: ceil(513 / 2) */
#define GV_NBLOCKS (GV_BLOCKS * GV_BLOCKS)
#define GV_MAX_RATE 12       /* largest index width r in bits */

/* Bytes per decoded tile: 513 * 513 * channels. */
static inline uint32_t gv_tile_bytes(int channels)
{
    return (uint32_t)GV_TILE * GV_TILE * (uint32_t)channels;
}

#endif
