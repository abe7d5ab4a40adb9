/*
 * render_call.c - serve a render from a 304, the output cache or the
 * render pool (see render_call.h).  A call lives from the queueing to the
 * resumed answer; it holds the image reference all along, so the store
 * stays open while the render thread decodes it.
 */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "output_cache.h"
#include "render_call.h"
#include "render_pool.h"
#include "render_stages.h"

struct render_call {
    struct render_job job;        /* first: the pool hands it back */
    struct MHD_Connection *conn;
    struct output_cache *outputs;
    struct image *img;
    struct render_spec spec;      /* key and etag point into the call */
    char *key;
    char etag[OUTPUT_ETAG_SIZE];
    int rc;
    uint8_t *out;
    size_t len;
    struct gv_error err;
    const atomic_int *gone;       /* the client hung up: skip the render */
};

static void call_free(struct render_call *c)
{
    if (!c)
        return;
    image_put(c->img);
    free(c->spec.arg);
    free(c->key);
    free(c->out);
    free(c);
}

/* A resumed call whose client went away (http.c frees it). */
static void async_free(void *c)
{
    call_free(c);
}

/* On a render thread: render, keep a success, resume the connection.
 * A render whose client has hung up is skipped (http.c ends the request
 * as 499 without calling the handler again). */
static void run(struct render_job *j)
{
    struct render_call *c = (struct render_call *)j;
    gv_error_clear(&c->err);
    if (atomic_load(c->gone)) {
        MHD_resume_connection(c->conn);
        return;
    }
    const double queued = (double)j->queued.tv_sec +
                          (double)j->queued.tv_nsec / 1e9;
    render_stages_begin(render_stages_now() - queued);
    c->rc = c->spec.render(c->spec.arg, c->img, &c->out, &c->len, &c->err);
    render_stages_end();
    if (c->rc == 0)
        output_cache_put(c->outputs, c->key, c->out, c->len, c->spec.mime);
    MHD_resume_connection(c->conn);
}

/* 200 with body (malloc'ed, taken), the ETag and the route's headers. */
static enum MHD_Result send_body(struct req *r, struct image *img,
                                 const struct render_spec *spec, uint8_t *body,
                                 size_t len)
{
    struct MHD_Response *resp = http_response_owned(body, len, spec->mime);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, spec->etag);
        if (spec->headers)
            spec->headers(spec->arg, r, img, resp);
        if (spec->body_headers)
            spec->body_headers(body, len, resp);
    }
    return http_send(r, 200, resp, len);
}

static enum MHD_Result send_busy(struct req *r)
{
    return http_send_fail(r, GV_EBUSY, "render: the render queue is full "
                          "(render_queue), or the server is stopping; try "
                          "again", "Retry-After", "1");
}

/* Suspend r and queue its render; takes over img and spec->arg. */
static enum MHD_Result queue(struct req *r, struct image *img,
                             const struct render_spec *spec)
{
    struct render_call *c = calloc(1, sizeof *c);
    char *key = strdup(spec->key);
    if (!c || !key) {
        free(c);
        free(key);
        free(spec->arg);
        image_put(img);
        render_pool_unreserve(r->srv->render);
        return http_send_errorf(r, GV_ENOMEM, "render: out of memory");
    }
    c->job.run = run;
    c->conn = r->conn;
    c->outputs = r->srv->outputs;
    c->img = img;
    c->spec = *spec;
    c->key = key;
    snprintf(c->etag, sizeof c->etag, "%s", spec->etag);
    c->spec.key = c->key;
    c->spec.etag = c->etag;
    c->gone = http_suspend(r, c, async_free); /* before the job can resume
                                                 it */
    render_pool_submit(r->srv->render, &c->job);
    return MHD_YES;
}

enum MHD_Result render_call_serve(struct req *r, struct image *img,
                                  const struct render_spec *spec)
{
    enum MHD_Result ret;
    uint8_t *body;
    size_t len;
    const char *mime;
    if (http_etag_listed(http_header(r, "If-None-Match"), spec->etag)) {
        ret = http_send_empty(r, 304, MHD_HTTP_HEADER_ETAG, spec->etag);
    } else if (output_cache_get(r->srv->outputs, spec->key, &body, &len, &mime)) {
        ret = send_body(r, img, spec, body, len);
    } else if (render_pool_reserve(r->srv->render) < 0) {
        ret = send_busy(r);
    } else {
        return queue(r, img, spec);
    }
    free(spec->arg);
    image_put(img);
    return ret;
}

int render_call_resumed(const struct req *r)
{
    return r->async != NULL;
}

enum MHD_Result render_call_finish(struct req *r)
{
    struct render_call *c = r->async;
    r->async = NULL;
    r->async_free = NULL;
    enum MHD_Result ret;
    if (c->rc < 0) {
        http_page_error(c->img, c->spec.module, "", &c->err);
        ret = http_send_error(r, &c->err);
    } else {
        ret = send_body(r, c->img, &c->spec, c->out, c->len);
        c->out = NULL;
    }
    call_free(c);
    return ret;
}

void render_call_cache_day(void *arg, struct req *r, struct image *img,
                           struct MHD_Response *resp)
{
    (void)arg;
    (void)r;
    (void)img;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=86400");
}
