/*
 * view_roi.h - a filter result shown in place in `gigaview view`: a
 * texture holding the picture of a region of the image (level-0 pixels
 * x0..x1, y0..y1) drawn over the picture as a quad in image space, so it
 * pans, zooms and turns with the image.  Texels are sampled at their
 * nearest (at 1:1 a frame shows the result's pixels exactly), and drawn
 * opaque.  GL thread only.
 */
#ifndef GV_VIEW_ROI_H
#define GV_VIEW_ROI_H

#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "view_geom.h"

struct vr;

struct vr *vr_new(struct gv_gpu *g, struct gv_error *err);
void vr_free(struct vr *r);

/* Show the w x h RGBA8 picture rgba (rows top first) over the level-0
 * rectangle [x0, x1) x [y0, y1). */
void vr_set(struct vr *r, const uint8_t *rgba, uint32_t w, uint32_t h, double x0,
            double y0, double x1, double y1);

/* Show nothing. */
void vr_clear(struct vr *r);

/* Draw it (if set) for view v over the bound w x h framebuffer. */
void vr_draw(struct vr *r, const struct vg_view *v, int w, int h);

#endif
