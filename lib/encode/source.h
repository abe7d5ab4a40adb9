/*
 * source.h - the encoder's input: one image, a mosaic of images, or a
 * procedural test pattern, delivered as 8-bit rows from top to bottom.
 *
 * Opening probes headers only (cheap); rows are then read strictly in
 * order, so no input ever has to fit in memory.  Input with more than 8
 * bits per sample is brought to 8 bits by the rule in docs/FORMAT.md
 * (section 7, "Bringing input to 8 bits"; source.c gives it exactly):
 * integers scale by 255/(2^bits - 1)
 * with rounding, floats are treated as linear light, clipped to [0,1] and
 * encoded with the sRGB transfer curve, and --range LO:HI maps [LO,HI]
 * linearly onto [0,255] instead.  One-channel and gray+alpha input
 * gives a gray (1-channel) image; three or more channels give RGB (alpha
 * and extra channels are dropped).
 *
 * With opts->native the samples come as the input holds them instead
 * (8-bit, 16-bit or 32-bit float, every channel, no tone rule): what the
 * height encoder reads (height_encode.h), from the same files, mosaics,
 * and the terrain pattern "synth-height:WIDTHxHEIGHT" (synth_height.h).
 */
#ifndef GV_SOURCE_H
#define GV_SOURCE_H

#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

enum gv_tone_rule {
    GV_TONE_NONE = 0,      /* 8-bit input, copied */
    GV_TONE_SCALE = 1,     /* integer input, scaled by 255 / (2^bits - 1) */
    GV_TONE_SRGB_CLIP = 2, /* float input: clip to [0,1], sRGB encode */
    GV_TONE_RANGE = 3      /* any input: [lo,hi] mapped linearly to [0,255] */
};

struct gv_source_opts {
    int mosaic_cols;       /* > 0: inputs form a grid of this many columns */
    int mosaic_rows;       /* ... and rows, listed row by row */
    uint64_t max_pixels;   /* refuse larger images (0: GV_SOURCE_MAX_PIXELS) */
    uint64_t max_decoder_bytes; /* a decoder's memory for one whole image,
                                 * e.g. a progressive JPEG's (0: the
                                 * default, GV_IMAGE_MAX_DECODER_BYTES of
                                 * imageio/imageio.h) */
    double range_lo;       /* used when range_hi > range_lo */
    double range_hi;
    struct gv_image_plane plane;  /* an OME-TIFF stack's plane (every input) */
    int native;            /* 1: samples as the input holds them (see
                            * the top); every mosaic tile must have the
                            * same channels and sample type */
};

/* Default cap on width x height: 2^40 pixels (a terapixel). */
#define GV_SOURCE_MAX_PIXELS (1ull << 40)

struct gv_source_info {
    uint32_t width, height;
    int channels;          /* 1 or 3: what the rows hold (native: the
                            * input's channels) */
    int sample_bytes;      /* bytes of a sample in the rows: 1, or when
                            * native 2 (16-bit) or 4 (float) */
    int src_bits;          /* bits per sample of the input (8, 16, 32...) */
    int src_float;         /* 1 for half/float input */
    enum gv_tone_rule tone;
};

struct gv_source;

/*
 * Open `n` inputs.  A single input is an image path or a pattern
 * "synth:WIDTHxHEIGHT[:gray]" (a deterministic procedural image, used for
 * tests and benchmarks at any size), or with opts->native also
 * "synth-height:WIDTHxHEIGHT".  With opts->mosaic_cols > 0 the
 * inputs are cols x rows tiles given row by row; every tile of a grid
 * column must have the same width and of a grid row the same height, and
 * all must agree on gray or colour.  Fills *info.  Returns NULL with *err
 * filled for a missing, unreadable, unsupported or oversized input.
 */
struct gv_source *gv_source_open(const char *const *inputs, int n,
                                 const struct gv_source_opts *opts,
                                 struct gv_source_info *info,
                                 struct gv_error *err);

/*
 * Read the next `rows` rows (width * channels * sample_bytes bytes each,
 * native-endian) into out, aligned for its samples.
 * Returns 0, or -1 with *err filled when an input is truncated or corrupt
 * (decoder warnings about damaged data count as errors).
 */
int gv_source_read(struct gv_source *s, uint32_t rows, uint8_t *out,
                   struct gv_error *err);

/* What a single input image says of its pixels, as the JSON object of
 * store metadata (store/store_meta.h; gv_image_meta says which readers
 * give it: a whole slide's scanner metadata, a raster's georeference),
 * or NULL (a mosaic, a pattern, a file without any).  Valid until the
 * first gv_source_read. */
const char *gv_source_meta(const struct gv_source *s);

/* Close every input.  gv_source_free(NULL) does nothing. */
/* A reader of any rectangle of the rows gv_source_read delivers, read
 * from the input file where they lie (raw_regions.h), for a source that
 * is one uncompressed file of 8-bit samples delivered unchanged (see
 * gv_image_raw_regions), asked before the first gv_source_read; else
 * NULL with err->code GV_OK, or NULL with *err for GV_ENOMEM.  The
 * reader outlives s; free it with gv_raw_regions_free. */
struct gv_raw_regions;
struct gv_raw_regions *gv_source_raw_regions(struct gv_source *s,
                                             struct gv_error *err);

/* Whether gv_source_read reads the rows where they lie in the file, with
 * no decoder (gv_image_reads_raw): cheap to read.  Before the first
 * gv_source_read. */
int gv_source_reads_raw(const struct gv_source *s);

void gv_source_free(struct gv_source *s);

#endif
