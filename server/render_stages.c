/*
 * render_stages.c - per-stage render histograms (see render_stages.h).
 * The bounds start at 0.1 ms, finer than the request histograms', since a
 * page read or a tile decode takes well under a millisecond.
 */
#include <time.h>

#include "render_stages.h"

#define STAGE_BUCKETS 17
static const double stage_le[STAGE_BUCKETS] = {
    0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
    0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};
_Static_assert(STAGE_BUCKETS <= METRICS_HIST_MAX, "stage bounds fit a histogram");
static const char *const stage_name[RENDER_STAGES] = {
    "queue_wait", "page_read", "decode", "decode_wait", "resample", "encode"};

static struct metrics_hist hist[RENDER_STAGES];

/* This thread's job: its stages so far, and whether any was added. */
static _Thread_local double job[RENDER_STAGES];
static _Thread_local int job_staged;

double render_stages_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

void render_stages_begin(double queue_wait)
{
    for (int s = 0; s < RENDER_STAGES; s++)
        job[s] = 0;
    job[STAGE_QUEUE_WAIT] = queue_wait;
    job_staged = 0;
}

void render_stages_add(enum render_stage s, double sec)
{
    if (s >= 0 && s < RENDER_STAGES && sec > 0)
        job[s] += sec;
    job_staged = 1;
}

void render_stages_decoder(struct gv_decoder *d, double total)
{
    struct gv_decode_times t;
    gv_decoder_times(d, &t, 1);
    double page = (double)t.page_ns / 1e9, dec = (double)t.decode_ns / 1e9,
           wait = (double)t.wait_ns / 1e9;
    render_stages_add(STAGE_PAGE_READ, page);
    render_stages_add(STAGE_DECODE, dec);
    render_stages_add(STAGE_DECODE_WAIT, wait);
    render_stages_add(STAGE_RESAMPLE, total - page - dec - wait);
}

void render_stages_end(void)
{
    if (!job_staged)
        return;
    for (int s = 0; s < RENDER_STAGES; s++)
        metrics_hist_add(&hist[s], stage_le, STAGE_BUCKETS, job[s]);
    job_staged = 0;
}

void render_stages_write(struct prom *p)
{
    const char *name = "gigaview_render_stage_seconds";
    prom_family(p, name, "histogram",
                "Seconds one IIIF image or region render spent in each "
                "stage: queue_wait, page_read, decode (tiles and their "
                "missing ancestors), decode_wait (the tile cache, mostly "
                "waiting for another render's decode), resample, encode.");
    for (int s = 0; s < RENDER_STAGES; s++)
        metrics_hist_write(p, name, "stage", stage_name[s], stage_le,
                           STAGE_BUCKETS, &hist[s]);
}
