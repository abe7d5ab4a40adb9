/*
 * decode_region.c - gv_decode_region (declared in store_decoder.h): a
 * region of one level, for an image or a height store.
 *
 * Design.  This is the one place that dispatches on the store's kind: a
 * height store's region goes to height_region.c, which maps its codes to
 * 8-bit gray, a sample store's to samples_region.c, which shows its codes
 * through the default window, an image store's region is checked and copied by the
 * decoder's tile walk (gv_decoder_copy_region).  Keeping the dispatch out
 * of store_decoder.c lets height_region.c use the decoder without the two
 * needing each other.
 */
#include <stddef.h>
#include <stdint.h>

#include "render/store_decoder.h"
#include "render/height_region.h"
#include "render/samples_region.h"

int gv_decode_region(struct gv_decoder *d, int level, uint32_t x, uint32_t y,
                     uint32_t w, uint32_t h, uint8_t *out,
                     struct gv_error *err)
{
    const struct gv_store_info *info = gv_store_info(gv_decoder_store(d));
    if (info->header.kind == GV_KIND_HEIGHT)   /* the documented gray */
        return gv_height_region_gray(d, level, x, y, w, h, out, err);
    if (info->header.kind == GV_KIND_SAMPLES)  /* the default window */
        return gv_samples_region8(d, level, x, y, w, h, NULL, NULL, out, err);
    return gv_decoder_copy_region(d, "decode", level, x, y, w, h, out, err);
}

int gv_decode_region_window(struct gv_decoder *d, int level, uint32_t x,
                            uint32_t y, uint32_t w, uint32_t h,
                            const struct gv_window *win,
                            const struct gv_colours *col, uint8_t *out,
                            struct gv_error *err)
{
    const struct gv_header *hd = &gv_store_info(gv_decoder_store(d))->header;
    if (hd->kind == GV_KIND_SAMPLES)
        return gv_samples_region8(d, level, x, y, w, h, win, col, out, err);
    if (gv_decode_region(d, level, x, y, w, h, out, err) < 0)
        return -1;
    if (!win || win->count == 0)
        return 0;
    return gv_window_apply8(win, out, (size_t)w * h, gv_display_channels(hd), err);
}
