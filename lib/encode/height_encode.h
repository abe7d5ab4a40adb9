/*
 * height_encode.h - `gigaview encode --height`: a single-channel raster
 * (16-bit or float; 8-bit too) to a height store with a guaranteed
 * maximum error (docs/FORMAT.md section 9).
 *
 * The input is mapped to 16-bit codes (value = code * scale + offset):
 * integer input is kept as it is (scale 1, offset 0) unless the caller
 * maps it; float input gets offset = its minimum and scale = its range /
 * 65535, so that quantizing costs at most scale/2.  The pyramid of codes
 * is built by the 2x2 box filter of section 1, and every tile of every
 * level is coded against its decoded parent (closed loop) within e codes
 * of that level's exact codes (height_tile.h).  The encoder holds the
 * code pyramid in memory (about 2.7 bytes per input sample): it is meant
 * for DEMs up to a few hundred megapixels.  Single-threaded; output is
 * byte-identical on every machine.
 */
#ifndef GV_HEIGHT_ENCODE_H
#define GV_HEIGHT_ENCODE_H

#include <stdint.h>

#include "base/error.h"
#include "store/geometry.h"

/* Default cap on width x height: 2^30 samples (about 2.9 GB of memory
 * for 16-bit input, 7 GB for float) since the encoder holds them all. */
#define GV_HEIGHT_MAX_PIXELS (1ull << 30)

struct gv_height_opts {
    double max_error;      /* E in source units; 0 = lossless */
    int mapped;            /* integer input: use scale/offset below */
    double scale, offset;  /* value = code * scale + offset */
    const char *unit;      /* up to 8 printable characters, or NULL */
    uint64_t max_pixels;   /* refuse larger inputs (0: GV_HEIGHT_MAX_PIXELS) */
    uint64_t max_decoder_bytes; /* a decoder's memory for the whole image
                                 * (gv_image_limits; 0: the default) */
    int threads;           /* workers; 0 = every CPU */
};

struct gv_height_result {
    struct gv_geometry geometry;
    uint64_t file_bytes, tiles;
    int e;                 /* the half-step in codes */
    double scale, offset, max_error, min, max;
    int src_float;
    double seconds;
};

/*
 * Encode `input` (an image path, or "synth-height:WIDTHxHEIGHT", a
 * reproducible fractal terrain in metres) into the height store `output`
 * (published atomically).  Returns 0 with *r filled, or -1 with *err:
 * GV_EINVAL for input that is not one channel or an error bound that the
 * float quantization cannot meet, the input's and the store's errors.
 */
int gv_height_encode(const char *input, const char *output,
                     const struct gv_height_opts *o,
                     struct gv_height_result *r, struct gv_error *err);

/*
 * Encode w x h codes already mapped (the core of gv_height_encode, and
 * what tests use): e is the half-step in codes; scale, offset, min, max,
 * max_error, unit and src_float go to the header as given; `threads`
 * workers (0: every CPU).
 */
int gv_height_encode_codes(const uint16_t *codes, uint32_t w, uint32_t h,
                           int e, const struct gv_height_result *meta,
                           const char *unit, int threads, const char *output,
                           struct gv_height_result *r, struct gv_error *err);

#endif
