/*
 * height_region.h - reading a height store (docs/FORMAT.md section 9):
 * its metadata and the 16-bit codes of any rectangle of any level, from
 * the CPU reference decoder.
 *
 * A code c stands for the value c * scale + offset in the store's unit.
 * Every decoded code of level k is within e = max_error / scale codes
 * (rounded down) of level k's exact code, the box-filtered pyramid of
 * the input's codes, so mesh builders may rely on max_error.  Thread
 * safety is the decoder's: one gv_decoder per thread.
 */
#ifndef GV_HEIGHT_REGION_H
#define GV_HEIGHT_REGION_H

#include <stdint.h>

#include "base/error.h"
#include "render/store_decoder.h"

struct gv_height_meta {
    double scale, offset;  /* value = code*scale + offset */
    double max_error;      /* guaranteed bound, source units */
    double min, max;       /* range of the source values */
    char unit[16];         /* NUL-terminated, "" when not given */
};

/* 1 if the decoder's store is a height store, filling *m; 0 otherwise
 * (*m untouched). */
int gv_height_meta_get(struct gv_decoder *d, struct gv_height_meta *m);

/*
 * Codes of rectangle x,y,w,h given in pixel coordinates of pyramid level
 * `level` (0 .. root + root_mips - 1, as gv_level_size counts them),
 * row-major into out[w*h].  Pixel (x,y) of a tiled level comes from tile
 * min(x/512, tiles_x-1) (likewise y), as for images.  Returns 0 or -1
 * with *err (GV_EINVAL outside the level or for an image store; decoding
 * failures as the store reports them).
 */
int gv_height_region(struct gv_decoder *d, int level, uint32_t x, uint32_t y,
                     uint32_t w, uint32_t h, uint16_t *out,
                     struct gv_error *err);

/* The documented gray mapping of a value v (IIIF, 8-bit regions):
 * round(255 (v - min) / (max - min)) clamped to 0..255; 0 if max = min. */
uint8_t gv_height_gray(const struct gv_height_meta *m, uint16_t code);

/* gv_height_region mapped through gv_height_gray into out[w*h] bytes
 * (what gv_decode_region returns for a height store).  0 or -1. */
int gv_height_region_gray(struct gv_decoder *d, int level, uint32_t x,
                          uint32_t y, uint32_t w, uint32_t h, uint8_t *out,
                          struct gv_error *err);

#endif
