/*
 * height_region.c - metadata and code regions of height stores (see
 * height_region.h).  Tiles come from gv_decoder_tile (the decoder holds
 * them as 513x513 uint16_t codes in its tile cache), the root and its
 * mips from the store.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "render/height_region.h"

int gv_height_meta_get(struct gv_decoder *d, struct gv_height_meta *m)
{
    const struct gv_header *h = &gv_store_info(gv_decoder_store(d))->header;
    if (h->kind != GV_KIND_HEIGHT)
        return 0;
    memset(m, 0, sizeof *m);
    m->scale = h->height_scale;
    m->offset = h->height_offset;
    m->max_error = h->height_max_error;
    m->min = h->height_min;
    m->max = h->height_max;
    memcpy(m->unit, h->height_unit, GV_HEIGHT_UNIT);
    m->unit[GV_HEIGHT_UNIT] = '\0';
    return 1;
}

int gv_height_region(struct gv_decoder *d, int level, uint32_t x, uint32_t y,
                     uint32_t w, uint32_t h, uint16_t *out,
                     struct gv_error *err)
{
    const struct gv_store *s = gv_decoder_store(d);
    const struct gv_store_info *info = gv_store_info(s);
    const struct gv_geometry *g = &info->geometry;
    if (info->header.kind != GV_KIND_HEIGHT)
        return gv_fail(err, GV_EINVAL, "height: not a height store");
    uint32_t lw, lh;
    if (gv_level_size(g, level, &lw, &lh) < 0)
        return gv_fail(err, GV_EINVAL, "height: no level %d (levels 0..%d)",
                       level, g->root + g->root_mips - 1);
    if (w == 0 || h == 0 || x >= lw || y >= lh || w > lw - x || h > lh - y)
        return gv_fail(err, GV_EINVAL, "height: region %u,%u %ux%u is outside "
                       "level %d (%ux%u)", x, y, w, h, level, lw, lh);
    if (level >= g->root) {
        const uint16_t *mip =
            (const uint16_t *)(const void *)gv_store_root(s, level - g->root, &lw, &lh);
        for (uint32_t r = 0; r < h; r++)
            memcpy(out + (size_t)r * w, mip + (size_t)(y + r) * lw + x,
                   sizeof *out * w);
        return 0;
    }
    const struct gv_level *l = &g->level[level];
    uint32_t t0x = x / GV_STEP, t1x = (x + w - 1) / GV_STEP;
    uint32_t t0y = y / GV_STEP, t1y = (y + h - 1) / GV_STEP;
    if (t1x >= l->tiles_x) t1x = l->tiles_x - 1;
    if (t1y >= l->tiles_y) t1y = l->tiles_y - 1;
    if (t0x > t1x) t0x = t1x;
    if (t0y > t1y) t0y = t1y;
    for (uint32_t ty = t0y; ty <= t1y; ty++)
        for (uint32_t tx = t0x; tx <= t1x; tx++) {
            const uint8_t *px;
            if (gv_decoder_tile(d, level, tx, ty, &px, err) < 0)
                return -1;
            const uint16_t *codes = (const uint16_t *)(const void *)px;
            /* Pixels this tile is the source of, clipped to the region. */
            uint32_t sx0 = tx * GV_STEP, sy0 = ty * GV_STEP;
            uint32_t sx1 = tx + 1 == l->tiles_x ? lw : sx0 + GV_STEP;
            uint32_t sy1 = ty + 1 == l->tiles_y ? lh : sy0 + GV_STEP;
            uint32_t ax = x > sx0 ? x : sx0, bx = x + w < sx1 ? x + w : sx1;
            uint32_t ay = y > sy0 ? y : sy0, by = y + h < sy1 ? y + h : sy1;
            if (ax >= bx || ay >= by)
                continue;
            for (uint32_t yy = ay; yy < by; yy++)
                memcpy(out + (size_t)(yy - y) * w + (ax - x),
                       codes + (size_t)(yy - sy0) * GV_TILE + (ax - sx0),
                       sizeof *out * (bx - ax));
        }
    return 0;
}

uint8_t gv_height_gray(const struct gv_height_meta *m, uint16_t code)
{
    if (!(m->max > m->min))
        return 0;
    double v = code * m->scale + m->offset;
    double g = floor(255.0 * (v - m->min) / (m->max - m->min) + 0.5);
    return (uint8_t)(g < 0 ? 0 : (g > 255 ? 255 : g));
}

int gv_height_region_gray(struct gv_decoder *d, int level, uint32_t x,
                          uint32_t y, uint32_t w, uint32_t h, uint8_t *out,
                          struct gv_error *err)
{
    struct gv_height_meta m;
    if (!gv_height_meta_get(d, &m))
        return gv_fail(err, GV_EINVAL, "height: not a height store");
    if ((uint64_t)w * h > SIZE_MAX / 2)
        return gv_fail(err, GV_ELIMIT, "height: region too large");
    uint16_t *codes = malloc(sizeof *codes * (size_t)w * h);
    if (!codes)
        return gv_fail(err, GV_ENOMEM, "height: out of memory for a region");
    int rc = gv_height_region(d, level, x, y, w, h, codes, err);
    if (rc == 0)
        for (size_t i = 0; i < (size_t)w * h; i++)
            out[i] = gv_height_gray(&m, codes[i]);
    free(codes);
    return rc;
}
