/*
 * gpu_cache.c - recursive GPU tile decoding with a byte-bounded LRU of
 * textures (gpu_cache.h).
 *
 * Entries live in a growable array scanned linearly: a GPU holds at most a
 * few thousand 1.3 MB textures, and a scan is far cheaper than a decode.
 * Eviction runs after each insertion and never removes the entry just
 * inserted, so the parent of a tile being decoded (touched just before)
 * survives until the child is made, whatever the budget.
 */
#include <stdlib.h>
#include <string.h>

#include "render/store_decoder.h"
#include "gpu/gpu_cache.h"
#include "codec/tile.h"

struct entry {
    int level;
    uint32_t tx, ty;
    uint32_t handle;
    uint64_t stamp;
};

struct gv_gpu_cache {
    struct gv_gpu_decoder *dec;
    struct gv_geometry geo;
    uint8_t *root_tile;             /* padded root tile, 513x513xC */
    size_t budget;
    gv_tile_fetch_fn fetch;
    void *ctx;
    struct entry *e;
    size_t n, cap;
    uint64_t clock;
    struct gv_gpu_cache_stats st;
};

struct gv_gpu_cache *gv_gpu_cache_new(struct gv_gpu_decoder *d,
                                      const struct gv_geometry *g,
                                      const uint8_t *root, uint32_t root_w,
                                      uint32_t root_h, size_t budget,
                                      gv_tile_fetch_fn fetch, void *ctx,
                                      struct gv_error *err)
{
    if (root_w == 0 || root_h == 0 || root_w > GV_TILE || root_h > GV_TILE) {
        gv_fail(err, GV_EINVAL, "gpu cache: bad root size %ux%u", root_w, root_h);
        return NULL;
    }
    struct gv_gpu_cache *c = calloc(1, sizeof *c);
    if (!c || !(c->root_tile = malloc(gv_tile_bytes(g->channels)))) {
        free(c);
        gv_fail(err, GV_ENOMEM, "gpu cache: out of memory");
        return NULL;
    }
    c->dec = d;
    c->geo = *g;
    gv_root_tile(root, root_w, root_h, g->channels, c->root_tile);
    c->budget = budget;
    c->fetch = fetch;
    c->ctx = ctx;
    return c;
}

void gv_gpu_cache_free(struct gv_gpu_cache *c)
{
    if (!c)
        return;
    for (size_t i = 0; i < c->n; i++)
        gv_gpu_release(c->dec, c->e[i].handle);
    free(c->e);
    free(c->root_tile);
    free(c);
}

static struct entry *lookup(struct gv_gpu_cache *c, int level, uint32_t tx,
                            uint32_t ty)
{
    for (size_t i = 0; i < c->n; i++)
        if (c->e[i].level == level && c->e[i].tx == tx && c->e[i].ty == ty) {
            c->e[i].stamp = ++c->clock;
            return &c->e[i];
        }
    return NULL;
}

/* Delete least recently used textures until within budget, sparing the
 * newest entry, and update the tile count. */
static void evict(struct gv_gpu_cache *c)
{
    while (c->n > 1 && c->st.bytes > c->budget) {
        size_t old = 0;
        for (size_t i = 1; i < c->n; i++)
            if (c->e[i].stamp < c->e[old].stamp)
                old = i;
        gv_gpu_release(c->dec, c->e[old].handle);
        c->e[old] = c->e[--c->n];
        c->st.bytes -= GV_GPU_TILE_BYTES;
        c->st.evictions++;
    }
    c->st.tiles = c->n;
}

static int insert(struct gv_gpu_cache *c, int level, uint32_t tx, uint32_t ty,
                  uint32_t handle, struct gv_error *err)
{
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 16;
        struct entry *e = realloc(c->e, cap * sizeof *e);
        if (!e) {
            gv_gpu_release(c->dec, handle);
            return gv_fail(err, GV_ENOMEM, "gpu cache: out of memory");
        }
        c->e = e;
        c->cap = cap;
    }
    c->e[c->n++] = (struct entry){level, tx, ty, handle, ++c->clock};
    c->st.bytes += GV_GPU_TILE_BYTES;
    if (c->st.bytes > c->st.peak_bytes)
        c->st.peak_bytes = c->st.bytes;
    evict(c);
    return 0;
}

int gv_gpu_cache_get(struct gv_gpu_cache *c, int level, uint32_t tx,
                     uint32_t ty, uint32_t *handle, struct gv_error *err)
{
    const struct gv_geometry *g = &c->geo;
    if (level < 0 || level > g->root ||
        (level == g->root ? tx != 0 || ty != 0
                          : tx >= g->level[level].tiles_x ||
                                ty >= g->level[level].tiles_y))
        return gv_fail(err, GV_ENOTFOUND, "gpu cache: no tile %d/%u/%u", level,
                       tx, ty);
    struct entry *e = lookup(c, level, tx, ty);
    if (e) {
        c->st.hits++;
        *handle = e->handle;
        return 0;
    }
    uint32_t h;
    if (level == g->root) {
        if (gv_gpu_upload_tile(c->dec, c->root_tile, &h, err) < 0)
            return -1;
    } else {
        /* The parent first (recursively); it is the newest entry when the
         * child is inserted, so eviction cannot take it before it is used. */
        uint32_t parent;
        if (gv_gpu_cache_get(c, level + 1, tx / 2, ty / 2, &parent, err) < 0)
            return -1;
        uint8_t *buf = NULL;
        size_t len = 0;
        c->st.fetches++;
        if (c->fetch(c->ctx, level, tx, ty, &buf, &len, err) < 0)
            return -1;
        int rc = gv_gpu_decode_tile(c->dec, buf, len, parent, (int)(tx & 1),
                                    (int)(ty & 1), &h, err);
        free(buf);
        if (rc < 0)
            return -1;
    }
    c->st.decodes++;
    if (insert(c, level, tx, ty, h, err) < 0)
        return -1;
    *handle = h;
    return 0;
}

int gv_gpu_cache_read(struct gv_gpu_cache *c, int level, uint32_t tx,
                      uint32_t ty, uint8_t *pixels, struct gv_error *err)
{
    uint32_t h;
    if (gv_gpu_cache_get(c, level, tx, ty, &h, err) < 0)
        return -1;
    return gv_gpu_read_tile(c->dec, h, 0, pixels, err);
}

void gv_gpu_cache_stats(const struct gv_gpu_cache *c,
                        struct gv_gpu_cache_stats *st)
{
    *st = c->st;
}
