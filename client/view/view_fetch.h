/*
 * view_fetch.h - the network side of `gigaview view`: a thread of its own
 * that talks to gigaviewd (http_fetch.c: curl multi, batches, the on-disk
 * ETag cache), so that the render thread never waits for the network.
 *
 * The render thread posts what it wants and polls for what came:
 *   - vf_open asks for an image: its metadata and every root mip;
 *   - vf_want replaces the list of tiles wanted, most urgent first; the
 *     thread fetches them from the front, up to VF_BATCH per round trip,
 *     and never asks for a tile that is on the wire or waiting to be
 *     polled (so posting the same list every frame costs nothing);
 *   - vf_poll hands over one result at a time, without blocking.
 * Results of an image that is no longer the current one are dropped.
 * A tile whose fetch fails comes back with ok = 0 and the message; the
 * render thread decides when to ask again.
 */
#ifndef GV_VIEW_FETCH_H
#define GV_VIEW_FETCH_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "remote/http_fetch.h"
#include "store/geometry.h"

#define VF_BATCH 48          /* tiles per round trip (the browser's batch size) */

struct vf_key {
    int level;
    uint32_t tx, ty;
};

enum vf_kind { VF_TILE, VF_IMAGE };

struct vf_result {
    enum vf_kind kind;
    int ok;                  /* 0: failed, msg says why */
    char msg[320];          /* = struct gv_error text */
    /* VF_TILE */
    struct vf_key key;
    uint8_t *buf;            /* malloc'ed tile buffer (checked), the caller's */
    size_t len;
    /* VF_IMAGE */
    struct gv_remote_image img;
    uint8_t *mip[GV_MAX_LEVELS]; /* root mips 0..img.root_mips-1, the caller's */
    uint32_t mip_w[GV_MAX_LEVELS], mip_h[GV_MAX_LEVELS];
};

struct vf_options {
    const char *url;         /* http(s)://host:port */
    long timeout_ms;         /* each request */
    const char *cache_dir;   /* NULL: the default location */
    int no_cache, no_batch, verbose;
};

struct vf;

/* Connect (lazily) to o->url and start the thread.  Returns NULL with *err
 * (a bad URL, no memory, no thread). */
struct vf *vf_new(const struct vf_options *o, struct gv_error *err);

/* Stop the thread and free everything, results not polled included.
 * The round trip in progress is dropped (gv_http_abort), so this never
 * waits for the network.  NULL does nothing. */
void vf_free(struct vf *f);

/* Ask for image `id` (its metadata and root mips): the tile list is
 * cleared, and tiles of the previous image no longer come back. */
void vf_open(struct vf *f, const char *id);

/* Replace the wanted tiles of the current image by keys[0..n) (copied). */
void vf_want(struct vf *f, const struct vf_key *keys, size_t n);

/* Move the next result into *r and return 1, or return 0 when there is
 * none.  The caller frees r->buf and r->mip[] (vf_result_free). */
int vf_poll(struct vf *f, struct vf_result *r);

/* Free what a result holds. */
void vf_result_free(struct vf_result *r);

/* Tiles on the wire now (for the loading indicator) and the counters of
 * the HTTP client so far. */
size_t vf_in_flight(struct vf *f);
void vf_stats(struct vf *f, struct gv_http_stats *st);

#endif
