/*
 * height_region.c - metadata and code regions of height stores (see
 * height_region.h).  The codes come from the decoder's tile walk,
 * gv_decoder_copy_region (the decoder holds a height store's tiles as
 * 513x513 uint16_t codes in its tile cache), the root and its mips from
 * the store.
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
    const struct gv_store_info *info = gv_store_info(gv_decoder_store(d));
    if (info->header.kind != GV_KIND_HEIGHT)
        return gv_fail(err, GV_EINVAL, "height: not a height store");
    return gv_decoder_copy_region(d, "height", level, x, y, w, h, out, err);
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
