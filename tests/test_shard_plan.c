/*
 * test_shard_plan.c - the tile sets of `gigaview encode --shard I/N`.
 *
 * For a range of image shapes and shard counts: every level-0 tile
 * belongs to exactly one shard, a shard wants exactly its level-0 tiles
 * and their ancestors (so the shards together cover every tile, and each
 * has the parent of everything it encodes), at most one tile per level is
 * shared per cut, and the level-0 pixels are split evenly to within one
 * tile.  Also the I/N parser and the sizes whose parents need the third
 * term of the tiles_x rule (1026 wide), which shard like any other.
 */
#include <stdlib.h>
#include <string.h>

#include "store/geometry.h"
#include "encode/shard_plan.h"
#include "util.h"

static uint64_t area(const struct gv_level *l, uint32_t tx, uint32_t ty)
{
    uint32_t w = l->width - tx * GV_STEP, h = l->height - ty * GV_STEP;
    return (uint64_t)(w < GV_TILE ? w : GV_TILE) * (h < GV_TILE ? h : GV_TILE);
}

/* Check the n plans of a w x h image; returns 1 when all properties hold. */
static int check_plans(uint32_t w, uint32_t h, int n)
{
    struct gv_geometry g;
    if (gv_geometry_init(&g, w, h, 3, GV_ROOT_MAX) < 0)
        fail("geometry %ux%u", w, h);
    struct gv_shard_plan *p = calloc((size_t)n, sizeof *p);
    if (!p)
        fail("out of memory");
    struct gv_error err = {0};
    for (int i = 0; i < n; i++)
        if (gv_shard_plan_init(&p[i], &g, i, n, &err) < 0)
            fail("plan %d/%d of %ux%u: %s", i, n, w, h, err.text);
    int ok = 1;
    uint64_t shared = 0, total = 0;
    uint64_t *share = calloc((size_t)n, sizeof *share);
    if (!share)
        fail("out of memory");
    for (int k = 0; k < g.root; k++) {
        const struct gv_level *l = &g.level[k];
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                int owners = 0;
                for (int i = 0; i < n; i++) {
                    int want = gv_shard_plan_wants(&p[i], &g, k, tx, ty);
                    owners += want;
                    if (k == 0 && want)
                        share[i] += area(l, tx, ty);
                    if (k > 0) {
                        /* Wanted exactly when a child is (the children of
                         * (tx,ty) are 2tx..2tx+1 x 2ty..2ty+1). */
                        int child = 0;
                        for (uint32_t q = 0; q < 4; q++)
                            child |= gv_shard_plan_wants(&p[i], &g, k - 1,
                                                         2 * tx + (q & 1),
                                                         2 * ty + (q >> 1));
                        ok &= want == child;
                    }
                }
                if (k == 0)
                    ok &= owners == 1;
                else
                    ok &= owners >= 1;
                if (owners > 1)
                    shared += (uint64_t)owners - 1;
                if (k == 0)
                    total += area(l, tx, ty);
            }
    }
    /* A cut lies inside one tile per level above 0. */
    if (g.root > 1)
        ok &= shared <= (uint64_t)(n - 1) * (uint64_t)(g.root - 1);
    for (int i = 0; i < n; i++) {
        uint64_t fair = total / (uint64_t)n;
        ok &= share[i] + (uint64_t)GV_TILE * GV_TILE >= fair &&
              share[i] <= fair + (uint64_t)GV_TILE * GV_TILE;
        gv_shard_plan_free(&p[i]);
    }
    free(share);
    free(p);
    return ok;
}

int main(void)
{
    static const struct { uint32_t w, h; } sizes[] = {
        {1100, 700}, {4700, 1100}, {513, 513}, {600, 600}, {70000, 1},
        {1, 70000}, {40000, 20000}, {9000, 9000}, {3000, 20000},
        {1026, 2050}, {4098, 1026},
    };
    static const int counts[] = {1, 2, 3, 4, 7, 16, 100};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        int ok = 1;
        for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++)
            ok &= check_plans(sizes[s].w, sizes[s].h, counts[c]);
        check(ok, "%ux%u: disjoint level 0, closed under parents, even split",
              sizes[s].w, sizes[s].h);
    }

    struct gv_geometry g;
    struct gv_shard_plan p;
    struct gv_error err = {0};
    gv_geometry_init(&g, 300, 200, 3, GV_ROOT_MAX);
    check(gv_shard_plan_init(&p, &g, 1, 2, &err) == 0 && p.tiles == 0,
          "an image that is all root has no tiles to shard");
    gv_shard_plan_free(&p);
    gv_geometry_init(&g, 1100, 700, 3, GV_ROOT_MAX);
    gv_error_clear(&err);
    check(gv_shard_plan_init(&p, &g, 2, 2, &err) < 0 &&
          gv_shard_plan_init(&p, &g, -1, 2, &err) < 0 &&
          gv_shard_plan_init(&p, &g, 0, 0, &err) < 0, "shard index and count checked");
    /* 1026 wide: 3 tiles at level 0, 2 at level 1 (every tile has a
     * parent), so it shards like any other size.  Shard 0 of 2 takes the
     * full 513x513 tile 0,0 (the even split of the pixels, to within a
     * tile) and its parent. */
    gv_geometry_init(&g, 1026, 600, 3, GV_ROOT_MAX);
    int rc = gv_shard_plan_init(&p, &g, 0, 2, &err);
    check(rc == 0 && p.own_tiles == 1 && p.tiles == 2 && gv_shard_plan_wants(&p, &g, 0, 0, 0) &&
              gv_shard_plan_wants(&p, &g, 1, 0, 0),
          "1026 wide: planned like any other size (shard 0/2: %llu level-0 tile, "
          "%llu in all)", (unsigned long long)p.own_tiles, (unsigned long long)p.tiles);
    gv_shard_plan_free(&p);

    int i, n, ok = 1;
    ok &= gv_shard_parse("0/1", &i, &n) == 0 && i == 0 && n == 1;
    ok &= gv_shard_parse("3/4", &i, &n) == 0 && i == 3 && n == 4;
    ok &= gv_shard_parse("65534/65535", &i, &n) == 0 && i == 65534;
    static const char *bad[] = {"4/4", "-1/4", "1/0", "a/b", "1/", "/2", "1/2x",
                                "0/65536", "1", "", " 1/2", "1/+2", "0/0"};
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++)
        ok &= gv_shard_parse(bad[b], &i, &n) < 0;
    check(ok, "I/N parser: accepts 0/1, 3/4, 65534/65535; refuses 13 bad forms");
    return tap_done();
}
