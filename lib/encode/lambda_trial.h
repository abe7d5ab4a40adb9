/*
 * lambda_trial.h - closed-loop price of a bit for `-q`: encode a fixed
 * sample of level-0 tiles, each with its chain of ancestors up to the
 * root, at trial lambdas, and keep the lambda whose sample reaches the
 * target PSNR.
 *
 * The rate model (lambda_model.h) guesses lambda from the image's detail
 * in one pass; on textured photographs and hard-edged images it landed
 * 2.5 to 6 dB off the target (docs/FORMAT.md section 8).  The trial
 * starts from that guess and corrects it by encoding real tiles: the
 * whole image where level 0 has at most GV_TRIAL_MAX tiles, else
 * GV_TRIAL_GROUPS groups of 2x2 sibling tiles spread evenly over level 0
 * (siblings share their ancestors, so a chain costs a quarter as much).
 * The sample depends only on the geometry, and every tile is coded as
 * pass 2 codes it, so the lambda found is the same for any thread count
 * and in every shard of a sharded encode.
 */
#ifndef GV_LAMBDA_TRIAL_H
#define GV_LAMBDA_TRIAL_H

#include <stdint.h>

#include "base/error.h"
#include "base/pool.h"
#include "codec/tile.h"
#include "encode/lambda_model.h"
#include "store/geometry.h"

#define GV_TRIAL_GROUPS 8                     /* 2x2 groups of level-0 tiles */
#define GV_TRIAL_MAX (4 * GV_TRIAL_GROUPS)    /* tiles of one level, at most */
#define GV_TRIAL_RECON (2 * GV_TRIAL_MAX)     /* decoded tiles the search holds */
#define GV_TRIAL_TRIES 4                      /* encodes of the sample, at most */

struct gv_trial_tile {
    uint32_t tx, ty;
};

/* The sample: per level below the root, its tiles, sorted by (ty, tx). */
struct gv_lambda_trial {
    int levels;                               /* the root's level; 0 = none */
    int n[GV_MAX_LEVELS];
    struct gv_trial_tile tile[GV_MAX_LEVELS][GV_TRIAL_MAX];
};

/* Fill *t with the sample of geometry g (see the top of the file). */
void gv_lambda_trial_plan(const struct gv_geometry *g, struct gv_lambda_trial *t);

/* 1 if tile (tx, ty) of `level` is in the sample (its original is read
 * by the search), else 0. */
int gv_lambda_trial_wants(const struct gv_lambda_trial *t, int level,
                          uint32_t tx, uint32_t ty);

/* What the search borrows from the encoder.  read_orig fills orig
 * (513x513xC) with the original of a tile, the last row and column
 * repeated past the image's edge, as pass 2 cuts it; returns 0 or -1
 * with *err. */
struct gv_lambda_trial_env {
    const struct gv_geometry *g;
    int c;
    const uint8_t *root_tile;        /* level (root - 1)'s parent */
    struct gv_tile_params params;    /* as pass 2's; lambda and seed are set
                                      * per trial and per tile */
    struct gv_pool *pool;
    struct gv_tile_workspace **ws;   /* one per worker of pool */
    uint8_t *origs, *wrecon;         /* per worker: gv_tile_bytes(c) each */
    uint8_t *const *recon;           /* GV_TRIAL_RECON decoded tiles */
    uint8_t *const *bufs;            /* GV_TRIAL_MAX buffers of GV_TILEBUF_MAX */
    int (*read_orig)(const void *ctx, int level, uint32_t tx, uint32_t ty,
                     uint8_t *orig, struct gv_error *err);
    const void *ctx;
    /* The rate model of levels 0 .. model_levels-1, level 0's with the
     * sample marked (gv_lambda_model_set_sample), and whether it was
     * fitted for layout D (gv_lambda_model_k); NULL: the sample's own
     * PSNR is taken for the whole level's. */
    const struct gv_lambda_model *model;
    int model_levels, dct;
    double level_f;                  /* gv_level_lambda's f */
};

/* One tile of the sample as the chosen try coded it: what pass 2 would
 * code at that lambda, byte for byte, so it takes it instead. */
struct gv_trial_coded {
    uint8_t *buf;                    /* the tile buffer (malloc'd) */
    size_t len;
    struct gv_tile_stats stats;
    uint64_t canon_sse;              /* level 0: squared error over the
                                      * pixels the tile is the source of */
};

struct gv_lambda_trial_result {
    int tries;                       /* encodes of the sample */
    double lambda;                   /* the one chosen */
    double psnr;                     /* the whole level 0's PSNR it
                                      * estimates there, dB */
    double first_psnr;               /* ... at lambda0 */
    /* The chosen try's tiles, [level][i] as the sample's tile[level][i];
     * NULL when there are none. */
    struct gv_trial_coded (*coded)[GV_TRIAL_MAX];
};

/*
 * Search lambda, from lambda0, until the whole level 0's PSNR that the
 * sample estimates (see lambda_trial.c) is within 0.25 dB of target_psnr,
 * GV_TRIAL_TRIES encodes are spent or a step changes nothing; each step
 * goes where the rate model, scaled to the last try, reaches the target,
 * or between the closest tries on either side of it, and moves lambda by
 * a factor of 16 at most.  The
 * result is the tried lambda whose PSNR came closest, with its try's
 * tiles (free them with gv_lambda_trial_result_free).  A sample with no
 * tiles keeps lambda0.  Returns 0, or -1 with *err (read_orig failed, or
 * out of memory).
 */
/* The chosen try's coding of tile (tx, ty) of `level`, or NULL where it
 * is not in the sample or r has none. */
const struct gv_trial_coded *gv_lambda_trial_coded(const struct gv_lambda_trial *t,
                                                   const struct gv_lambda_trial_result *r,
                                                   int level, uint32_t tx,
                                                   uint32_t ty);

/* Free r's coded tiles (r itself is the caller's). */
void gv_lambda_trial_result_free(struct gv_lambda_trial_result *r);

int gv_lambda_trial_search(const struct gv_lambda_trial *t,
                           const struct gv_lambda_trial_env *env,
                           double target_psnr, double lambda0,
                           struct gv_lambda_trial_result *out,
                           struct gv_error *err);

#endif
