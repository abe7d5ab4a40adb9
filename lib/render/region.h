/*
 * region.h - from a store to the pixels a viewer asked for: a region of the
 * full-resolution image, scaled to an output size, rotated by a multiple of
 * 90 degrees (optionally mirrored), in colour, gray or bitonal.
 *
 * The region is decoded at the coarsest pyramid level that still has at
 * least the output's resolution (so no more than 2x oversampling), with the
 * CPU reference decoder, then resampled to the exact output size by area
 * averaging (downscaling) or bilinear interpolation (upscaling).  Pure
 * computation: used by the server's region and IIIF routes and by tests.
 * Thread-safety: one gv_decoder per thread, as store_decoder.h says.
 */
#ifndef GV_REGION_H
#define GV_REGION_H

#include <stddef.h>
#include <stdint.h>

#include "render/store_decoder.h"
#include "render/window.h"
#include "base/error.h"

enum gv_quality {
    GV_QUALITY_DEFAULT = 0, /* the store's own channels */
    GV_QUALITY_COLOR,       /* RGB (gray stores are expanded) */
    GV_QUALITY_GRAY,        /* one channel, BT.601 luma, rounded */
    GV_QUALITY_BITONAL      /* one channel, 0 or 255 (threshold 128 on luma) */
};

struct gv_render_req {
    /* Region in level-0 pixel coordinates; must lie inside the image. */
    uint32_t x, y, w, h;
    /* Output size before rotation; >= 1 each. */
    uint32_t out_w, out_h;
    int rotation;           /* 0, 90, 180 or 270, clockwise */
    int mirror;             /* 1: mirror horizontally before rotating */
    enum gv_quality quality;
    /* Refuse (GV_ELIMIT) if the rectangle decoded at the chosen level
     * would have more pixels than this; 0: no limit. */
    uint64_t max_decode_pixels;
    /* A display window (render/window.h) applied to the decoded samples
     * before resampling, or NULL / count 0 for none. */
    const struct gv_window *window;
    /* A sample store's channel colours (render/samples_region.h), or NULL
     * for the store's own. */
    const struct gv_colours *colours;
};

/*
 * Render req from the store behind d.  On success *pixels (malloc'ed,
 * caller frees) holds *w x *h pixels of *channels (1 or 3) channels, rows
 * packed, after rotation.  Returns 0, or -1 with *err (GV_EINVAL for a bad
 * request, GV_ELIMIT past max_decode_pixels, decoder errors as they come).
 */
int gv_render(struct gv_decoder *d, const struct gv_render_req *req,
              uint8_t **pixels, uint32_t *w, uint32_t *h, int *channels,
              struct gv_error *err);

/*
 * gv_render into a buffer the caller keeps between renders: *buf
 * (malloc'ed or NULL) of *cap bytes receives the pixels, and is replaced
 * (the old one freed, *cap updated) when it is too small or when the
 * render makes its answer elsewhere (resampled, rotated or recoloured).
 * A render at a level's own size (an IIIF tile) decodes straight into
 * *buf, so a caller that keeps it allocates nothing for its pixels once
 * it is large enough.  The same pixels as gv_render; on failure *buf and
 * *cap stay valid (to free).
 */
int gv_render_to(struct gv_decoder *d, const struct gv_render_req *req,
                 uint8_t **buf, size_t *cap, uint32_t *w, uint32_t *h,
                 int *channels, struct gv_error *err);

#endif
