/*
 * render_stages.h - where the time of each IIIF image and region render
 * goes, for /metrics: one histogram per stage, of the seconds one render
 * spent in it.
 *
 * Stages: queue_wait (in the render queue, before a render thread took
 * the job), page_read (reading and checking store pages), decode
 * (decoding tiles, the missing ancestors included), decode_wait (finding
 * tiles in the tile cache, mostly waiting for another render's decode of
 * a tile this one needs), resample (the rest of gv_render: scaling,
 * rotation, colour, copies) and encode (the output format's encoder).
 *
 * A render thread calls render_stages_begin before a job, the route's
 * render function adds its stages (render_stages_add, or
 * render_stages_decoder and render_stages_encode), and render_stages_end
 * records them, every stage of the render at once (a stage it did not
 * reach counts 0 s), or nothing for a job that added no stage (a mesh or
 * terrain render).  The per-render state is the calling thread's own; the
 * histograms are atomics.
 */
#ifndef GV_SERVER_RENDER_STAGES_H
#define GV_SERVER_RENDER_STAGES_H

#include "metrics.h"
#include "render/store_decoder.h"

enum render_stage {
    STAGE_QUEUE_WAIT,
    STAGE_PAGE_READ,
    STAGE_DECODE,
    STAGE_DECODE_WAIT,
    STAGE_RESAMPLE,
    STAGE_ENCODE,
    RENDER_STAGES
};

/* The monotonic clock, in seconds. */
double render_stages_now(void);

/* A job starts on this thread after queue_wait seconds in the queue. */
void render_stages_begin(double queue_wait);

/* Add sec seconds to stage s of this thread's job. */
void render_stages_add(enum render_stage s, double sec);

/* After a gv_render (or gv_decode_region) of `total` seconds with decoder
 * d, reset before it (gv_decoder_times): its page_read, decode and
 * decode_wait, and the rest of `total` as resample. */
void render_stages_decoder(struct gv_decoder *d, double total);

/* Record this thread's job, if it added any stage. */
void render_stages_end(void);

/* The histogram family gigaview_render_stage_seconds{stage=...}. */
void render_stages_write(struct prom *p);

#endif
