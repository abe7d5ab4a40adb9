/*
 * view_select.h - the Shift-drag selection of `gigaview view`: which
 * region of the image a window rectangle selects for a filter
 * (vsel_region, used both to draw the selection and to ask for the
 * filter job, so the user sees exactly what will be filtered), and the
 * selection drawn over the picture while the drag goes on: a dark outline
 * outside a light one (visible on dark and on bright images), a light
 * translucent fill, and the region's size in image pixels next to it in
 * the overlay's font.  GL thread only (vsel_region: any).
 */
#ifndef GV_VIEW_SELECT_H
#define GV_VIEW_SELECT_H

#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "store/geometry.h"
#include "view_geom.h"

/* A selected region: pixels [x, x + w) x [y, y + h) of `level`, which is
 * [x0, x1) x [y0, y1) in level-0 pixels. */
struct vsel_region {
    int level;
    uint32_t x, y, w, h;
    double x0, y0, x1, y1;
};

/* The region that window rectangle sel (x0, y0, x1, y1 in drawable
 * pixels, any two opposite corners) selects in view v of a w x h window
 * over image geometry g whose last level is top: the image-space
 * bounding box of the rectangle's corners (the rectangle itself when the
 * view is not turned), at the level the view shows (the zoom's floor,
 * within 0..top), widened to whole pixels of that level and cut to the
 * level.  Returns 0, or -1 when nothing of the image is under it. */
int vsel_region(const struct vg_view *v, int w, int h, const double sel[4],
                const struct gv_geometry *g, int top, struct vsel_region *out);

struct vsel;

/* Compile the program.  Returns NULL with *err. */
struct vsel *vsel_new(struct gv_gpu *g, struct gv_error *err);
void vsel_free(struct vsel *s);

/* Draw region r, as view v shows it, over the bound w x h framebuffer:
 * the region's edges lie between the dark outline (the window pixels just
 * outside) and the light one (just inside); the pixels inside those are
 * blended with white at VSEL_FILL_ALPHA; the label ("W x H px", level-0
 * pixels, and the level the filter runs at when not 0) goes below the
 * region's lowest point, kept inside the window. */
#define VSEL_FILL_ALPHA 0.25
void vsel_draw(struct vsel *s, const struct vg_view *v, int w, int h,
               const struct vsel_region *r);

#endif
