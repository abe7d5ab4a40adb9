/*
 * codes_trial.h - the half-step e of a sample store encoded for a PSNR
 * (`gigaview encode --bits 16 -q Q`, docs/FORMAT.md section 13), chosen
 * by coding a sample of the store.
 *
 * The uniform rule (e (e + 1) / 3 <= the target's mean square error) is
 * only a start: where the parent predicts a channel well, most residuals
 * are smaller than e and the PSNR reached is several dB above the target
 * (3.4 dB on ETOPO5 at 45 dB).  The trial codes up to 8 level-0 tiles,
 * spread evenly, with every ancestor up to the root, closed loop, at a
 * try of e, and measures level 0's PSNR over them; it keeps the largest
 * e whose sample reaches the target, by doubling then bisection to a
 * 32nd of e.  The sample depends only on the geometry, so the choice is
 * the same for any number of threads.
 */
#ifndef GV_CODES_TRIAL_H
#define GV_CODES_TRIAL_H

#include <stdint.h>

#include "base/error.h"
#include "base/pool.h"
#include "base/spill.h"
#include "store/geometry.h"

struct gv_codes_trial {
    struct gv_spill *spill;        /* pass 1's scratch file */
    const struct gv_geometry *g;
    const uint64_t *orig_base;     /* where each level's strips start */
    int c;                         /* channels, interleaved in the strips */
    const uint16_t *root_tile;     /* the root tile, c planes of 513^2 */
    struct gv_pool *pool;
    double peak;                   /* the samples' full range */
};

/* Fill *e with the largest half-step (0 .. 32767) whose sample reaches
 * `target` dB, starting from e0; *tries and *psnr (the sample's PSNR at
 * *e) say how.  0, or -1 with *err (scratch reads, memory). */
int gv_codes_trial(const struct gv_codes_trial *t, double target, int e0,
                   int *e, int *tries, double *psnr, struct gv_error *err);

#endif
