/*
 * strips.c - the scratch layout of a pyramid level (see strips.h).
 */
#include <stdlib.h>
#include <string.h>

#include "encode/strips.h"

uint32_t gv_strip_width(uint32_t width, uint32_t p)
{
    const uint32_t w = width - p * GV_STRIP_PAGE_W;
    return w < GV_STRIP_WINDOW ? w : GV_STRIP_WINDOW;
}

uint32_t gv_strip_count(const struct gv_level *l)
{
    return l->pages_x ? l->pages_x : 1;
}

uint64_t gv_strips_bytes(const struct gv_level *l, size_t px)
{
    /* n strips hold n - 1 columns twice */
    return ((uint64_t)l->width + gv_strip_count(l) - 1) * l->height * px;
}

uint64_t gv_strip_at(const struct gv_level *l, uint64_t base, size_t px,
                     uint32_t p, uint32_t y)
{
    return base + ((uint64_t)p * GV_STRIP_WINDOW * l->height +
                   (uint64_t)y * gv_strip_width(l->width, p)) * px;
}

int gv_strips_store(struct gv_spill *s, const struct gv_level *l,
                    uint64_t base, size_t px, uint32_t y, const void *row,
                    uint32_t x0, uint32_t x1, struct gv_error *err)
{
    const uint8_t *r = row;
    for (uint32_t p = 0; p < gv_strip_count(l); p++) {
        const uint32_t s0 = p * GV_STRIP_PAGE_W;
        const uint32_t s1 = s0 + gv_strip_width(l->width, p);
        const uint32_t a = x0 > s0 ? x0 : s0, b = x1 < s1 ? x1 : s1;
        if (a < b &&
            gv_spill_write(s, r + (size_t)a * px, (size_t)(b - a) * px,
                           gv_strip_at(l, base, px, p, y) + (uint64_t)(a - s0) * px,
                           err) < 0)
            return -1;
    }
    return 0;
}

struct gv_spill *gv_strips_spill_new(const char *tmpdir, const char *output,
                                     struct gv_error *err)
{
    char *outdir = NULL;
    if (!tmpdir) {
        outdir = strdup(output);
        char *slash = outdir ? strrchr(outdir, '/') : NULL;
        if (slash)
            *(slash == outdir ? slash + 1 : slash) = '\0';
        tmpdir = slash ? outdir : ".";
    }
    struct gv_spill *s = gv_spill_new(tmpdir, err);
    free(outdir);
    return s;
}
