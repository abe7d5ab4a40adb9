/*
 * filter_output.h - encoding a filter result (float RGBA) as PNG, 16-bit
 * or float TIFF, or raw floats, after docs/FILTERS.md section 6.
 *
 * The shared image writer (lib/imageio/imageio.h) takes 8-bit gray or RGB only;
 * filter results also need RGBA, 16-bit and 32-bit float samples, so
 * these encoders are written out here: PNG through zlib, baseline TIFF
 * (one uncompressed strip, little-endian) by hand.  Both are plain enough
 * to check with any reader (the tests use OpenImageIO's).
 */
#ifndef GV_SERVER_FILTER_OUTPUT_H
#define GV_SERVER_FILTER_OUTPUT_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

enum filter_output_form {
    FILTER_OUT_PNG = 0,   /* 8-bit: floor(clamp(v, 0, 1) * 255 + 0.5) */
    FILTER_OUT_TIFF16,    /* floor(clamp(v * scale, 0, 65535) + 0.5) */
    FILTER_OUT_TIFF32F,   /* v as 32-bit float */
    FILTER_OUT_RAW        /* little-endian f32, channel-interleaved */
};

/* "png", "tiff16", "tiff32f" or "raw": 0 and *form, or -1. */
int filter_output_parse(const char *name, enum filter_output_form *form);

/* The Content-Type of a form. */
const char *filter_output_type(enum filter_output_form form);

/*
 * Encode w*h texels of RGBA floats (rows packed, top first), keeping the
 * first `channels` (1, 3 or 4) of each.  NaN counts as 0 in the integer
 * forms.  *out is malloc'ed (the caller frees it).  Returns 0, or -1 with
 * GV_ENOMEM or GV_ELIMIT (a TIFF over 4 GiB).
 */
int filter_output_encode(enum filter_output_form form, const float *rgba,
                         uint32_t w, uint32_t h, int channels, double scale,
                         uint8_t **out, size_t *len, struct gv_error *err);

#endif
