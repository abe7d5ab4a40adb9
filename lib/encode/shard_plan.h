/*
 * shard_plan.h - which tiles shard i of n encodes (`gigaview encode
 * --shard i/n`).
 *
 * The tile tree is a quadtree: tile (tx,ty) of level k is the parent of
 * tiles (2tx..2tx+1, 2ty..2ty+1) of level k-1.  Level-0 tiles are put in
 * Morton (Z) order, and shard i takes one contiguous run of that order,
 * cut so that every shard gets about the same number of level-0 pixels.
 * A contiguous run of Z order is a union of whole subtrees (aligned square
 * blocks of the quadtree) plus at most one partial subtree per level at
 * each end, so a shard encodes:
 *
 *   - its level-0 tiles, and
 *   - every ancestor of them up to the level below the root.
 *
 * Because every tile is predicted from its decoded parent and nothing
 * else (docs/FORMAT.md, section 3; the --rd slope is a constant of -q),
 * an ancestor encoded by two shards comes out byte for byte the same in
 * both, and the union over the n shards is exactly the tile set of a
 * single encode.  Only the ancestors whose subtrees straddle a cut are
 * encoded twice: at most one tile per level per cut.
 *
 * The plan is pure arithmetic on the geometry; every shard computes it
 * for itself, so shards need no coordination.
 */
#ifndef GV_SHARD_PLAN_H
#define GV_SHARD_PLAN_H

#include <stdint.h>

#include "base/error.h"
#include "store/geometry.h"

#define GV_SHARD_MAX 65535   /* shard counts fit the file's 16-bit fields */

struct gv_shard_plan {
    int index, count;
    /* want[k][ty * tiles_x + tx] != 0: this shard encodes that tile
     * (levels 0 .. root-1; NULL above). */
    uint8_t *want[GV_MAX_LEVELS];
    uint64_t tiles;           /* tiles wanted, every level */
    uint64_t own_tiles;       /* level-0 tiles: this shard's share */
    uint64_t samples;         /* valid pixels x channels of wanted tiles */
};

/*
 * Plan shard `index` (0-based) of `count` (1..GV_SHARD_MAX) for geometry
 * *g.  A shard may own no tile (more shards than level-0 tiles); its plan
 * is then empty.  Every geometry plans: every tile has a parent
 * (docs/FORMAT.md section 2).  Returns 0, or -1 with *err filled (bad
 * index or count, no memory).  Free with gv_shard_plan_free.
 */
int gv_shard_plan_init(struct gv_shard_plan *p, const struct gv_geometry *g,
                       int index, int count, struct gv_error *err);

/* Release the bitmaps.  Safe on a zeroed or already freed plan. */
void gv_shard_plan_free(struct gv_shard_plan *p);

/* Whether the plan wants tile (tx,ty) of `level` (0 outside the grid). */
int gv_shard_plan_wants(const struct gv_shard_plan *p,
                        const struct gv_geometry *g, int level, uint32_t tx,
                        uint32_t ty);

/* Whether the plan wants any tile of page (px,py) of `level`. */
int gv_shard_plan_wants_page(const struct gv_shard_plan *p,
                             const struct gv_geometry *g, int level,
                             uint32_t px, uint32_t py);

/*
 * Parse "I/N" (0 <= I < N <= GV_SHARD_MAX, decimal digits only) into
 * *index and *count.  Returns 0 or -1.
 */
int gv_shard_parse(const char *s, int *index, int *count);

#endif
