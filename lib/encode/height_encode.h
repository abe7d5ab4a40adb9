/*
 * height_encode.h - `gigaview encode --height`: a single-channel raster
 * (16-bit or float; 8-bit too) to a height store with a guaranteed
 * maximum error (docs/FORMAT.md section 12); and `gigaview encode
 * --bits 16`: an image of 1 to 8 channels to a sample store, the same
 * codes and tiles a channel (section 13).
 *
 * The input is mapped to 16-bit codes (value = code * scale + offset):
 * integer input is kept as it is (scale 1, offset 0) unless the caller
 * maps it; float input gets offset = its minimum and scale = its range /
 * 65535, so that quantizing costs at most scale/2.  The pyramid of codes
 * is built by the 2x2 box filter of section 1, and every tile of every
 * level is coded against its decoded parent (closed loop) within e codes
 * of that level's exact codes (height_tile.h).
 *
 * The encoder streams, as the image encoder does (stream_encoder.h):
 * pass 1 reads the input's rows top to bottom (encode/source.h, native
 * samples: one image, a mosaic of images, or synth-height:) and writes
 * every level of the code pyramid to a scratch file in strips
 * (strips.h); pass 2 codes the levels from the root down, page by page,
 * each page's tiles in parallel against their decoded parents, which the
 * level above left in the scratch file.  Float input is read once more
 * before pass 1, for its range.  Memory is one page's working set (about
 * 80 MB: the 4097^2 window, 64 decoded tiles, 16 parents) plus a few rows
 * of the widest level, whatever the area; the scratch file takes about
 * 2.9 bytes per input sample (docs/FORMAT.md section 12).  Output is
 * byte-identical on every machine and for any number of threads.
 */
#ifndef GV_HEIGHT_ENCODE_H
#define GV_HEIGHT_ENCODE_H

#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"
#include "encode/stream_encoder.h"
#include "store/geometry.h"

struct gv_height_opts {
    int samples;           /* 1: a sample store (docs/FORMAT.md section 13)
                            * of the input's 1..8 channels, not a height
                            * store of one */
    double max_error;      /* E in source units; 0 = lossless */
    double target_psnr;    /* > 0: e from this PSNR (dB, over the samples'
                            * full range) instead of max_error: the
                            * largest e with e (e + 1) / 3 <= the MSE */
    const char *window;    /* sample stores: the default display window
                            * (render/window.h, on codes), or NULL */
    const char *colours;   /* sample stores: the channels' colours
                            * (render/samples_region.h), or NULL */
    int mapped;            /* integer input: use scale/offset below */
    double scale, offset;  /* value = code * scale + offset */
    const char *unit;      /* up to 8 printable characters, or NULL */
    uint64_t max_pixels;   /* refuse larger inputs (0: GV_SOURCE_MAX_PIXELS) */
    uint64_t max_decoder_bytes; /* a decoder's memory for the whole image
                                 * (gv_image_limits; 0: the default) */
    struct gv_image_plane plane;  /* an OME-TIFF stack's plane */
    int threads;           /* workers; 0 = every CPU */
    int mosaic_cols;       /* > 0: the inputs are a mosaic of this many */
    int mosaic_rows;       /* columns and rows (source.h) */
    const char *tmpdir;    /* scratch directory; NULL = output's */
    /* Called from the encoding thread every few rows of pass 1 and after
     * each page of pass 2 (phases "pyramid", "encode", "done"); may be
     * NULL. */
    void (*progress)(void *ctx, const struct gv_encode_progress *p);
    void *progress_ctx;
};

struct gv_height_result {
    struct gv_geometry geometry;
    uint64_t file_bytes, tiles;
    int e;                 /* the half-step in codes */
    int channels;
    double psnr0;          /* level 0's PSNR (dB, 99 when lossless) */
    int trial_tries;       /* -q: tries of the trial (codes_trial.h), */
    double trial_psnr;     /* the sample's PSNR at e, */
    int uniform_e;         /* and the uniform rule's e it started from */
    double scale, offset, max_error, min, max;
    int src_float;
    uint64_t scratch_bytes; /* the scratch file's size at the end */
    double seconds;
};

/*
 * Encode `n` inputs (one image path, or "synth-height:WIDTHxHEIGHT", a
 * reproducible fractal terrain in metres; or with o->mosaic_cols the
 * tiles of a mosaic, row by row) into the height store `output`
 * (published atomically).  Returns 0 with *r filled, or -1 with *err:
 * GV_EINVAL for input that is not one channel or an error bound that the
 * float quantization cannot meet, GV_ELIMIT past o->max_pixels, the
 * input's, the scratch file's and the store's errors.
 */
int gv_height_encode(const char *const *inputs, int n, const char *output,
                     const struct gv_height_opts *o,
                     struct gv_height_result *r, struct gv_error *err);

#endif
