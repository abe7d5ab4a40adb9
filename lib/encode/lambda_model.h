/*
 * lambda_model.h - the slope of the default encoding mode, from a model
 * of the whole image, so that level 0 lands near its PSNR target.
 *
 * Equal-slope allocation codes every tile at one price lambda of a bit in
 * squared error.  How much error a given lambda leaves depends on the
 * image (at one lambda, the level-0 PSNR of the bench photos spans 10 dB:
 * smooth regions come out nearly exact), so -q, the whole image's level-0
 * PSNR, cannot fix lambda by a formula alone.  The model is reverse water
 * filling over 2x2 blocks: a block whose detail (the squared error per
 * sample of a prediction from level 1, bilinear from the box means around
 * it) is below the water level theta keeps that detail as error, a busier
 * block is coded down to theta, so D(theta) = mean over blocks of
 * min(detail, theta).  Each level below the root has such a histogram,
 * fed by pass 1 with every 2x2 block; a level's blocks also carry a
 * share of the error its parent level is left with (the root is exact).
 * theta is the level at which level 0's D is the target, and
 * lambda = K * 2 ln 2 * theta, with K and the share of a parent's error
 * that its children inherit measured on photographs
 * (docs/FORMAT.md section 8).
 *
 * Integer counts over every row of the image, in row order: the same
 * lambda for any thread count and in every shard of a sharded encode
 * (each reads the whole input in pass 1).
 */
#ifndef GV_LAMBDA_MODEL_H
#define GV_LAMBDA_MODEL_H

#include <stdint.h>

#define GV_LM_BINS 256   /* 8 per octave of the block's detail */
#define GV_LM_TBINS 64   /* per tile: 2 per octave */

struct gv_lambda_model {
    int channels;
    uint32_t width;               /* of level 0 */
    int have;                     /* block rows buffered: 0, 1 or 2 */
    uint8_t *even[2], *odd[2];    /* the pending block row's two rows:
                                   * their even and their odd pixels */
    uint8_t *mean[3];             /* level-1 rows above, at, below it,
                                   * each with one pixel more on either
                                   * side (the edge pixel repeated) */
    uint32_t *detail;             /* per block and channel, one row */
    uint64_t blocks;
    uint64_t count[GV_LM_BINS];   /* blocks per bin of detail */
    uint64_t sum[GV_LM_BINS];     /* ... and their detail, summed */
    /* Each tile's blocks again, in coarser bins (2 per octave), where
     * gv_lambda_model_set_tiles asked for them: the lambda trial's
     * model of where the error is (lambda_trial.h). */
    uint32_t tiles_x, tiles_y;
    uint32_t block_rows;          /* block rows added so far */
    uint32_t *t_count;            /* [tile][GV_LM_TBINS] */
    uint64_t *t_sum;
};

/* Start an empty model for a level 0 of `width` pixels of `channels`
 * (1 or 3) channels.  Returns 0, or -1 out of memory. */
int gv_lambda_model_init(struct gv_lambda_model *m, uint32_t width,
                         int channels);

/* Feed level-0 rows 2j and 2j+1 and row j of level 1 (their box
 * reduction, (width + 1) / 2 pixels); the blocks of row j - 1 are added
 * now, those of the last row by gv_lambda_model_finish. */
void gv_lambda_model_rows(struct gv_lambda_model *m, const uint8_t *r0,
                          const uint8_t *r1, const uint8_t *reduced);

/* Add the last block row (the level-1 row below it repeats the last). */
void gv_lambda_model_finish(struct gv_lambda_model *m);

/* Keep a histogram per tile too, for a level of tiles_x x tiles_y tiles
 * (a block belongs to the tile its top left pixel is the source of).
 * Before the first row.  Returns 0, or -1 out of memory. */
int gv_lambda_model_set_tiles(struct gv_lambda_model *m, uint32_t tiles_x,
                              uint32_t tiles_y);

/* Release the row buffers and the per-tile histograms (the level's
 * histogram stays usable). */
void gv_lambda_model_free(struct gv_lambda_model *m);

/* The water level theta (squared error per sample, at most 255^2) at
 * which level 0's modelled error is target_mse, given the models of
 * levels 0 .. n-1 (the levels below the root); 0 if level 0's is empty. */
double gv_lambda_model_theta(const struct gv_lambda_model *lv, int n,
                             double target_mse);

/* Level 0's modelled error per sample at water level theta, tile by
 * tile: each tile's blocks carry LM_ALPHA of their parent tile's error
 * (not the level's, as in gv_lambda_model_theta), from the level below
 * the root down.  Over the tiles marked in mask0 (level 0's tiles, row
 * by row), or all of them with mask0 NULL; 0 without per-tile
 * histograms (gv_lambda_model_set_tiles on every level) or marked
 * blocks, -1 out of memory. */
double gv_lambda_model_tiles_mse(const struct gv_lambda_model *lv, int n,
                                 double theta, const uint8_t *mask0);

/* K of gv_lambda_model_lambda for target_mse: lambda = K * 2 ln 2 * theta. */
double gv_lambda_model_k(double target_mse, int dct);

/* The price of a bit for a level-0 MSE of target_mse: K * 2 ln 2 * theta
 * (at least gv_rd_lambda(target_mse) / 64, so that a flat image still has
 * a positive price, and at most K * gv_rd_lambda(target_mse) * 64, where
 * theta saturates because the model takes the prediction alone for
 * enough: a guess the lambda trial corrects in a step or two).  dct: the
 * factor K fitted for stores that may use layout D, whose tiles reach a
 * lower error at the same price. */
double gv_lambda_model_lambda(const struct gv_lambda_model *lv, int n,
                              double target_mse, int dct);

/* The factor f of gv_level_lambda for an image whose level-0 MSE target
 * is target_mse: 1/2 + 1/2 p, p the share of level 0's blocks whose detail
 * is above the model's water level (the blocks that get coded).  Pure. */
double gv_lambda_model_level_factor(const struct gv_lambda_model *lv, int n,
                                    double target_mse);

/* The price of a bit in a tile of level k, for level 0's price lambda:
 * lambda * f^k.  A coarse level's error is the prediction of every level
 * below: where they code little (smooth images, low rates) it reaches
 * level 0 as it is, where they code much it costs only their bits, so f
 * goes from 1/2 to 1 with the share of level 0 that is coded. */
double gv_level_lambda(double lambda, double f, int level);

#endif
