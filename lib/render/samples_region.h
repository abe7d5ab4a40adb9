/*
 * samples_region.h - what a sample store (docs/FORMAT.md section 13)
 * looks like on a screen: its 16-bit codes through a display window to
 * 8-bit gray (one channel) or RGB (two to eight channels, each in its
 * colour, added), for regions, IIIF and the viewers that take 8-bit
 * pixels.  The codes themselves come from gv_decoder_copy_region (the
 * decoder holds a sample tile as 513 x 513 pixels of C interleaved
 * uint16_t codes); png16 and tiff16 regions serve them as they are.
 *
 * The display rule (docs/API.md, "Sample stores"):
 *   t_c = the window's table of channel c (window.h, samples 0 .. 65535)
 *         applied to the code; the window is the request's, else the
 *         store's default (display.window), else black and white at the
 *         smallest and largest code of the input, gamma 1;
 *   one channel:  gray = t_0;
 *   more:         RGB_j = min(255, floor((sum_c t_c * colour_c[j] + 127) / 255))
 *                 with colour_c the request's colours, else the store's
 *                 (display.colours), else the c-th of red, green, blue,
 *                 magenta, cyan, yellow, orange (255,128,0) and white;
 *                 three channels are thus by default the RGB of the
 *                 codes' windows.
 * Integers and the window's table only, so any client can reproduce it.
 */
#ifndef GV_SAMPLES_REGION_H
#define GV_SAMPLES_REGION_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "render/store_decoder.h"
#include "render/window.h"
#include "store/store_format.h"

/* The colours of a sample store's channels: count 0 for the default
 * palette below, else one per channel.  Their text (the `colours` query
 * parameter, `gigaview encode --colours`, the metadata key
 * display.colours) is "RRGGBB;RRGGBB;..." in hexadecimal, one per
 * channel. */
struct gv_colours {
    int count;
    uint8_t rgb[GV_SAMPLES_MAX_CHANNELS][3];
};

#define GV_COLOURS_META_KEY "display.colours"
#define GV_COLOURS_MAX_TEXT 80   /* 8 * 7 bytes and then some */

/* Parse text s into *c (1 to 8 colours).  0, or -1 with GV_EINVAL and a
 * message starting "colours: ". */
int gv_colours_parse(const char *s, struct gv_colours *c, struct gv_error *err);

/* The canonical text of c (lower-case hexadecimal) into buf of size bytes,
 * always terminated; "" for count 0.  Returns the length it needs. */
int gv_colours_format(const struct gv_colours *c, char *buf, size_t size);

/* 0 when c fits a store of `channels` channels: count 0, or exactly one
 * colour a channel for a store of two or more (one channel is gray).
 * Else -1 with GV_EINVAL. */
int gv_colours_check(const struct gv_colours *c, int channels,
                     struct gv_error *err);

/* The store's colours from its metadata JSON (display.colours): 1 with
 * *c filled, 0 when it names none (*c count 0), -1 with GV_ECORRUPT when
 * they are malformed or do not fit `channels`. */
int gv_colours_from_meta(const char *json, int channels, struct gv_colours *c,
                         struct gv_error *err);

/* json (or NULL for {}) with display.colours set to c: a new malloc'ed
 * string (compact, keys sorted), or NULL with *err. */
char *gv_colours_meta_set(const char *json, const struct gv_colours *c,
                          struct gv_error *err);

/* A request's display window w and colours c (count 0: not given)
 * against the store of header h: a window's points within 255 unless it
 * is a sample store, one window or one per channel; colours only for a
 * sample store, one per channel (gv_colours_check).  0, or -1 with
 * GV_EINVAL.  What the region and IIIF routes check alike. */
int gv_display_check(const struct gv_header *h, const struct gv_window *w,
                     const struct gv_colours *c, struct gv_error *err);

/* Bytes gv_display_key writes at most, its NUL included. */
#define GV_DISPLAY_KEY_MAX (GV_WINDOW_MAX_CHANNELS * 32 + GV_COLOURS_MAX_TEXT + 8)

/* What a window and colours add to an output's cache key and ETag: ""
 * when neither is given, else " w" and the window's canonical text
 * and/or " c" and the colours', into buf (GV_DISPLAY_KEY_MAX bytes). */
void gv_display_key(const struct gv_window *w, const struct gv_colours *c,
                    char buf[GV_DISPLAY_KEY_MAX]);

/* The colour of channel k (0..7) under c (NULL or count 0: the default
 * palette): rgb[3], each 0..255. */
void gv_samples_colour(const struct gv_colours *c, int k, uint8_t rgb[3]);

/* The channels of a store's 8-bit pixels: an image store's own, 1 for a
 * height store, 1 or 3 for a sample store of 1 or more channels. */
int gv_display_channels(const struct gv_header *h);

/* A sample store's default window when it keeps none: black and white at
 * its smallest and largest code (white at least black + 1), gamma 1, one
 * for every channel. */
void gv_samples_default_window(const struct gv_header *h, struct gv_window *w);

/*
 * Map n pixels of c interleaved codes to display pixels (1 byte for
 * c = 1, else 3) through window w (count 1 or c) and colours col (NULL or
 * count 0: the default palette).  tables holds c * 65536 bytes of scratch
 * (the window's tables, built here).  0, or -1 with GV_EINVAL for a
 * window or colours of another channel count.
 */
int gv_samples_display(const uint16_t *codes, size_t n, int c,
                       const struct gv_window *w, const struct gv_colours *col,
                       uint8_t *tables, uint8_t *out, struct gv_error *err);

/*
 * The display pixels of rectangle x,y,w,h of `level` of a sample store
 * (gv_display_channels of them a pixel) into out, through window `win`
 * (NULL: the store's default window, its metadata's display.window, else
 * gv_samples_default_window; count 0, "none": gv_samples_default_window)
 * and colours `col` (NULL: the store's display.colours, else the default
 * palette; count 0: the default palette).  0 or -1 with *err (GV_EINVAL
 * outside the level or for another kind of store, GV_ENOMEM, decoding
 * failures).
 */
int gv_samples_region8(struct gv_decoder *d, int level, uint32_t x,
                       uint32_t y, uint32_t w, uint32_t h,
                       const struct gv_window *win,
                       const struct gv_colours *col, uint8_t *out,
                       struct gv_error *err);

#endif
