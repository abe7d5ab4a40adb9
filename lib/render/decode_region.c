/*
 * decode_region.c - gv_decode_region (declared in store_decoder.h): a
 * region of one level, for an image or a height store.
 *
 * Design.  This is the one place that dispatches on the store's kind: a
 * height store's region goes to height_region.c, which maps its codes to
 * 8-bit gray, an image store's region is checked and copied by the
 * decoder's tile walk (gv_decoder_copy_region).  Keeping the dispatch out
 * of store_decoder.c lets height_region.c use the decoder without the two
 * needing each other.
 */
#include <stdint.h>

#include "render/store_decoder.h"
#include "render/height_region.h"

int gv_decode_region(struct gv_decoder *d, int level, uint32_t x, uint32_t y,
                     uint32_t w, uint32_t h, uint8_t *out,
                     struct gv_error *err)
{
    const struct gv_store_info *info = gv_store_info(gv_decoder_store(d));
    if (info->header.kind == GV_KIND_HEIGHT)   /* the documented gray */
        return gv_height_region_gray(d, level, x, y, w, h, out, err);
    return gv_decoder_copy_region(d, "decode", level, x, y, w, h, out, err);
}
