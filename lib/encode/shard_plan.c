/*
 * shard_plan.c - the tiles of one shard (see shard_plan.h).
 *
 * Level-0 tiles are visited in Z order by descending an implicit quadtree
 * of aligned power-of-two blocks and pruning blocks that start outside
 * the grid, so the walk costs O(tiles) however elongated the image.  The
 * cut between shards uses integer arithmetic only (128-bit for the
 * product), so every machine computes the same plan.
 */
#include <stdlib.h>
#include <string.h>

#include "encode/shard_plan.h"

struct walk {
    const struct gv_geometry *g;
    const struct gv_shard_plan *p;
    uint64_t total;           /* weight of every level-0 tile */
    uint64_t cum;             /* weight visited so far */
    uint8_t *want0;
};

/* Valid pixels of tile (tx,ty) of level 0: its weight. */
static uint64_t tile_area(const struct gv_level *l, uint32_t tx, uint32_t ty)
{
    uint32_t w = l->width - tx * GV_STEP, h = l->height - ty * GV_STEP;
    return (uint64_t)(w < GV_TILE ? w : GV_TILE) * (h < GV_TILE ? h : GV_TILE);
}

/* Visit the block of 2^s x 2^s level-0 tiles at block coordinates (bx,by)
 * in Z order: upper-left, upper-right, lower-left, lower-right. */
static void walk(struct walk *w, uint32_t bx, uint32_t by, int s)
{
    const struct gv_level *l = &w->g->level[0];
    if (((uint64_t)bx << s) >= l->tiles_x || ((uint64_t)by << s) >= l->tiles_y)
        return;
    if (s > 0) {
        for (uint32_t q = 0; q < 4; q++)
            walk(w, 2 * bx + (q & 1), 2 * by + (q >> 1), s - 1);
        return;
    }
    uint64_t a = tile_area(l, bx, by);
    /* The shard whose share of [0, total) holds this tile's midpoint. */
    unsigned __int128 mid2 = (unsigned __int128)(2 * w->cum + a) *
                             (unsigned)w->p->count;
    uint64_t shard = (uint64_t)(mid2 / ((unsigned __int128)2 * w->total));
    if (shard == (uint64_t)w->p->index)
        w->want0[(uint64_t)by * l->tiles_x + bx] = 1;
    w->cum += a;
}

int gv_shard_plan_init(struct gv_shard_plan *p, const struct gv_geometry *g,
                       int index, int count, struct gv_error *err)
{
    memset(p, 0, sizeof *p);
    if (count < 1 || count > GV_SHARD_MAX || index < 0 || index >= count)
        return gv_fail(err, GV_EINVAL, "shard: %d/%d is not a shard (want "
                       "I/N with 0 <= I < N <= %d)", index, count, GV_SHARD_MAX);
    p->index = index;
    p->count = count;
    if (g->root == 0)
        return 0;   /* no tiles: the root is the whole store */
    for (int k = 0; k < g->root; k++) {
        const struct gv_level *l = &g->level[k];
        p->want[k] = calloc((size_t)l->tiles_x * l->tiles_y, 1);
        if (!p->want[k]) {
            gv_shard_plan_free(p);
            return gv_fail(err, GV_ENOMEM, "shard: out of memory for the plan");
        }
    }
    const struct gv_level *l0 = &g->level[0];
    struct walk w = {.g = g, .p = p, .want0 = p->want[0]};
    for (uint32_t ty = 0; ty < l0->tiles_y; ty++)
        for (uint32_t tx = 0; tx < l0->tiles_x; tx++)
            w.total += tile_area(l0, tx, ty);
    int s = 0;
    while ((1ull << s) < l0->tiles_x || (1ull << s) < l0->tiles_y)
        s++;
    walk(&w, 0, 0, s);
    /* Ancestors: a wanted tile wants its parent, which exists by the
     * tiles_x rule of docs/FORMAT.md section 2 (geometry.c). */
    for (int k = 0; k + 1 < g->root; k++) {
        const struct gv_level *l = &g->level[k], *u = &g->level[k + 1];
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++)
                if (p->want[k][(uint64_t)ty * l->tiles_x + tx])
                    p->want[k + 1][(uint64_t)(ty / 2) * u->tiles_x + tx / 2] = 1;
    }
    for (int k = 0; k < g->root; k++) {
        const struct gv_level *l = &g->level[k];
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                if (!p->want[k][(uint64_t)ty * l->tiles_x + tx])
                    continue;
                uint32_t vw = l->width - tx * GV_STEP, vh = l->height - ty * GV_STEP;
                p->tiles++;
                if (k == 0)
                    p->own_tiles++;
                p->samples += (uint64_t)(vw < GV_TILE ? vw : GV_TILE) *
                              (vh < GV_TILE ? vh : GV_TILE) * (unsigned)g->channels;
            }
    }
    return 0;
}

void gv_shard_plan_free(struct gv_shard_plan *p)
{
    for (int k = 0; k < GV_MAX_LEVELS; k++) {
        free(p->want[k]);
        p->want[k] = NULL;
    }
}

int gv_shard_plan_wants(const struct gv_shard_plan *p,
                        const struct gv_geometry *g, int level, uint32_t tx,
                        uint32_t ty)
{
    if (level < 0 || level >= g->root || !p->want[level])
        return 0;
    const struct gv_level *l = &g->level[level];
    if (tx >= l->tiles_x || ty >= l->tiles_y)
        return 0;
    return p->want[level][(uint64_t)ty * l->tiles_x + tx] != 0;
}

int gv_shard_plan_wants_page(const struct gv_shard_plan *p,
                             const struct gv_geometry *g, int level,
                             uint32_t px, uint32_t py)
{
    for (uint32_t j = 0; j < GV_PAGE_TILES; j++)
        for (uint32_t i = 0; i < GV_PAGE_TILES; i++)
            if (gv_shard_plan_wants(p, g, level, px * GV_PAGE_TILES + i,
                                    py * GV_PAGE_TILES + j))
                return 1;
    return 0;
}

static int parse_part(const char *s, const char *end, long *out)
{
    if (s == end || end - s > 6)
        return -1;
    long v = 0;
    for (const char *c = s; c < end; c++) {
        if (*c < '0' || *c > '9')
            return -1;
        v = v * 10 + (*c - '0');
    }
    *out = v;
    return 0;
}

int gv_shard_parse(const char *s, int *index, int *count)
{
    const char *slash = strchr(s, '/');
    long i, n;
    if (!slash || parse_part(s, slash, &i) < 0 ||
        parse_part(slash + 1, slash + strlen(slash), &n) < 0)
        return -1;
    if (n < 1 || n > GV_SHARD_MAX || i >= n)
        return -1;
    *index = (int)i;
    *count = (int)n;
    return 0;
}
