/*
 * geometry.h - the shape of a gigaview pyramid: levels, tiles and pages.
 *
 * Level 0 is the full image; level k+1 is the 2x2 box average of level k
 * (ceil halving).  The first level that fits in root_side x root_side
 * pixels is the root (root_side is 512 before format version 6, a header
 * field from it on).  Every level below the root is cut into 513x513
 * tiles on a 512-pixel step (one pixel of overlap to the right and below)
 * and 8x8 tiles make a page.
 * Everything here is pure arithmetic on the header fields; see
 * docs/FORMAT.md for the definitions.
 */
#ifndef GV_GEOMETRY_H
#define GV_GEOMETRY_H

#include <stdint.h>

#include "codec/tile_layout.h"

#define GV_STEP 512          /* distance between tile origins (GV_TILE - 1) */
#define GV_PAGE_TILES 8      /* tiles per page edge: 4096^2 pixels a page */
#define GV_ROOT_MAX 512      /* the largest root_side: a root is at most this
                              * many pixels a side */
#define GV_MAX_LEVELS 40     /* a 2^31-pixel side needs 23; room to spare */
#define GV_MAX_DIM 0x7fffffffu /* width and height must stay below 2^31 */
#define GV_MAX_CHANNELS 8      /* a sample store's; image stores have 1 or 3 */

struct gv_level {
    uint32_t width, height;   /* pixels of this level */
    uint32_t tiles_x, tiles_y;/* tile grid (0 for the root level) */
    uint32_t pages_x, pages_y;/* page grid */
    uint64_t first_page;      /* index of its first page in the page index */
};

struct gv_geometry {
    uint32_t width, height;
    int channels;             /* image stores 1 (gray) or 3 (RGB); sample
                               * stores 1..GV_MAX_CHANNELS */
    uint32_t root_side;       /* the root is the first level within this */
    int root;                 /* index of the root level: levels 0..root */
    int root_mips;            /* mip levels stored for the root, root..1x1 */
    uint64_t pages;           /* total pages of levels 0..root-1 */
    struct gv_level level[GV_MAX_LEVELS];
};

/*
 * Fill *g for an image of width x height pixels with the given channel
 * count, whose root is the first level that fits in root_side x root_side
 * pixels (GV_ROOT_MAX for stores before format version 6).  Returns 0, or
 * -1 if a dimension is 0 or above GV_MAX_DIM, channels is not 1 ..
 * GV_MAX_CHANNELS (the store header checks an image store's 1 or 3), or
 * root_side is not 1..GV_ROOT_MAX.  A level has at least half (rounded
 * up) the tiles of the level below in each direction, so every tile has a
 * parent (which can add a column or row of tiles past a level's edge).
 * Page numbering runs from the level just below the root down to level 0
 * (the order the encoder writes them), row-major inside a level.
 */
int gv_geometry_init(struct gv_geometry *g, uint32_t width, uint32_t height,
                     int channels, uint32_t root_side);

/* Number of tiles along an edge of `pixels` pixels: max(1, ceil((n-1)/512)). */
uint32_t gv_tiles_for(uint32_t pixels);

/*
 * Width and height of pyramid level `level` of g: levels 0..g->root are
 * g->level[], and the root's mips follow as levels g->root + 1 ..
 * g->root + g->root_mips - 1, each the previous one halved, rounding up
 * (the sizes gv_store_root gives).  Returns 0, or -1 with *w and *h
 * untouched when there is no such level.  Pure; any thread.
 */
int gv_level_size(const struct gv_geometry *g, int level, uint32_t *w,
                  uint32_t *h);

/* Index of page (px,py) of `level` in the page index. */
uint64_t gv_page_number(const struct gv_geometry *g, int level, uint32_t px,
                        uint32_t py);

#endif
