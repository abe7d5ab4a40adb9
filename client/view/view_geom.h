/*
 * view_geom.h - the view of `gigaview view` and its geometry, the same as
 * the browser viewer's (client/web/view.js) and `gigaview render`'s.
 *
 * A view is {cx, cy, zoom, rot}: the centre in level-0 pixels, the zoom as
 * a level of detail (one window pixel shows 2^zoom level-0 pixels: 0 is
 * 1:1, negative magnifies) and the image turned clockwise by rot degrees
 * about the centre.  A window point s of a W x H window shows the image
 * point  p = c + 2^zoom * R(-rot) * (s - (W/2, H/2)),  y down, and a
 * pixel's sample is taken at its centre (i + 0.5, j + 0.5).
 *
 * Views are exchanged as the browser's URL hash,
 * "#image=ID&x=CX&y=CY&z=ZOOM&r=DEG[&window=B,W,G...]" (docs/VIEWER.md),
 * or as the `--view CX,CY,ZOOM[,ROT]` argument.  Pure functions, any thread.
 */
#ifndef GV_VIEW_GEOM_H
#define GV_VIEW_GEOM_H

#include <stddef.h>

struct vg_view {
    double cx, cy, zoom, rot;
};

/* Image point (level 0) under window point (sx, sy) of a w x h window. */
void vg_screen_to_image(const struct vg_view *v, double w, double h, double sx,
                        double sy, double *px, double *py);

/* Window point of image point (px, py): the inverse of the above. */
void vg_image_to_screen(const struct vg_view *v, double w, double h, double px,
                        double py, double *sx, double *sy);

/* v moved so that image point (px, py) lies under window point (sx, sy). */
struct vg_view vg_anchored(const struct vg_view *v, double w, double h, double px,
                           double py, double sx, double sy);

/* The whole image (iw x ih), unrotated, centred in a w x h window. */
struct vg_view vg_home(double iw, double ih, double w, double h);

/* Rotation in (-180, 180]. */
double vg_norm_rot(double r);

/* The view kept sensible, as the browser keeps it: zoom between -6 and
 * the home zoom + 2 (at least 0), the centre inside the image. */
struct vg_view vg_clamp(const struct vg_view *v, double iw, double ih, double w,
                        double h);

/*
 * Parse "CX,CY,ZOOM" or "CX,CY,ZOOM,ROT" (finite numbers, |zoom| <= 64)
 * into *v, or a browser link's hash: the text from its '#' on (a whole
 * URL may precede it), "image=ID&x=CX&y=CY&z=ZOOM&r=DEG" in any order,
 * other keys ignored, x, y and z required.  image (cap bytes, may be
 * NULL) receives the hash's image id, "" when it has none.  Returns 0, or
 * -1 when s is neither (then *v and image are unchanged).
 */
int vg_parse(const char *s, struct vg_view *v, char *image, size_t cap);

/*
 * The display window of a browser link: the value of the hash's `window`
 * key (s as vg_parse takes it; the text after '#'), percent-decoded as the
 * browser's URLSearchParams decodes it ("%2C" is ',', "%3B" ';', '+' a
 * space), into out (cap bytes).  The text is not checked as a window here
 * (render/window.h's gv_window_parse does that, or it is "none").
 * Returns 1 with the text, 0 when s has no hash or the hash no window
 * (out ""), -1 when the value has a malformed escape, a NUL, or does not
 * fit out (out "").  The last `window` key wins, as in the browser.
 */
int vg_hash_window(const char *s, char *out, size_t cap);

/* The browser's hash of `image` at v ("#image=..&x=..&y=..&z=..&r=..",
 * numbers as the browser rounds them: 2, 2, 4 and 2 decimals, trailing
 * zeros dropped), then "&window=TEXT" when window is neither NULL nor "",
 * TEXT's ',' and ';' escaped as the browser's URLSearchParams writes them
 * (%2C, %3B), into out (cap bytes, always terminated). */
void vg_format_hash(const char *image, const struct vg_view *v,
                    const char *window, char *out, size_t cap);

/* The scale bar for a zoom: a round length (1, 2 or 5 times a power of
 * ten) at most max_px window pixels long, of level-0 pixels, or of
 * microns when mpp (microns per level-0 pixel) is more than 0 (a slide's
 * metadata slide.mpp_x): its length in window pixels in *bar_px, its label
 * ("200 PX", "50 UM", "2 MM" from a millimetre) into label[cap]. */
void vg_scale_bar(double zoom, double mpp, double max_px, double *bar_px,
                  char *label, int cap);

#endif
