/*
 * render_call.h - how the IIIF image and region routes answer a parsed
 * request: from a 304, from the output cache, or by rendering on the
 * render pool while the connection is suspended.
 *
 * The route parses and validates on the HTTP thread and describes the
 * answer (struct render_spec: the canonical key, its ETag, the media type,
 * the function that renders and encodes).  render_call_serve then
 *   - answers 304 with the ETag when If-None-Match lists it (no render);
 *   - answers 200 from the output cache on a hit;
 *   - answers 503 with Retry-After when the render queue is full;
 *   - otherwise suspends the connection and queues the render: a render
 *     thread runs spec.render, keeps a success in the output cache and
 *     resumes the connection; the route's handler is then called again
 *     and calls render_call_finish, which answers 200 or the error.
 * Every 200 carries the ETag and whatever spec.headers adds.
 */
#ifndef GV_SERVER_RENDER_CALL_H
#define GV_SERVER_RENDER_CALL_H

#include "http.h"

struct render_spec {
    const char *module;   /* "iiif", "region": log lines of store errors */
    const char *key;      /* output cache key (copied) */
    const char *etag;     /* strong ETag of the answer (copied) */
    const char *mime;     /* static */
    /* Render and encode on a render thread: *out malloc'ed, *len bytes.
     * 0, or -1 with *err. */
    int (*render)(void *arg, struct image *img, uint8_t **out, size_t *len,
                  struct gv_error *err);
    /* Add the route's headers to a 200 (may be NULL). */
    void (*headers)(void *arg, struct req *r, struct image *img,
                    struct MHD_Response *resp);
    /* Add headers read from the body of a 200, rendered or cached (may
     * be NULL; the mesh route puts the measured error in a header). */
    void (*body_headers)(const uint8_t *body, size_t len,
                         struct MHD_Response *resp);
    void *arg;            /* malloc'ed, owned by the call from here on:
                             freed (free) once answered */
};

/* Answer r as above.  Takes over the reference img and spec->arg in every
 * case. */
enum MHD_Result render_call_serve(struct req *r, struct image *img,
                                  const struct render_spec *spec);

/* 1 if r is a resumed render (r->async is a render call), else 0. */
int render_call_resumed(const struct req *r);

/* A render_spec's headers for answers that may be cached a day, as they
 * are (Cache-Control: public, max-age=86400): regions and meshes. */
void render_call_cache_day(void *arg, struct req *r, struct image *img,
                           struct MHD_Response *resp);

/* Answer a resumed render (render_call_resumed), and free the call. */
enum MHD_Result render_call_finish(struct req *r);

#endif
