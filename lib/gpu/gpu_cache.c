/*
 * gpu_cache.c - recursive GPU tile decoding with a byte-bounded LRU of
 * textures (gpu_cache.h).
 *
 * Entries live in a growable array scanned linearly: a GPU holds at most a
 * few thousand 1.3 MB textures, and a scan is far cheaper than a decode.
 * Eviction runs after each insertion and never removes the entry just
 * inserted, so the parent of a tile being decoded (touched just before)
 * survives until the child is made, whatever the budget.  A range of tiles
 * can be prepared in one batch: the missing tiles and their missing
 * ancestors, found level by level upwards, go to the GPU in one call,
 * top level first (image and codes decoders both batch).
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
    struct gv_gpu_tiles t;
    struct gv_geometry geo;
    uint8_t *root_tile;             /* padded root tile, 513x513 pixels */
    size_t budget;
    gv_tile_fetch_fn fetch;
    void *ctx;
    struct entry *e;
    size_t n, cap;
    uint64_t clock;
    struct gv_gpu_cache_stats st;
};

static int image_upload(void *dec, const void *tile, uint32_t *handle,
                        struct gv_error *err)
{
    return gv_gpu_upload_tile(dec, tile, handle, err);
}

static int image_decode(void *dec, const uint8_t *buf, size_t len, uint32_t parent,
                        int qx, int qy, uint32_t *handle, struct gv_error *err)
{
    return gv_gpu_decode_tile(dec, buf, len, parent, qx, qy, handle, err);
}

static int image_batch(void *dec, struct gv_gpu_tile_job *jobs, size_t n,
                       struct gv_error *err)
{
    return gv_gpu_decode_batch(dec, jobs, n, err);
}

static int image_read(void *dec, uint32_t handle, void *pixels, struct gv_error *err)
{
    return gv_gpu_read_tile(dec, handle, 0, pixels, err);
}

static void image_release(void *dec, uint32_t handle)
{
    gv_gpu_release(dec, handle);
}

struct gv_gpu_tiles gv_gpu_tiles_image(struct gv_gpu_decoder *d, int channels)
{
    return (struct gv_gpu_tiles){d, GV_GPU_TILE_BYTES, (size_t)channels,
                                 image_upload, image_decode, image_batch,
                                 image_read, image_release};
}

static int codes_upload(void *dec, const void *tile, uint32_t *handle,
                        struct gv_error *err)
{
    return gv_gpu_height_upload(dec, tile, handle, err);
}

static int codes_decode(void *dec, const uint8_t *buf, size_t len, uint32_t parent,
                        int qx, int qy, uint32_t *handle, struct gv_error *err)
{
    return gv_gpu_height_decode(dec, buf, len, parent, qx, qy, handle, err);
}

static int codes_batch(void *dec, struct gv_gpu_tile_job *jobs, size_t n,
                       struct gv_error *err)
{
    return gv_gpu_height_decode_batch(dec, jobs, n, err);
}

static int codes_read(void *dec, uint32_t handle, void *pixels, struct gv_error *err)
{
    return gv_gpu_height_read(dec, handle, pixels, err);
}

static void codes_release(void *dec, uint32_t handle)
{
    gv_gpu_height_release(dec, handle);
}

struct gv_gpu_tiles gv_gpu_tiles_codes(struct gv_gpu_height *h, int channels)
{
    const size_t px = sizeof(uint16_t) * (size_t)channels;
    return (struct gv_gpu_tiles){h, (size_t)GV_TILE * GV_TILE * px, px,
                                 codes_upload, codes_decode, codes_batch, codes_read,
                                 codes_release};
}

struct gv_gpu_cache *gv_gpu_cache_new(const struct gv_gpu_tiles *t,
                                      const struct gv_geometry *g,
                                      const void *root, uint32_t root_w,
                                      uint32_t root_h, size_t budget,
                                      gv_tile_fetch_fn fetch, void *ctx,
                                      struct gv_error *err)
{
    if (root_w == 0 || root_h == 0 || root_w > GV_TILE || root_h > GV_TILE) {
        gv_fail(err, GV_EINVAL, "gpu cache: bad root size %ux%u", root_w, root_h);
        return NULL;
    }
    struct gv_gpu_cache *c = calloc(1, sizeof *c);
    if (!c || !(c->root_tile = malloc((size_t)GV_TILE * GV_TILE * t->pixel_bytes))) {
        free(c);
        gv_fail(err, GV_ENOMEM, "gpu cache: out of memory");
        return NULL;
    }
    c->t = *t;
    c->geo = *g;
    /* The clamp padding moves whole pixels, whatever their bytes. */
    gv_root_tile(root, root_w, root_h, (int)t->pixel_bytes, c->root_tile);
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
        c->t.release(c->t.dec, c->e[i].handle);
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
        c->t.release(c->t.dec, c->e[old].handle);
        c->e[old] = c->e[--c->n];
        c->st.bytes -= c->t.gpu_bytes;
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
            c->t.release(c->t.dec, handle);
            return gv_fail(err, GV_ENOMEM, "gpu cache: out of memory");
        }
        c->e = e;
        c->cap = cap;
    }
    c->e[c->n++] = (struct entry){level, tx, ty, handle, ++c->clock};
    c->st.bytes += c->t.gpu_bytes;
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
        if (c->t.upload(c->t.dec, c->root_tile, &h, err) < 0)
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
        int rc = c->t.decode(c->t.dec, buf, len, parent, (int)(tx & 1),
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

struct want {
    int level;
    uint32_t tx, ty;
    uint8_t *buf;
    size_t len;
};

/* Index of (level,tx,ty) in w[0..n), or -1. */
static long find_want(const struct want *w, size_t n, int level, uint32_t tx,
                      uint32_t ty)
{
    for (size_t i = 0; i < n; i++)
        if (w[i].level == level && w[i].tx == tx && w[i].ty == ty)
            return (long)i;
    return -1;
}

/* Is (level,tx,ty) cached?  (Without touching it.) */
static int cached(const struct gv_gpu_cache *c, int level, uint32_t tx, uint32_t ty)
{
    for (size_t i = 0; i < c->n; i++)
        if (c->e[i].level == level && c->e[i].tx == tx && c->e[i].ty == ty)
            return 1;
    return 0;
}

/* The missing tiles: those of the range at `level`, then the missing
 * parents of each level's missing tiles, up to below the root.  Listed
 * finest first into *out (malloc'ed); returns their count, or -1 when
 * they would exceed `max`. */
static long missing_tiles(const struct gv_gpu_cache *c, int level, uint32_t t0x,
                          uint32_t t0y, uint32_t t1x, uint32_t t1y, size_t max,
                          struct want **out)
{
    const size_t range = (size_t)(t1x - t0x + 1) * (t1y - t0y + 1);
    size_t cap = range * 2 + 16, n = 0;
    struct want *w = calloc(cap, sizeof *w);
    if (!w)
        return -1;
    for (uint32_t ty = t0y; ty <= t1y; ty++)
        for (uint32_t tx = t0x; tx <= t1x; tx++)
            if (!cached(c, level, tx, ty)) {
                if (n == max) {
                    free(w);
                    return -1;
                }
                w[n++] = (struct want){level, tx, ty, NULL, 0};
            }
    /* Each pass adds the parents of the previous level's tiles; a level
     * has at most as many as the one below, so cap suffices. */
    for (size_t a = 0, b = n; a < b && w[a].level + 1 < c->geo.root; a = b, b = n)
        for (size_t i = a; i < b; i++) {
            const int k = w[i].level + 1;
            const uint32_t px = w[i].tx / 2, py = w[i].ty / 2;
            if (cached(c, k, px, py) || find_want(w + b, n - b, k, px, py) >= 0)
                continue;
            if (n == max || n == cap) {
                free(w);
                return -1;
            }
            w[n++] = (struct want){k, px, py, NULL, 0};
        }
    *out = w;
    return (long)n;
}

int gv_gpu_cache_prepare(struct gv_gpu_cache *c, int level, uint32_t t0x,
                         uint32_t t0y, uint32_t t1x, uint32_t t1y,
                         struct gv_error *err)
{
    const struct gv_geometry *g = &c->geo;
    if (level < 0 || level >= g->root || !c->t.batch)
        return 0;   /* a decoder without batches decodes tile by tile */
    const struct gv_level *l = &g->level[level];
    if (t1x >= l->tiles_x)
        t1x = l->tiles_x - 1;
    if (t1y >= l->tiles_y)
        t1y = l->tiles_y - 1;
    if (t0x > t1x || t0y > t1y)
        return 0;
    /* The root tile first, if it is needed and missing (an upload). */
    uint32_t root_h;
    if (gv_gpu_cache_get(c, g->root, 0, 0, &root_h, err) < 0)
        return -1;
    const size_t max = c->budget / c->t.gpu_bytes;
    struct want *w = NULL;
    const long n = missing_tiles(c, level, t0x, t0y, t1x, t1y, max, &w);
    if (n <= 0) {
        free(w);
        return 0;
    }
    struct gv_gpu_tile_job *jobs = calloc((size_t)n, sizeof *jobs);
    int rc = jobs ? 0 : gv_fail(err, GV_ENOMEM, "gpu cache: out of memory");
    /* Jobs top level first: w[] backwards. */
    for (long j = 0; j < n && rc == 0; j++) {
        struct want *t = &w[n - 1 - j];
        c->st.fetches++;
        if (c->fetch(c->ctx, t->level, t->tx, t->ty, &t->buf, &t->len, err) < 0) {
            rc = -1;
            break;
        }
        long pj = find_want(w, (size_t)n, t->level + 1, t->tx / 2, t->ty / 2);
        struct entry *pe = pj >= 0 ? NULL : lookup(c, t->level + 1, t->tx / 2, t->ty / 2);
        jobs[j] = (struct gv_gpu_tile_job){
            .buf = t->buf, .len = t->len, .parent = pe ? pe->handle : 0,
            .parent_job = pj >= 0 ? n - 1 - pj : -1,
            .qx = (int)(t->tx & 1), .qy = (int)(t->ty & 1)};
    }
    if (rc == 0)
        rc = c->t.batch(c->t.dec, jobs, (size_t)n, err);
    for (long j = 0; j < n && rc == 0; j++) {
        const struct want *t = &w[n - 1 - j];
        c->st.decodes++;
        if (insert(c, t->level, t->tx, t->ty, jobs[j].handle, err) < 0) {
            /* insert released this one; the rest were never cached */
            for (long k = j + 1; k < n; k++)
                c->t.release(c->t.dec, jobs[k].handle);
            rc = -1;
        }
    }
    for (long j = 0; j < n; j++)
        free(w[j].buf);
    free(w);
    free(jobs);
    return rc;
}

int gv_gpu_cache_read(struct gv_gpu_cache *c, int level, uint32_t tx,
                      uint32_t ty, void *pixels, struct gv_error *err)
{
    uint32_t h = 0;
    if (gv_gpu_cache_get(c, level, tx, ty, &h, err) < 0)
        return -1;
    return c->t.read(c->t.dec, h, pixels, err);
}

void gv_gpu_cache_stats(const struct gv_gpu_cache *c,
                        struct gv_gpu_cache_stats *st)
{
    *st = c->st;
}
