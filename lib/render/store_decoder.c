/*
 * store_decoder.c - recursive tile decoding over a tile cache (see
 * store_decoder.h).
 *
 * A tile is taken from the cache or claimed there (tile_cache.h): the
 * claimer pins the parent (decoding it the same way first), reads the
 * page, decodes into the claimed entry and publishes it, so other threads
 * that want the same tile wait for this decode instead of repeating it.
 * A page read for one tile is kept while its neighbours are decoded.
 * gv_decoder_copy_region is the one tile walk behind both region readers
 * (decode_region.c for images, height_region.c for height and sample
 * codes): it copies pixel units, C bytes for an image and C 2-byte codes
 * for a height or sample store.  A level-0 tile that the region covers
 * whole is decoded into a buffer the cache lends, not into the cache: no
 * tile is decoded from a level-0 tile, and the request that covers one
 * whole (an IIIF tile at full size, an export) seldom comes again but
 * through the output cache.  So a pass over level 0 neither takes fresh
 * memory for every tile (its page faults were most of a cold IIIF pass's
 * CPU, bench/README.md 2026-12-03) nor evicts the ancestors it needs.
 * The time spent reading pages, decoding and in the cache is summed per
 * decoder (gv_decoder_times; one clock read before and after each).
 */
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "render/store_decoder.h"
#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "codec/tile.h"

struct gv_decoder {
    const struct gv_store *store;
    const struct gv_store_info *info;
    int channels;        /* bytes per pixel: 2 C for a store of codes */
    int kind;            /* header.kind: GV_KIND_HEIGHT (FORMAT.md section
                          * 12) and GV_KIND_SAMPLES (13) hold codes */
    struct gv_tile_cache *cache;
    int owns_cache;
    uint64_t store_key;
    struct gv_tile_entry *held;   /* the tile gv_decoder_tile returned last */
    uint8_t *page;       /* last page read */
    size_t page_len;
    int page_level;
    uint32_t page_px, page_py;
    struct gv_decode_times times;
};

/* The monotonic clock in nanoseconds. */
static uint64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec;
}

void gv_decoder_times(struct gv_decoder *d, struct gv_decode_times *t,
                      int reset)
{
    *t = d->times;
    if (reset)
        memset(&d->times, 0, sizeof d->times);
}

struct gv_decoder *gv_decoder_new_shared(const struct gv_store *s,
                                         struct gv_tile_cache *cache,
                                         uint64_t store_key)
{
    struct gv_decoder *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->store = s;
    d->info = gv_store_info(s);
    d->kind = d->info->header.kind;
    d->channels = d->info->geometry.channels *
                  (gv_header_codes(&d->info->header) ? 2 : 1);
    d->cache = cache;
    d->store_key = store_key;
    d->page_level = -1;
    return d;
}

struct gv_decoder *gv_decoder_new(const struct gv_store *s, size_t cache_bytes)
{
    struct gv_tile_cache *c = gv_tile_cache_new(cache_bytes);
    struct gv_decoder *d = c ? gv_decoder_new_shared(s, c, 0) : NULL;
    if (!d) {
        gv_tile_cache_free(c);
        return NULL;
    }
    d->owns_cache = 1;
    return d;
}

void gv_decoder_free(struct gv_decoder *d)
{
    if (!d)
        return;
    gv_tile_cache_release(d->cache, d->held);
    if (d->owns_cache)
        gv_tile_cache_free(d->cache);
    free(d->page);
    free(d);
}

void gv_decoder_idle(struct gv_decoder *d)
{
    gv_tile_cache_release(d->cache, d->held);
    d->held = NULL;
}

const struct gv_store *gv_decoder_store(const struct gv_decoder *d)
{
    return d->store;
}

void gv_root_tile(const uint8_t *root, uint32_t w, uint32_t h, int channels,
                  uint8_t *tile)
{
    const size_t row = (size_t)GV_TILE * channels;
    for (uint32_t y = 0; y < GV_TILE; y++) {
        const uint8_t *src = root + (size_t)(y < h ? y : h - 1) * w * channels;
        uint8_t *dst = tile + y * row;
        for (uint32_t x = 0; x < GV_TILE; x++)
            memcpy(dst + x * channels, src + (size_t)(x < w ? x : w - 1) * channels,
                   (size_t)channels);
    }
}

static int load_page(struct gv_decoder *d, int level, uint32_t px, uint32_t py,
                     struct gv_error *err)
{
    if (d->page && d->page_level == level && d->page_px == px && d->page_py == py)
        return 0;
    free(d->page);
    d->page = NULL;
    d->page_level = -1;
    const uint64_t t0 = now_ns();
    int rc = gv_store_read_page(d->store, level, px, py, &d->page,
                                &d->page_len, err);
    d->times.page_ns += now_ns() - t0;
    if (rc < 0)
        return -1;
    d->page_level = level;
    d->page_px = px;
    d->page_py = py;
    return 0;
}

static struct gv_tile_entry *tile_entry(struct gv_decoder *d, int level,
                                        uint32_t tx, uint32_t ty,
                                        struct gv_error *err);

/* Fill the claimed entry `out` with tile (tx,ty) of `level` (a tiled level
 * below the root): decode it from its parent.  0 or -1. */
static int decode_into(struct gv_decoder *d, int level, uint32_t tx,
                       uint32_t ty, uint8_t *out, struct gv_error *err)
{
    struct gv_tile_entry *parent = tile_entry(d, level + 1, tx / 2, ty / 2, err);
    if (!parent)
        return -1;
    const uint8_t *buf;
    size_t len;
    int rc = -1;
    uint64_t t0 = 0;
    if (load_page(d, level, tx / GV_PAGE_TILES, ty / GV_PAGE_TILES, err) == 0 &&
        gv_page_tile(d->page, d->page_len, d->channels, (int)(tx % GV_PAGE_TILES),
                     (int)(ty % GV_PAGE_TILES), &buf, &len, err) == 0 &&
        (t0 = now_ns(), d->kind == GV_KIND_HEIGHT
             ? gv_height_tile_decode(buf, len,
                                     (const uint16_t *)(void *)gv_tile_entry_pixels(parent),
                                     (int)(tx & 1), (int)(ty & 1),
                                     (uint16_t *)(void *)out, err)
             : d->kind == GV_KIND_SAMPLES
             ? gv_samples_tile_decode(buf, len, d->info->geometry.channels,
                                      (const uint16_t *)(void *)gv_tile_entry_pixels(parent),
                                      (int)(tx & 1), (int)(ty & 1),
                                      (uint16_t *)(void *)out, err)
             : gv_tile_decode(buf, len, d->channels, gv_tile_entry_pixels(parent),
                              (int)(tx & 1), (int)(ty & 1), out, err)) == 0)
        rc = 0;
    if (t0)
        d->times.decode_ns += now_ns() - t0;
    gv_tile_cache_release(d->cache, parent);
    return rc;
}

/* Tile (tx,ty) of `level`, pinned in the cache (release it), or NULL. */
static struct gv_tile_entry *tile_entry(struct gv_decoder *d, int level,
                                        uint32_t tx, uint32_t ty,
                                        struct gv_error *err)
{
    const struct gv_geometry *g = &d->info->geometry;
    if (level == g->root) {
        if (tx || ty) {
            gv_fail(err, GV_ENOTFOUND, "decode: no root tile %u,%u", tx, ty);
            return NULL;
        }
    } else if (level < 0 || level > g->root || tx >= g->level[level].tiles_x ||
               ty >= g->level[level].tiles_y) {
        gv_fail(err, GV_ENOTFOUND, "decode: no tile %d/%u/%u", level, tx, ty);
        return NULL;
    }
    struct gv_tile_key k = {d->store_key, level, tx, ty};
    struct gv_tile_entry *e;
    const uint64_t t0 = now_ns();
    int rc = gv_tile_cache_acquire(d->cache, &k, gv_tile_bytes(d->channels), &e, err);
    d->times.wait_ns += now_ns() - t0;
    if (rc != 0)
        return rc > 0 ? e : NULL;
    uint8_t *px = gv_tile_entry_pixels(e);
    if (level == g->root) {
        const uint64_t t1 = now_ns();
        uint32_t w, h;
        const uint8_t *root = gv_store_root(d->store, 0, &w, &h);
        gv_root_tile(root, w, h, d->channels, px);
        d->times.decode_ns += now_ns() - t1;
    } else if (decode_into(d, level, tx, ty, px, err) < 0) {
        gv_tile_cache_fail(d->cache, e, err);
        return NULL;
    }
    gv_tile_cache_publish(d->cache, e);
    return e;
}

int gv_decoder_tile(struct gv_decoder *d, int level, uint32_t tx, uint32_t ty,
                    const uint8_t **pixels, struct gv_error *err)
{
    /* The new tile is pinned before the old one is let go, so asking for
     * the same tile again never decodes it again. */
    struct gv_tile_entry *e = tile_entry(d, level, tx, ty, err);
    gv_tile_cache_release(d->cache, d->held);
    d->held = e;
    if (!e)
        return -1;
    *pixels = gv_tile_entry_pixels(e);
    return 0;
}

int gv_decoder_copy_region(struct gv_decoder *d, const char *module,
                           int level, uint32_t x, uint32_t y, uint32_t w,
                           uint32_t h, void *dst, struct gv_error *err)
{
    const struct gv_geometry *g = &d->info->geometry;
    const int c = d->channels;
    uint8_t *out = dst;
    const size_t orow = (size_t)w * c;
    uint32_t lw, lh;
    if (gv_level_size(g, level, &lw, &lh) < 0)
        return gv_fail(err, GV_EINVAL, "%s: no level %d (levels 0..%d)",
                       module, level, g->root + g->root_mips - 1);
    if (w == 0 || h == 0 || x >= lw || y >= lh || w > lw - x || h > lh - y)
        return gv_fail(err, GV_EINVAL, "%s: region %u,%u %ux%u is outside "
                       "level %d (%ux%u)", module, x, y, w, h, level, lw, lh);
    if (level >= g->root) {
        const uint8_t *mip = gv_store_root(d->store, level - g->root, &lw, &lh);
        for (uint32_t r = 0; r < h; r++)
            memcpy(out + r * orow, mip + ((size_t)(y + r) * lw + x) * c, orow);
        return 0;
    }
    const struct gv_level *l = &g->level[level];
    uint32_t t0x = x / GV_STEP, t1x = (x + w - 1) / GV_STEP;
    uint32_t t0y = y / GV_STEP, t1y = (y + h - 1) / GV_STEP;
    if (t1x >= l->tiles_x) t1x = l->tiles_x - 1;
    if (t1y >= l->tiles_y) t1y = l->tiles_y - 1;
    if (t0x > t1x) t0x = t1x;
    if (t0y > t1y) t0y = t1y;
    const size_t tile_bytes = gv_tile_bytes(c);
    uint8_t *lent = NULL;
    int rc = 0;
    for (uint32_t ty = t0y; ty <= t1y && rc == 0; ty++)
        for (uint32_t tx = t0x; tx <= t1x; tx++) {
            /* Pixels this tile is the source of, clipped to the region. */
            uint32_t sx0 = tx * GV_STEP, sy0 = ty * GV_STEP;
            uint32_t sx1 = tx + 1 == l->tiles_x ? lw : sx0 + GV_STEP;
            uint32_t sy1 = ty + 1 == l->tiles_y ? lh : sy0 + GV_STEP;
            uint32_t ax = x > sx0 ? x : sx0, bx = x + w < sx1 ? x + w : sx1;
            uint32_t ay = y > sy0 ? y : sy0, by = y + h < sy1 ? y + h : sy1;
            if (ax >= bx || ay >= by)
                continue;
            const uint8_t *px;
            if (level == 0 && ax == sx0 && bx == sx1 && ay == sy0 && by == sy1) {
                if (!lent && !(lent = gv_tile_cache_lend(d->cache, tile_bytes))) {
                    rc = gv_fail(err, GV_ENOMEM, "%s: out of memory", module);
                    break;
                }
                if (decode_into(d, 0, tx, ty, lent, err) < 0) {
                    rc = -1;
                    break;
                }
                px = lent;
            } else if (gv_decoder_tile(d, level, tx, ty, &px, err) < 0) {
                rc = -1;
                break;
            }
            for (uint32_t yy = ay; yy < by; yy++)
                memcpy(out + (size_t)(yy - y) * orow + (size_t)(ax - x) * c,
                       px + ((size_t)(yy - sy0) * GV_TILE + (ax - sx0)) * c,
                       (size_t)(bx - ax) * c);
        }
    gv_tile_cache_give_back(d->cache, lent, tile_bytes);
    return rc;
}

int gv_decoder_pin_levels(struct gv_decoder *d, uint64_t budget,
                          struct gv_tile_entry ***pins, int *npins,
                          uint64_t *bytes, struct gv_error *err)
{
    const struct gv_geometry *g = &d->info->geometry;
    const uint64_t tile = gv_tile_bytes(d->channels);
    /* The levels that fit, coarsest first: count their tiles. */
    uint64_t used = 0;
    size_t n = 0;
    int finest = g->root + 1;
    for (int level = g->root; level >= 0; level--) {
        uint64_t tiles = level == g->root ? 1 :
            (uint64_t)g->level[level].tiles_x * g->level[level].tiles_y;
        if (used + tiles * tile > budget)
            break;
        used += tiles * tile;
        n += (size_t)tiles;
        finest = level;
    }
    *pins = NULL;
    *npins = 0;
    *bytes = 0;
    if (n == 0)
        return 0;
    struct gv_tile_entry **p = malloc(n * sizeof *p);
    if (!p)
        return gv_fail(err, GV_ENOMEM, "decode: out of memory");
    size_t k = 0;
    for (int level = g->root; level >= finest; level--) {
        uint32_t tx_n = level == g->root ? 1 : g->level[level].tiles_x;
        uint32_t ty_n = level == g->root ? 1 : g->level[level].tiles_y;
        for (uint32_t ty = 0; ty < ty_n; ty++)
            for (uint32_t tx = 0; tx < tx_n; tx++) {
                struct gv_tile_entry *e = tile_entry(d, level, tx, ty, err);
                if (!e) {
                    while (k > 0)
                        gv_tile_cache_release(d->cache, p[--k]);
                    free(p);
                    return -1;
                }
                p[k++] = e;
            }
    }
    *pins = p;
    *npins = (int)k;
    *bytes = used;
    return 0;
}
