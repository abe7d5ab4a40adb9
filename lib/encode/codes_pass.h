/*
 * codes_pass.h - how pass 2 of the codes encoder (height_encode.c) and
 * its -q trial (codes_trial.c) measure a level-0 plane of 16-bit codes,
 * written once: the trial's PSNR chooses the store's e, and pass 2's is
 * the one the store reports, so the two must not drift apart (as
 * tile_pass.h is for the image encoder and its lambda trial).
 */
#ifndef GV_CODES_PASS_H
#define GV_CODES_PASS_H

#include <math.h>
#include <stdint.h>

#include "codec/height_tile.h"
#include "encode/tile_pass.h"

/* The squared error of one channel plane (513 x 513 codes) of level-0
 * tile (tx, ty) of level l over the pixels it is the source of: 512 x
 * 512, its valid span in the last column and row of tiles.  Adds the
 * count of codes summed to *samples (if not NULL). */
static inline double gv_codes_level0_sse(const struct gv_level *l, uint32_t tx,
                                         uint32_t ty, const uint16_t *orig,
                                         const uint16_t *dec, uint64_t *samples)
{
    const uint32_t cw = tx + 1 == l->tiles_x ? gv_tile_span(l->width, tx) : GV_STEP;
    const uint32_t ch = ty + 1 == l->tiles_y ? gv_tile_span(l->height, ty) : GV_STEP;
    double s = 0;
    for (uint32_t y = 0; y < ch; y++)
        for (uint32_t x = 0; x < cw; x++) {
            const double d = (double)orig[y * GV_HT_SIDE + x] - dec[y * GV_HT_SIDE + x];
            s += d * d;
        }
    if (samples)
        *samples += (uint64_t)cw * ch;
    return s;
}

/* The PSNR of a squared error sse over n codes of full range `peak`,
 * capped at 99 dB (lossless) as an image store's. */
static inline double gv_codes_psnr(double sse, double n, double peak)
{
    const double p = sse > 0 ? 10.0 * log10(peak * peak * n / sse) : 99.0;
    return p > 99.0 ? 99.0 : p;
}

#endif
