/*
 * stream_encoder.h - `gigaview encode`: input images to a store file, streaming.
 *
 * Pass 1 reads the input once, top to bottom, and builds the box pyramid
 * row by row into a scratch file.  Pass 2 encodes level by level from the
 * root down, one page (8x8 tiles) at a time, its 64 tiles in parallel on
 * the thread pool, each predicted from its decoded parent (closed loop).
 * Peak memory is bounded by a page's working set plus a few rows of the
 * widest level: it does not grow with the image's area (docs/FORMAT.md,
 * "Encoder memory").
 *
 * A sharded encode (shard_count > 0) runs both passes over the whole
 * input but keeps and encodes only the tiles of its shard (shard_plan.h)
 * and writes them to a shard file (shard_file.h); gv_shard_merge
 * (shard_merge.h) then writes the store, byte for byte the one a single
 * encode writes.
 */
#ifndef GV_STREAM_ENCODER_H
#define GV_STREAM_ENCODER_H

#include <stdint.h>

#include "base/error.h"
#include "store/geometry.h"
#include "codec/tile.h"
#include "encode/source.h"

#define GV_DEFAULT_DCT GV_LAYOUTS_D   /* tile layouts (tile.h GV_LAYOUTS_*) */
#define GV_DEFAULT_LAYOUTS "d"        /* ... as --layouts names them */
#define GV_DEFAULT_PSNR 40.0     /* dB, level 0 of the whole image */
#define GV_DEFAULT_MAX_RATE 10   /* 1024 codevectors */

struct gv_encode_progress {
    double fraction;          /* 0..1 of the whole encode */
    uint64_t source_pixels;   /* width * height */
    const char *phase;        /* "pyramid" (pass 1), "encode" (pass 2),
                               * then "done" once, with fraction 1 */
    int level;                /* level being encoded (pass 2) */
};

struct gv_encode_opts {
    double target_psnr;       /* PSNR target in dB: of the whole image's
                               * level 0 (equal-slope mode, the default),
                               * or of every tile (per_tile) */
    int max_rate;             /* cap on the index width r (1..12) */
    int per_tile;             /* 1: every tile meets target_psnr (or the
                               * cap) at the first rate that does; 0:
                               * equal-slope allocation (FORMAT.md 8), one
                               * price of a bit for every tile, found by
                               * lambda_model.h for the whole-image target */
    int dct;                  /* equal-slope mode: GV_LAYOUTS_* (tile.h);
                               * with layout D the store is format
                               * version 4 */
    int threads;              /* workers; 0 = every CPU */
    int shard_index;          /* with shard_count > 0: write shard */
    int shard_count;          /* shard_index of shard_count (0-based) to
                               * `output` as a shard file, not a store */
    const char *tmpdir;       /* scratch directory; NULL = output's */
    const char *window;       /* the store's default display window
                               * (render/window.h text), kept in its
                               * metadata; NULL = none */
    struct gv_source_opts source;
    /* Called from the encoding thread after each page and every few rows
     * of pass 1; may be NULL. */
    void (*progress)(void *ctx, const struct gv_encode_progress *p);
    void *progress_ctx;
};

struct gv_encode_result {
    struct gv_source_info source;
    struct gv_geometry geometry;
    uint64_t file_bytes;
    double bpp;               /* file bits per source pixel */
    double psnr0;             /* level 0 against the (8-bit) input, dB */
    uint64_t tiles;
    uint64_t rate_tiles[GV_RATE_DCT + 1]; /* tiles per chosen rate (D last) */
    uint64_t level_bytes[GV_MAX_LEVELS];
    uint64_t below_target;    /* per_tile: tiles at the cap that missed
                               * the target */
    int per_tile;             /* the mode it was encoded in (opts) */
    double lambda;            /* equal-slope mode: the price of a bit in
                               * squared error (0 in per_tile mode) */
    int lambda_tries;         /* equal-slope mode: encodes of the lambda
                               * trial's sample (lambda_trial.h) */
    double model_psnr;        /* ... and its level-0 PSNR at the rate
                               * model's lambda, before the trial's
                               * correction (dB) */
    double seconds;
    uint64_t scratch_bytes;   /* disk the scratch files took at the end of
                               * pass 2 (their most) */
    int level0_from_input;    /* pass 2 read level 0 from the input file
                               * instead of a scratch copy */
};

/* Fill *o with the defaults. */
void gv_encode_opts_default(struct gv_encode_opts *o);

/*
 * Encode `n` inputs (one image, a mosaic, or a synth: pattern; see
 * source.h) into the store file `output` (or the shard file, see
 * shard_count).  Returns 0 and fills *res, or -1 with *err filled; on
 * failure no file exists under `output` (an existing one is left as it
 * was).  For a shard, *res counts the shard's tiles, file_bytes is the
 * shard file's size and psnr0 is 0.
 */
int gv_encode(const char *const *inputs, int n, const char *output,
              const struct gv_encode_opts *opts, struct gv_encode_result *res,
              struct gv_error *err);

#endif
