/*
 * view_overlay.h - the overlay of `gigaview view`: lines of text at the
 * bottom left (zoom, level, rotation, image, loading, the GPU renderer),
 * a scale bar in image pixels above them, and an optional panel at the
 * top left (the image list), drawn with a built-in 5 x 7 bitmap font
 * (view_font.c) into one texture blended over the picture.  The texture
 * is redrawn only when its content changes.  GL thread only.
 */
#ifndef GV_VIEW_OVERLAY_H
#define GV_VIEW_OVERLAY_H

#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"

#define VO_LINES 24
#define VO_LINE 96

struct vo_content {
    char bottom[6][VO_LINE];     /* "" lines are skipped */
    char panel[VO_LINES][VO_LINE];
    int npanel;
    double bar_px;               /* scale bar length in window pixels (0: none) */
    char bar_label[32];
};

struct vo;

struct vo *vo_new(struct gv_gpu *g, struct gv_error *err);
void vo_free(struct vo *o);

/* Draw c over the bound w x h framebuffer. */
void vo_draw(struct vo *o, int w, int h, const struct vo_content *c);

/* Text s on a box, as the overlay draws its lines: a malloc'ed RGBA
 * canvas (rows top first, not premultiplied) into *rgba, its size into
 * *w x *h.  Returns 0, or -1 when s is empty or memory runs out. */
int vo_label(const char *s, uint8_t **rgba, int *w, int *h);

/* The rows of character c (7, top first, bit 4 leftmost), or NULL for a
 * space or a character the font lacks.  Small letters give capitals. */
const unsigned char *vo_glyph(char c);

#endif
