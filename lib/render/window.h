/*
 * window.h - the display window of an image: per channel a black point,
 * a white point (sample values) and a gamma, mapping a sample v to
 *
 *     out = round(255 * clamp((v - black) / (white - black), 0, 1) ^ (1 / gamma))
 *
 * applied through a lookup table per channel that is computed one way
 * only: gv_window_table here, and its twin buildTable in
 * client/web/window.js, which must give the same bytes (tests/window.sh
 * compares them over many windows).  The server applies it to decoded
 * regions and IIIF images, the browser viewer in its display shader.
 *
 * The text form (docs/API.md, the viewers' links, --window of render,
 * view and encode, a store's display.window) is "B,W,G" for every
 * channel or "B,W,G;B,W,G;..." one per channel, B and W decimal integers
 * 0 .. max (255 for 8-bit samples), B < W, G a decimal gamma 0.1 .. 10
 * with at most three decimals (",G" may be left out: 1).  Gamma is kept
 * in thousandths, so the text has one canonical form (gv_window_format).
 * The sample maximum and the channel count are parameters: 8-bit image
 * stores take 0 .. 255, sample stores (16-bit codes, 1 to 8 channels)
 * 0 .. 65535, with the same text and the same table rule (a table of
 * max + 1 entries).
 */
#ifndef GV_WINDOW_H
#define GV_WINDOW_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define GV_WINDOW_MAX_CHANNELS 8
#define GV_WINDOW_MAX_TEXT 512       /* bytes of text accepted */
#define GV_WINDOW_GAMMA_MIN 100      /* thousandths */
#define GV_WINDOW_GAMMA_MAX 10000

struct gv_window_channel {
    uint32_t black, white;      /* black < white <= the sample maximum */
    uint32_t gamma_milli;       /* GV_WINDOW_GAMMA_MIN .. _MAX */
};

struct gv_window {
    int count;                  /* 0: no window; 1: all channels; else one each */
    struct gv_window_channel ch[GV_WINDOW_MAX_CHANNELS];
};

/* Parse text s (NUL-terminated) into *w for samples of 0 .. max.  Returns
 * 0, or -1 with *err (GV_EINVAL, a message starting "window: ") for
 * anything but the form above. */
int gv_window_parse(const char *s, uint32_t max, struct gv_window *w,
                    struct gv_error *err);

/* The canonical text of w (gamma with its thousandths, "B,W,G.GGG" per
 * channel, ';' between) into buf of size bytes, always terminated.
 * Returns the length it needs (as snprintf). */
int gv_window_format(const struct gv_window *w, char *buf, size_t size);

/* The window of channel c (0-based) of w: its own, or the one for all. */
const struct gv_window_channel *gv_window_of(const struct gv_window *w, int c);

/* The table of channel window c for samples 0 .. max: max + 1 entries
 * (65536 for a sample store's codes) into table. */
void gv_window_table(const struct gv_window_channel *c, uint32_t max,
                     uint8_t *table);

/* 0 when every point of w is within 0 .. max (a window parsed for 16-bit
 * samples, checked against an 8-bit image), else -1 with GV_EINVAL. */
int gv_window_check_max(const struct gv_window *w, uint32_t max,
                        struct gv_error *err);

/* The 256-entry table of channel window c for 8-bit samples. */
void gv_window_table8(const struct gv_window_channel *c, uint8_t table[256]);

/* Apply w to n pixels of `channels` interleaved 8-bit samples in place.
 * w->count must be 1 or `channels` (GV_EINVAL otherwise, pixels
 * untouched).  Returns 0 or -1 with *err. */
int gv_window_apply8(const struct gv_window *w, uint8_t *pix, size_t n,
                     int channels, struct gv_error *err);

/* The automatic window of the browser viewer's "auto" (client/web/
 * window.js autoPoints, the same rule): per channel, black at the first
 * value whose cumulative count passes 0.5 % of the n pixels of px
 * (`channels` interleaved 8-bit samples, e.g. the root level's) and white
 * at the first reaching 99.5 %, white at least black + 1; gamma_milli for
 * each.  linked: one window for all channels (the lowest black, the
 * highest white), else one each. */
void gv_window_auto8(const uint8_t *px, size_t n, int channels, int linked,
                     uint32_t gamma_milli, struct gv_window *w);

/* The same on 16-bit codes (a sample store's root): points 0 .. 65535.
 * 0, or -1 when out of memory (*w count 0). */
int gv_window_auto16(const uint16_t *px, size_t n, int channels, int linked,
                     uint32_t gamma_milli, struct gv_window *w);

/* The store metadata key (docs/FORMAT.md section 6) that holds an
 * image's default window, in the text form above. */
#define GV_WINDOW_META_KEY "display.window"

/* The default window of a store from its metadata JSON (NULL: none), for
 * samples of 0 .. max and an image of `channels` channels.  Returns 1 with
 * *w set, 0 (w->count 0) when the metadata has no such key; -1 with *err
 * when the key is there but is not a string, does not parse, or has a
 * window count that is neither 1 nor `channels`. */
int gv_window_from_meta(const char *json, uint32_t max, int channels,
                        struct gv_window *w, struct gv_error *err);

/* The metadata JSON `json` (NULL or "" for none: an empty object) with
 * the key above set to the canonical text of w (w->count >= 1), compact
 * and with sorted keys.  Returns a malloc'ed string, or NULL with *err. */
char *gv_window_meta_set(const char *json, const struct gv_window *w,
                         struct gv_error *err);

#endif
