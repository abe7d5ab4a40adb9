/*
 * view_draw.h - drawing a view of `gigaview view` from the resident tiles
 * (view_tiles.h) with one full-window pass, and reading a frame back.
 *
 * The display shader samples, for every window pixel, levels f and f + 1
 * bilinearly at the pixel's centre and blends them by the fraction of the
 * zoom, exactly as `gigaview render` composes a view (client/cmd/cmd_render.c)
 * and the browser draws one (client/web/display.frag.glsl): each tap is
 * read from the tile that owns its pixel, through the page table, so
 * there are no seams; a pixel whose taps are not all resident at a level
 * takes the nearest coarser level that has them, down to the pinned root
 * mips.  Outside the image is black.  At 1:1 (an integer zoom, no
 * rotation, pixel centres on texel centres) the weights are 0 and 1 and
 * every pixel is a decoded texel, bit for bit.  A display window, if set
 * (vd_set_window), maps each composed 8-bit sample through its table.
 *
 * A store of 16-bit codes (height and sample stores) has a layer a
 * channel in the atlas; each tap's codes go through the tables and colours
 * of vd_set_codes to the 8-bit value gigaviewd draws (gray, or the
 * channels' colours added), which is then sampled as an image's: the
 * same order as `gigaview render` (its to_display before composing).
 *
 * GIGAVIEW_VIEW_SABOTAGE=decode (for tests only) flips the low bit of
 * texel (100, 100) of every tiled level's tile as the shader reads it, so
 * that a test can show that its comparison catches a wrong decode.
 * GL thread only.
 */
#ifndef GV_VIEW_DRAW_H
#define GV_VIEW_DRAW_H

#include <stdint.h>

#include "base/error.h"
#include "gpu/gpu.h"
#include "render/window.h"
#include "view_geom.h"
#include "view_tiles.h"

struct vd;

/* Compile the display program.  Returns NULL with *err. */
struct vd *vd_new(struct gv_gpu *g, struct gv_error *err);
void vd_free(struct vd *d);

/* Draw plan p of view v (tiles of t) into the bound framebuffer, w x h. */
void vd_draw(struct vd *d, const struct vt *t, const struct vt_plan *p,
             const struct vg_view *v, int w, int h);

/* Draw through display window w (render/window.h; NULL or count 0: none)
 * for an image of `channels` channels (1 or 3) from now on: the same
 * tables as the server's.  GL thread; no tile is touched. */
void vd_set_window(struct vd *d, const struct gv_window *w, int channels);

/* The picture of a store of codes from now on: tables holds, for each of
 * `channels` channels, 65536 bytes (a code's 8-bit value: a sample store's
 * window on its codes, a height store's gray), colour each channel's RGB
 * (used when channels > 1).  GL thread; no tile is touched. */
void vd_set_codes(struct vd *d, const uint8_t *tables, const uint8_t (*colour)[3],
                  int channels);

/* Read the w x h framebuffer back as `channels`-channel rows, top row
 * first, into px (w * h * channels bytes). */
void vd_read(int w, int h, int channels, uint8_t *px);

#endif
