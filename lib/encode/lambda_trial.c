/*
 * lambda_trial.c - the sample of tiles and the search over lambda (see
 * lambda_trial.h).
 *
 * One encode of the sample walks its levels from the root down: level k's
 * tiles are coded on the pool, each from its decoded parent among level
 * k+1's (the root's tile for level root-1), into one half of the decoded
 * tiles the encoder lends (even levels the first half, odd the second),
 * so that a level's parents are still there while it is coded.  Level 0's
 * decoded tiles are only measured, in each worker's own buffer.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "encode/lambda_model.h"
#include "encode/lambda_trial.h"
#include "encode/tile_pass.h"

#define TRIAL_TOLERANCE 0.5          /* dB: close enough, stop */
#define TRIAL_NEAR 1.0               /* dB: ... after TRIAL_TRIES_NEAR tries */
#define TRIAL_TRIES_NEAR 3
#define TRIAL_STEP_MAX 2.772588722   /* ln 16: lambda moves at most 16x a step */
#define TRIAL_SLOPE (-4.342944819)   /* dB per ln lambda where D is
                                      * proportional to lambda */
#define TRIAL_SLOPE_MIN (-0.1)       /* a secant at least this steep */

static int tile_order(const void *a, const void *b)
{
    const struct gv_trial_tile *x = a, *y = b;
    if (x->ty != y->ty)
        return x->ty < y->ty ? -1 : 1;
    return x->tx < y->tx ? -1 : x->tx > y->tx;
}

/* Index of (tx, ty) among level k's sample, or -1. */
static int find_tile(const struct gv_lambda_trial *t, int k, uint32_t tx,
                     uint32_t ty)
{
    const struct gv_trial_tile key = {tx, ty};
    const struct gv_trial_tile *hit =
        bsearch(&key, t->tile[k], (size_t)t->n[k], sizeof key, tile_order);
    return hit ? (int)(hit - t->tile[k]) : -1;
}

static void add_tile(struct gv_lambda_trial *t, int k, uint32_t tx, uint32_t ty)
{
    for (int i = 0; i < t->n[k]; i++)
        if (t->tile[k][i].tx == tx && t->tile[k][i].ty == ty)
            return;
    if (t->n[k] < GV_TRIAL_MAX)
        t->tile[k][t->n[k]++] = (struct gv_trial_tile){tx, ty};
}

/* Level 0's sample: every tile, or GV_TRIAL_GROUPS 2x2 groups of
 * siblings at the centres of an even grid over the parents' grid, as
 * near square cells as the image's shape allows. */
static void plan_level0(const struct gv_level *l0, struct gv_lambda_trial *t)
{
    const uint32_t G = GV_TRIAL_GROUPS;
    if ((uint64_t)l0->tiles_x * l0->tiles_y <= GV_TRIAL_MAX) {
        for (uint32_t ty = 0; ty < l0->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l0->tiles_x; tx++)
                add_tile(t, 0, tx, ty);
        return;
    }
    const uint32_t px = (l0->tiles_x + 1) / 2, py = (l0->tiles_y + 1) / 2;
    uint32_t gx = (uint32_t)lround(sqrt((double)G * px / py));
    gx = gx < 1 ? 1 : gx > G ? G : gx;
    gx = gx > px ? px : gx;
    uint32_t gy = G / gx;
    gy = gy > py ? py : gy;
    gx = G / gy > px ? px : G / gy;
    for (uint32_t j = 0; j < gy; j++)
        for (uint32_t i = 0; i < gx; i++) {
            const uint32_t X = (uint32_t)(((2 * (uint64_t)i + 1) * px) / (2 * gx));
            const uint32_t Y = (uint32_t)(((2 * (uint64_t)j + 1) * py) / (2 * gy));
            for (uint32_t b = 0; b < 2; b++)
                for (uint32_t a = 0; a < 2; a++)
                    if (2 * X + a < l0->tiles_x && 2 * Y + b < l0->tiles_y)
                        add_tile(t, 0, 2 * X + a, 2 * Y + b);
        }
}

void gv_lambda_trial_plan(const struct gv_geometry *g, struct gv_lambda_trial *t)
{
    memset(t, 0, sizeof *t);
    if (g->root <= 0)
        return;
    t->levels = g->root;
    plan_level0(&g->level[0], t);
    /* Each level's parents: at most as many as its tiles. */
    for (int k = 1; k < g->root; k++)
        for (int i = 0; i < t->n[k - 1]; i++)
            add_tile(t, k, t->tile[k - 1][i].tx / 2, t->tile[k - 1][i].ty / 2);
    for (int k = 0; k < g->root; k++)
        qsort(t->tile[k], (size_t)t->n[k], sizeof t->tile[k][0], tile_order);
}

int gv_lambda_trial_wants(const struct gv_lambda_trial *t, int level,
                          uint32_t tx, uint32_t ty)
{
    return level >= 0 && level < t->levels && find_tile(t, level, tx, ty) >= 0;
}

/* ------------------------------------------------------------ search */

/* One level of one encode of the sample, for the pool. */
struct trial_level {
    const struct gv_lambda_trial *t;
    const struct gv_lambda_trial_env *env;
    int level;
    double lambda;
    const uint8_t *parent[GV_TRIAL_MAX];
    uint8_t *out[GV_TRIAL_MAX];      /* decoded tiles (levels >= 1) */
    uint64_t sse[GV_TRIAL_MAX], samples[GV_TRIAL_MAX]; /* level 0 */
    size_t len[GV_TRIAL_MAX];
    struct gv_tile_stats stats[GV_TRIAL_MAX];
    atomic_int failed;
    struct gv_error err;             /* the first failure */
};

static void trial_tile(void *ctx, size_t i, int worker)
{
    struct trial_level *r = ctx;
    const struct gv_lambda_trial_env *env = r->env;
    const struct gv_level *l = &env->g->level[r->level];
    const struct gv_trial_tile *tile = &r->t->tile[r->level][i];
    const int c = env->c;
    const size_t tb = gv_tile_bytes(c);
    uint8_t *orig = env->origs + (size_t)worker * tb;
    struct gv_error err = {0};
    if (env->read_orig(env->ctx, r->level, tile->tx, tile->ty, orig, &err) < 0) {
        if (!atomic_exchange(&r->failed, 1))
            r->err = err;
        return;
    }
    const uint32_t vw = gv_tile_span(l->width, tile->tx);
    const uint32_t vh = gv_tile_span(l->height, tile->ty);
    struct gv_tile_params params = env->params;
    params.lambda = gv_level_lambda(r->lambda, env->level_f, r->level);
    params.seed = gv_encode_tile_seed(r->level, tile->tx, tile->ty);
    uint8_t *recon = r->level == 0 ? env->wrecon + (size_t)worker * tb : r->out[i];
    r->len[i] = gv_tile_encode(env->ws[worker], orig, r->parent[i],
                               (int)(tile->tx & 1), (int)(tile->ty & 1), c,
                               vw, vh, &params, recon, env->bufs[i],
                               &r->stats[i]);
    if (r->level == 0)
        r->sse[i] = gv_level0_tile_sse(l, tile->tx, tile->ty, c, orig, recon,
                                       &r->samples[i]);
}

typedef struct gv_trial_coded coded_level[GV_TRIAL_MAX];

static void free_coded(coded_level *coded)
{
    if (!coded)
        return;
    for (int k = 0; k < GV_MAX_LEVELS; k++)
        for (int i = 0; i < GV_TRIAL_MAX; i++)
            free(coded[k][i].buf);
    free(coded);
}

/* Keep level k's tiles of a try, from the borrowed buffers. */
static int keep_level(const struct trial_level *r, int n, coded_level *coded)
{
    for (int i = 0; i < n; i++) {
        struct gv_trial_coded *c = &coded[r->level][i];
        if (!(c->buf = malloc(r->len[i] ? r->len[i] : 1)))
            return -1;
        memcpy(c->buf, r->env->bufs[i], r->len[i]);
        c->len = r->len[i];
        c->stats = r->stats[i];
        c->canon_sse = r->level == 0 ? r->sse[i] : 0;
    }
    return 0;
}

/* Encode the sample at lambda into coded (calloc'd by the caller); *mse
 * is its level-0 error per sample. */
static int encode_sample(const struct gv_lambda_trial *t,
                         const struct gv_lambda_trial_env *env, double lambda,
                         coded_level *coded, double *mse, struct gv_error *err)
{
    struct trial_level *r = calloc(1, sizeof *r);
    if (!r)
        return gv_fail(err, GV_ENOMEM, "encode: out of memory for the lambda trial");
    uint64_t sse = 0, samples = 0;
    for (int k = t->levels - 1; k >= 0; k--) {
        r->t = t;
        r->env = env;
        r->level = k;
        r->lambda = lambda;
        for (int i = 0; i < t->n[k]; i++) {
            const struct gv_trial_tile *tile = &t->tile[k][i];
            const int p = k + 1 < t->levels ?
                          find_tile(t, k + 1, tile->tx / 2, tile->ty / 2) : -1;
            r->parent[i] = p < 0 ? env->root_tile :
                           env->recon[((k + 1) & 1) * GV_TRIAL_MAX + p];
            r->out[i] = env->recon[(k & 1) * GV_TRIAL_MAX + i];
        }
        gv_pool_run(env->pool, trial_tile, r, (size_t)t->n[k]);
        if (atomic_load(&r->failed)) {
            *err = r->err;
            free(r);
            return -1;
        }
        if (keep_level(r, t->n[k], coded) < 0) {
            free(r);
            return gv_fail(err, GV_ENOMEM, "encode: out of memory for the lambda trial");
        }
    }
    for (int i = 0; i < t->n[0]; i++) {
        sse += r->sse[i];
        samples += r->samples[i];
    }
    free(r);
    *mse = samples ? (double)sse / (double)samples : 0;
    return 0;
}

static double psnr_of(double mse)
{
    return mse > 0 ? 10.0 * log10(65025.0 / mse) : 99.0;
}

/* The search's state: the rate model, its scale from lambda to theta,
 * and the sample's tiles of level 0 marked for it. */
struct search {
    const struct gv_lambda_trial_env *env;
    double target_mse, theta_per_lambda;
    uint8_t *mask0;
};

/* The rate model's error of the sample (mask0) or the whole level 0,
 * tile by tile, at lambda; 0 where it has none. */
static double model_mse(const struct search *s, double lambda, int sample)
{
    const struct gv_lambda_trial_env *env = s->env;
    if (!env->model || !s->mask0)
        return 0;
    const double m = gv_lambda_model_tiles_mse(env->model, env->model_levels,
                                               lambda * s->theta_per_lambda,
                                               sample ? s->mask0 : NULL);
    return m > 0 ? m : 0;
}

/* Level 0's whole error at lambda, estimated from the sample's, `mse`:
 * scaled by how the rate model sees the whole level against the sample,
 * tile by tile (a ratio estimator: the model knows which tiles are
 * busier than the sample's, the sample how far the model is off). */
static double whole_mse(const struct search *s, double lambda, double mse)
{
    const double ms = model_mse(s, lambda, 1), mw = model_mse(s, lambda, 0);
    return ms > 0 && mw > 0 ? mse * mw / ms : mse;
}

/* The lambda at which the whole level's model, scaled by the last try's
 * ratio of the estimated error to the model's (est at lam), gives the
 * target: bisected in ln lambda over 16x either way. */
static double model_step(const struct search *s, double lam, double est)
{
    const double mw = model_mse(s, lam, 0);
    if (!(mw > 0) || !(est > 0))
        return exp(log(lam) + (psnr_of(est) - psnr_of(s->target_mse)) / -TRIAL_SLOPE);
    const double want = s->target_mse * mw / est;   /* the model's error to reach */
    double lo = log(lam) - TRIAL_STEP_MAX, hi = log(lam) + TRIAL_STEP_MAX;
    for (int i = 0; i < 30; i++) {
        const double mid = 0.5 * (lo + hi);
        if (model_mse(s, exp(mid), 0) < want)
            lo = mid;
        else
            hi = mid;
    }
    return exp(0.5 * (lo + hi));
}

/* The next lambda to try after n tries (lam, p: the estimated whole
 * PSNR): between the closest tries on either side of the target where
 * there are both, else along the last two tries' secant where PSNR fell
 * with lambda between them (hard edges answer lambda far less than the
 * model: a synthetic image gained 0.56 dB where lambda halved), else
 * the model's step from the last; 16x at most. */
static double next_lambda(const struct search *s, const double *lam,
                          const double *p, const double *est, int n,
                          double target)
{
    int above = -1, below = -1;
    for (int i = 0; i < n; i++) {
        if (p[i] > target && (above < 0 || p[i] < p[above]))
            above = i;
        /* Below the target, the closest; of equal ones (the prediction
         * alone at every lambda above some), the lowest lambda. */
        if (p[i] < target && (below < 0 || p[i] > p[below] ||
                              (p[i] == p[below] && lam[i] < lam[below])))
            below = i;
    }
    double next;
    const double slope = n >= 2 ? (p[n - 1] - p[n - 2]) /
                                  (log(lam[n - 1]) - log(lam[n - 2])) : 0;
    if (above >= 0 && below >= 0)
        next = exp(log(lam[above]) + (target - p[above]) *
                   (log(lam[below]) - log(lam[above])) / (p[below] - p[above]));
    else if (isfinite(slope) && slope < TRIAL_SLOPE_MIN)
        next = lam[n - 1] * exp((target - p[n - 1]) / slope);   /* the secant */
    else
        next = model_step(s, lam[n - 1], est[n - 1]);
    const double step = log(next / lam[n - 1]);
    if (!isfinite(step))
        return lam[n - 1];
    return step > TRIAL_STEP_MAX ? lam[n - 1] * exp(TRIAL_STEP_MAX) :
           step < -TRIAL_STEP_MAX ? lam[n - 1] * exp(-TRIAL_STEP_MAX) : next;
}

int gv_lambda_trial_search(const struct gv_lambda_trial *t,
                           const struct gv_lambda_trial_env *env,
                           double target_psnr, double lambda0,
                           struct gv_lambda_trial_result *out,
                           struct gv_error *err)
{
    memset(out, 0, sizeof *out);
    out->lambda = lambda0;
    if (t->levels <= 0 || t->n[0] == 0 || !(lambda0 > 0))
        return 0;
    const double target_mse = 65025.0 / pow(10.0, target_psnr / 10.0);
    const struct gv_level *l0 = &env->g->level[0];
    struct search s = {
        .env = env,
        .target_mse = target_mse,
        .theta_per_lambda = 1.0 / (gv_lambda_model_k(target_mse, env->dct) * 2.0 * log(2.0)),
        .mask0 = calloc((size_t)l0->tiles_x * l0->tiles_y, 1),
    };
    if (!s.mask0)
        return gv_fail(err, GV_ENOMEM, "encode: out of memory for the lambda trial");
    for (int i = 0; i < t->n[0]; i++)
        s.mask0[(size_t)t->tile[0][i].ty * l0->tiles_x + t->tile[0][i].tx] = 1;
    double lam[GV_TRIAL_TRIES], p[GV_TRIAL_TRIES], est[GV_TRIAL_TRIES];
    double mse[GV_TRIAL_TRIES];
    coded_level *best_coded = NULL;
    int n = 0, best = 0, rc = 0;
    double cur = lambda0;
    for (;;) {
        coded_level *coded = calloc(GV_MAX_LEVELS, sizeof *coded);
        if (!coded) {
            rc = gv_fail(err, GV_ENOMEM, "encode: out of memory for the lambda trial");
            break;
        }
        if (encode_sample(t, env, cur, coded, &mse[n], err) < 0) {
            free_coded(coded);
            rc = -1;
            break;
        }
        lam[n] = cur;
        est[n] = whole_mse(&s, cur, mse[n]);
        p[n] = psnr_of(est[n]);
        if (n == 0 || fabs(p[n] - target_psnr) < fabs(p[best] - target_psnr)) {
            free_coded(best_coded);
            best_coded = coded;
            best = n;
        } else {
            free_coded(coded);
        }
        n++;
        /* Close enough, out of tries, or a step that changed nothing (the
         * sample coded with the prediction alone, or at the rate cap).
         * Where the target lies above and a lower lambda still far above
         * the high-rate price changed nothing, the sample is all
         * prediction and the model's first guess was far too high (a
         * smooth image whose model says the prediction alone reaches
         * the target): lower it on. */
        const int all_prediction = n >= 2 && p[n - 1] < target_psnr &&
                                   lam[n - 1] < lam[n - 2] &&
                                   lam[n - 1] > 16.0 * gv_rd_lambda(target_mse);
        if (fabs(p[n - 1] - target_psnr) <= TRIAL_TOLERANCE || n == GV_TRIAL_TRIES ||
            (n >= 2 && mse[n - 1] == mse[n - 2] && !all_prediction) ||
            (n >= TRIAL_TRIES_NEAR && fabs(p[best] - target_psnr) <= TRIAL_NEAR))
            break;
        cur = next_lambda(&s, lam, p, est, n, target_psnr);
        int tried = !isfinite(cur) || cur <= 0;
        for (int i = 0; i < n && !tried; i++)
            tried = fabs(cur / lam[i] - 1.0) < 1e-3;
        if (tried)
            break;
    }
    free(s.mask0);
    if (rc < 0) {
        free_coded(best_coded);
        return -1;
    }
    out->coded = best_coded;
    out->tries = n;
    out->lambda = lam[best];
    out->psnr = p[best];
    out->first_psnr = p[0];
    return 0;
}

const struct gv_trial_coded *gv_lambda_trial_coded(const struct gv_lambda_trial *t,
                                                   const struct gv_lambda_trial_result *r,
                                                   int level, uint32_t tx,
                                                   uint32_t ty)
{
    if (!r->coded || level < 0 || level >= t->levels)
        return NULL;
    const int i = find_tile(t, level, tx, ty);
    return i < 0 ? NULL : &r->coded[level][i];
}

void gv_lambda_trial_result_free(struct gv_lambda_trial_result *r)
{
    free_coded(r->coded);
    r->coded = NULL;
}
