/*
 * view_filter.h - filter graphs in `gigaview view`: a thread of its own
 * that lists the server's graphs (GET /v1/filters) and runs one over a
 * region of a level (POST /v1/images/{id}/filter, docs/API.md), decodes
 * the PNG that comes back (lib/imageio) and hands over RGBA pixels, so the
 * render thread never waits for a filter job (they take seconds).
 *
 * One job at a time: vx_run replaces a job not yet started; a result of a
 * job that was replaced since is dropped.  A failed job comes back with
 * ok = 0 and the server's message (a 4xx or 5xx, the network).
 */
#ifndef GV_VIEW_FILTER_H
#define GV_VIEW_FILTER_H

#include <stdint.h>

#include "base/error.h"

#define VX_MAX_GRAPHS 128

/* A graph and its first parameter (has_param 0: it has none). */
struct vx_graph {
    char id[129];
    int has_param;
    char module[64], name[64];
    double min, max, def;
};

/* A job: graph g over region (x, y, w, h) of `level` of image `image`,
 * with g's first parameter set to `param` (when it has one). */
struct vx_job {
    char image[129];
    struct vx_graph g;
    double param;
    int level;
    uint32_t x, y, w, h;
};

struct vx_result {
    int ok;
    char msg[320];
    struct vx_job job;           /* what ran */
    uint32_t w, h;               /* the picture, RGBA8, rows top first */
    uint8_t *rgba;               /* malloc'ed, the caller's (NULL when !ok) */
};

struct vx;

/* Start the thread for the server at url (it lists the graphs first).
 * Returns NULL with *err (no memory, no thread). */
struct vx *vx_new(const char *url, long timeout_ms, int verbose, struct gv_error *err);

/* Stop the thread and free everything.  A request in progress is
 * dropped, so this never waits for the server.  NULL does nothing. */
void vx_free(struct vx *x);

/* The graphs listed so far into out[0..max): returns their count (0
 * before the list came, or when it failed). */
int vx_graphs(struct vx *x, struct vx_graph *out, int max);

/* Run job j (copied) next, replacing a job not started yet. */
void vx_run(struct vx *x, const struct vx_job *j);

/* Move the next result into *r and return 1, or return 0. */
int vx_poll(struct vx *x, struct vx_result *r);

/* 1 while a job is queued or running, or the list is still coming. */
int vx_busy(struct vx *x);

#endif
