/*
 * geometry.c - level, tile and page arithmetic (see geometry.h).
 */
#include "store/geometry.h"

uint32_t gv_tiles_for(uint32_t pixels)
{
    if (pixels <= GV_TILE)
        return 1;
    return (pixels - 1 + GV_STEP - 1) / GV_STEP;
}

int gv_geometry_init(struct gv_geometry *g, uint32_t width, uint32_t height,
                     int channels, uint32_t root_side)
{
    if (root_side < 1 || root_side > GV_ROOT_MAX)
        return -1;
    if (width == 0 || height == 0 || width > GV_MAX_DIM || height > GV_MAX_DIM)
        return -1;
    if (channels < 1 || channels > GV_MAX_CHANNELS)
        return -1;
    g->width = width;
    g->height = height;
    g->channels = channels;
    g->root_side = root_side;
    uint32_t w = width, h = height;
    int k = 0;
    for (;;) {
        struct gv_level *l = &g->level[k];
        l->width = w;
        l->height = h;
        if (w <= root_side && h <= root_side)
            break;
        w = (w + 1) / 2;
        h = (h + 1) / 2;
        k++;
    }
    g->root = k;
    /* The root keeps its own mip chain down to 1x1. */
    int mips = 1;
    for (uint32_t mw = w, mh = h; mw > 1 || mh > 1; mips++) {
        mw = (mw + 1) / 2;
        mh = (mh + 1) / 2;
    }
    g->root_mips = mips;
    struct gv_level *r = &g->level[g->root];
    r->tiles_x = r->tiles_y = r->pages_x = r->pages_y = 0;
    r->first_page = 0;
    /* Every tile's parent (tx / 2, ty / 2) must exist: a level has at
     * least half (rounded up) the tiles of the level below.  Without this,
     * widths such as 1026 (3 tiles, over a level of 513 pixels and 1 tile)
     * had tiles with no parent. */
    for (int i = 0; i < g->root; i++) {
        struct gv_level *l = &g->level[i];
        l->tiles_x = gv_tiles_for(l->width);
        l->tiles_y = gv_tiles_for(l->height);
        if (i > 0) {
            const struct gv_level *c = &g->level[i - 1];
            if (l->tiles_x < (c->tiles_x + 1) / 2)
                l->tiles_x = (c->tiles_x + 1) / 2;
            if (l->tiles_y < (c->tiles_y + 1) / 2)
                l->tiles_y = (c->tiles_y + 1) / 2;
        }
    }
    uint64_t page = 0;
    for (int i = g->root - 1; i >= 0; i--) {
        struct gv_level *l = &g->level[i];
        l->pages_x = (l->tiles_x + GV_PAGE_TILES - 1) / GV_PAGE_TILES;
        l->pages_y = (l->tiles_y + GV_PAGE_TILES - 1) / GV_PAGE_TILES;
        l->first_page = page;
        page += (uint64_t)l->pages_x * l->pages_y;
    }
    g->pages = page;
    return 0;
}

int gv_level_size(const struct gv_geometry *g, int level, uint32_t *w,
                  uint32_t *h)
{
    if (level < 0 || level >= g->root + g->root_mips)
        return -1;
    int k = level < g->root ? level : g->root;
    uint32_t lw = g->level[k].width, lh = g->level[k].height;
    for (; k < level; k++) {
        lw = (lw + 1) / 2;
        lh = (lh + 1) / 2;
    }
    *w = lw;
    *h = lh;
    return 0;
}

uint64_t gv_page_number(const struct gv_geometry *g, int level, uint32_t px,
                        uint32_t py)
{
    const struct gv_level *l = &g->level[level];
    return l->first_page + (uint64_t)py * l->pages_x + px;
}
