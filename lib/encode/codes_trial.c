/*
 * codes_trial.c - choosing a sample store's half-step by trial (see
 * codes_trial.h).  Each try codes the sample's tiles level by level from
 * the root down, every tile once (neighbouring level-0 tiles share their
 * ancestors), on the pool; a tile is read from the scratch strips row by
 * row and clamp-padded as pass 2 cuts it.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "encode/codes_pass.h"
#include "encode/codes_trial.h"
#include "encode/strips.h"

#define SAMPLE_MAX 8
#define MAX_TRIES 16
#define PLANE ((size_t)GV_HT_SAMPLES)

/* One tile of a try: where it is, its parent's index one level up (-1:
 * the root tile), its decoded planes, its level-0 squared error. */
struct trial_tile {
    int level;
    uint32_t tx, ty;
    int parent;
    uint16_t *dec;       /* c planes */
    double sse;
    uint64_t pixels;
    int failed;
};

struct trial_run {
    const struct gv_codes_trial *t;
    struct trial_tile *tiles;
    int first, e;        /* the level being coded: tiles from `first` */
    struct gv_error err;
};

/* Tile (tx,ty) of `level` into c planes, clamp-padded to 513 x 513. */
static int read_tile(const struct gv_codes_trial *t, int level, uint32_t tx,
                     uint32_t ty, uint16_t *rows, uint16_t *planes,
                     struct gv_error *err)
{
    const struct gv_level *l = &t->g->level[level];
    const int c = t->c;
    const uint32_t p = tx / GV_PAGE_TILES, x0 = (tx % GV_PAGE_TILES) * GV_STEP;
    const uint32_t sw = gv_strip_width(l->width, p);
    const uint32_t avail = sw - x0 < GV_HT_SIDE ? sw - x0 : GV_HT_SIDE;
    for (uint32_t v = 0; v < GV_HT_SIDE; v++) {
        uint32_t y = ty * GV_STEP + v;
        y = y < l->height ? y : l->height - 1;
        uint16_t *row = rows + (size_t)v * GV_HT_SIDE * c;
        if (gv_spill_read(t->spill, row, (size_t)avail * c * 2,
                          gv_strip_at(l, t->orig_base[level], 2 * (size_t)c, p, y) +
                              (uint64_t)x0 * c * 2, err) < 0)
            return -1;
        for (uint32_t u = avail; u < GV_HT_SIDE; u++)
            memcpy(row + (size_t)u * c, row + (size_t)(avail - 1) * c, 2 * (size_t)c);
    }
    for (int k = 0; k < c; k++)
        gv_samples_plane_get(rows, PLANE, c, k, planes + (size_t)k * PLANE);
    return 0;
}

/* Pool job: code tile first + item at r->e against its decoded parent. */
static void code_tile(void *ctx, size_t item, int worker)
{
    (void)worker;
    struct trial_run *r = ctx;
    const struct gv_codes_trial *t = r->t;
    struct trial_tile *tt = &r->tiles[r->first + (int)item];
    const struct gv_level *l = &t->g->level[tt->level];
    const int c = t->c;
    uint16_t *rows = malloc(PLANE * c * sizeof *rows);
    uint16_t *orig = malloc(PLANE * c * sizeof *orig);
    uint8_t *buf = malloc(GV_HT_BUF_MAX);
    struct gv_error err = {0};
    tt->failed = 1;
    if (rows && orig && buf && tt->dec &&
        read_tile(t, tt->level, tt->tx, tt->ty, rows, orig, &err) == 0) {
        const int w = (int)gv_tile_span(l->width, tt->tx);
        const int h = (int)gv_tile_span(l->height, tt->ty);
        const uint16_t *parent = tt->parent < 0 ? t->root_tile : r->tiles[tt->parent].dec;
        tt->failed = 0;
        tt->sse = 0;
        tt->pixels = 0;
        for (int k = 0; k < c && !tt->failed; k++) {
            const uint16_t *o = orig + (size_t)k * PLANE;
            uint16_t *d = tt->dec + (size_t)k * PLANE;
            if (!gv_height_tile_encode(o, parent + (size_t)k * PLANE,
                                       (int)(tt->tx & 1), (int)(tt->ty & 1),
                                       r->e, w, h, buf, d))
                tt->failed = 1;
            else if (tt->level == 0)
                tt->sse += gv_codes_level0_sse(l, tt->tx, tt->ty, o, d, &tt->pixels);
        }
    } else if (err.code != GV_OK) {
        r->err = err;
    }
    free(rows);
    free(orig);
    free(buf);
}

/* Level 0's PSNR over the sample at half-step e.  0 or -1. */
static int try_e(struct trial_run *r, int ntiles, const int *level_first,
                 int e, double *psnr, struct gv_error *err)
{
    const struct gv_geometry *g = r->t->g;
    r->e = e;
    for (int k = g->root - 1; k >= 0; k--) {
        r->first = level_first[k];
        gv_pool_run(r->t->pool, code_tile, r, (size_t)(level_first[k + 1] - level_first[k]));
        for (int i = level_first[k]; i < level_first[k + 1]; i++)
            if (r->tiles[i].failed)
                return r->err.code != GV_OK ? (*err = r->err, -1)
                     : gv_fail(err, GV_ENOMEM, "trial: out of memory");
    }
    double sse = 0;
    uint64_t n = 0;
    for (int i = 0; i < ntiles; i++)
        if (r->tiles[i].level == 0) {
            sse += r->tiles[i].sse;
            n += r->tiles[i].pixels;
        }
    *psnr = gv_codes_psnr(sse, (double)n, r->t->peak);
    return 0;
}

/* The sample's tiles, level 0 first, then each level's distinct
 * ancestors; level_first[k] is where level k's start.  Returns the count. */
static int plan(const struct gv_geometry *g, struct trial_tile *tiles,
                int *level_first)
{
    const struct gv_level *l0 = &g->level[0];
    int n = 0;
    if ((uint64_t)l0->tiles_x * l0->tiles_y <= SAMPLE_MAX) {
        for (uint32_t ty = 0; ty < l0->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l0->tiles_x; tx++)
                tiles[n++] = (struct trial_tile){.tx = tx, .ty = ty};
    } else {
        /* 4 x 2 on an even grid (2 x 4 for a tall image) */
        const int cols = l0->tiles_x >= l0->tiles_y ? 4 : 2, rows = SAMPLE_MAX / cols;
        for (int j = 0; j < rows; j++)
            for (int i = 0; i < cols; i++) {
                uint32_t tx = (uint32_t)(((2 * i + 1) * (uint64_t)l0->tiles_x) / (2 * cols));
                uint32_t ty = (uint32_t)(((2 * j + 1) * (uint64_t)l0->tiles_y) / (2 * rows));
                int dup = 0;
                for (int m = 0; m < n; m++)
                    dup |= tiles[m].tx == tx && tiles[m].ty == ty;
                if (!dup)
                    tiles[n++] = (struct trial_tile){.tx = tx, .ty = ty};
            }
    }
    level_first[0] = 0;
    for (int k = 1; k < g->root; k++) {
        level_first[k] = n;
        for (int i = level_first[k - 1]; i < level_first[k]; i++) {
            uint32_t tx = tiles[i].tx / 2, ty = tiles[i].ty / 2;
            int at = -1;
            for (int m = level_first[k]; m < n; m++)
                if (tiles[m].tx == tx && tiles[m].ty == ty)
                    at = m;
            if (at < 0) {
                tiles[n] = (struct trial_tile){.level = k, .tx = tx, .ty = ty};
                at = n++;
            }
            tiles[i].parent = at;
        }
    }
    level_first[g->root] = n;
    for (int i = level_first[g->root > 0 ? g->root - 1 : 0]; i < n; i++)
        tiles[i].parent = -1;
    return n;
}

int gv_codes_trial(const struct gv_codes_trial *t, double target, int e0,
                   int *e, int *tries, double *psnr, struct gv_error *err)
{
    const struct gv_geometry *g = t->g;
    *e = e0;
    *tries = 0;
    *psnr = 0;
    if (g->root == 0)   /* the root alone: nothing is coded */
        return 0;
    const int cap = SAMPLE_MAX * g->root;
    struct trial_tile *tiles = calloc((size_t)cap, sizeof *tiles);
    int level_first[GV_MAX_LEVELS + 1];
    if (!tiles)
        return gv_fail(err, GV_ENOMEM, "trial: out of memory");
    const int n = plan(g, tiles, level_first);
    int rc = 0;
    for (int i = 0; i < n && rc == 0; i++)
        if (!(tiles[i].dec = malloc(PLANE * t->c * sizeof *tiles[i].dec)))
            rc = gv_fail(err, GV_ENOMEM, "trial: out of memory");
    struct trial_run r = {.t = t, .tiles = tiles};
    /* lo reaches the target (or is 0), hi does not (or is past the top). */
    int lo = -1, hi = -1, cur = e0;
    double p = 0, plo = 99.0;
    while (rc == 0 && *tries < MAX_TRIES) {
        if ((rc = try_e(&r, n, level_first, cur, &p, err)) < 0)
            break;
        ++*tries;
        if (p >= target) {
            lo = cur;
            plo = p;
        } else {
            hi = cur;
        }
        if (lo < 0)
            cur = cur / 2;                   /* too coarse: halve */
        else if (hi < 0)
            cur = 2 * cur + 1;               /* fine enough: double */
        else
            cur = lo + (hi - lo) / 2;        /* bisect */
        if (lo < 0 && hi == 0) {             /* even lossless misses */
            lo = 0;
            plo = p;
            break;
        }
        if (hi < 0 && lo >= GV_HT_MAX_E) {
            lo = GV_HT_MAX_E;
            break;
        }
        if (cur > GV_HT_MAX_E)
            cur = GV_HT_MAX_E;
        if (lo >= 0 && hi >= 0 && hi - lo <= (lo / 32 > 1 ? lo / 32 : 1))
            break;
    }
    if (rc == 0) {
        *e = lo >= 0 ? lo : 0;
        *psnr = plo;
    }
    for (int i = 0; i < n; i++)
        free(tiles[i].dec);
    free(tiles);
    return rc;
}
