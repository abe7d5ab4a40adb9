/*
 * synth_height.h - "synth-height:WIDTHxHEIGHT", a reproducible fractal
 * terrain in metres (about 0 .. 7000) for tests and benchmarks of height
 * stores at any size.  Each sample is a function of (x, y) alone, so the
 * source (source.h) delivers it row by row like any input; the values are
 * part of what stores written from it hold, so they never change.
 */
#ifndef GV_SYNTH_HEIGHT_H
#define GV_SYNTH_HEIGHT_H

#include <stdint.h>

/* Parse "synth-height:WxH" (1 <= W, H <= GV_MAX_DIM of store/geometry.h)
 * into *w, *h.  Returns 0, or -1 when spec is not such a pattern. */
int gv_synth_height_parse(const char *spec, uint32_t *w, uint32_t *h);

/* Row y, columns x0 .. x0+w-1, of the terrain into out (w codes). */
void gv_synth_height_row(uint32_t y, uint32_t x0, uint32_t w, uint16_t *out);

#endif
