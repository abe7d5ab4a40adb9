/*
 * route_filters.c - filter graphs over HTTP (docs/API.md, "Filters"):
 *
 *   GET    /v1/filters              the stock and stored graphs
 *   POST   /v1/filters              validate, compile in a worker, store
 *   GET    /v1/filters/{fid}        a graph's document and plan
 *   DELETE /v1/filters/{fid}        remove a stored graph
 *   POST   /v1/images/{id}/filter   run a graph over a region of an image
 *
 * The two POSTs that need a worker never block an HTTP thread on it: the
 * handler validates everything it can, holds an admission place
 * (filter_jobs_reserve: 503 with Retry-After when the queue is full),
 * decodes the padded region, suspends the connection and queues the job.
 * The pool's done() callback resumes the connection; libmicrohttpd then
 * calls the handler again, which finds its call in r->async and answers.
 * Graph validation failures are 400 (docs/FILTERS.md section 2, limits
 * included); a job past its time limit is 504, a worker that died is 500,
 * no worker (gpu = off, no EGL) is 503 and a build without the GPU 501.  Each is a gv_code (the pool sets
 * them, filter_jobs.c) that server/http.c's error table turns into the
 * status and the JSON body.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "filter.h"
#include "filter_call.h"
#include "filter_jobs.h"
#include "filter_output.h"
#include "filter_store.h"
#include "render/samples_region.h"
#include "render/store_decoder.h"
#include "store/geometry.h"
#include "log.h"
#include "routes.h"

/* A request waiting for a worker (r->async). */
struct call {
    struct filter_job fj;
    char *doc;
    size_t doc_len;
    double *values;
    uint8_t *rgba;
    uint8_t *codes;     /* the values inputs' samples (gv_filter_input) */
    int ncodes;         /* their channels, 0 when the graph reads none */
    double codes_scale, codes_offset;
    enum filter_output_form form;
    double scale;
    int channels;
    uint32_t level, px, py, pw, ph;  /* the padded region decoded */
};

static void call_free(struct call *c)
{
    if (!c)
        return;
    free(c->doc);
    free(c->values);
    free(c->rgba);
    free(c->codes);
    free(c->fj.res.out);
    free(c);
}

/* r->async_free: the client went away while the job ran. */
static void call_free_any(void *c)
{
    call_free(c);
}

static void limits(const struct settings *cfg, struct gv_filter_limits *lim)
{
    lim->max_json_bytes = (size_t)cfg->filter_max_json_bytes;
    lim->max_json_depth = (int)cfg->filter_max_json_depth;
    lim->max_modules = (int)cfg->filter_max_modules;
    lim->max_glsl_bytes = (size_t)cfg->filter_max_glsl_bytes;
    lim->max_padding = (int)cfg->filter_max_padding;
}

/* A graph that does not parse: 400 whatever the cause, limits included
 * (docs/FILTERS.md section 2). */
static void invalid_graph(struct gv_error *err)
{
    gv_error_recode(err, GV_ELIMIT, GV_EINVAL);
}

/* No pool: 503 (gpu = off, no EGL, no worker program), or 501 in a build
 * without the GPU. */
static enum MHD_Result send_no_filters(struct req *r)
{
    return http_send_fail(r, r->srv->filter_code, r->srv->filter_reason, NULL, NULL);
}

static enum MHD_Result send_busy(struct req *r)
{
    char msg[160];
    snprintf(msg, sizeof msg, "filter: %llu jobs are queued or running "
             "(filter_max_jobs), or the server is stopping; try again",
             (unsigned long long)r->srv->cfg->filter_max_jobs);
    return http_send_fail(r, GV_EBUSY, msg, "Retry-After", "1");
}

/* The answer for a job that did not produce a result: the worker's
 * verdict, or what became of the job (err: timeout, crash, no worker). */
static enum MHD_Result send_job_error(struct req *r, struct filter_job *j)
{
    if (j->status == FILTER_JOB_DONE)
        return http_send_error(r, &j->res.err);
    if (j->status == FILTER_JOB_UNAVAILABLE || j->status == FILTER_JOB_CANCELLED)
        return http_send_fail(r, j->err.code, j->err.text, "Retry-After", "5");
    return http_send_error(r, &j->err);
}

/* Writes need auth_token configured and presented.  0, or -1 with *ret. */
static int check_auth(struct req *r, enum MHD_Result *ret)
{
    if (!r->srv->cfg->auth_token[0]) {
        *ret = http_send_fail(r, GV_EPERM,
                              "filter: storing and deleting graphs is disabled: "
                              "no auth_token is configured", NULL, NULL);
        return -1;
    }
    if (!http_authorized(r)) {
        *ret = http_send_fail(r, GV_EAUTH,
                              "filter: this needs the header 'Authorization: "
                              "Bearer <auth_token>'", "WWW-Authenticate",
                              "Bearer realm=\"gigaview\"");
        return -1;
    }
    return 0;
}

/* Queue c's job and suspend the connection until it is done. */
static enum MHD_Result suspend_on(struct req *r, struct call *c)
{
    return filter_call_suspend(r, &c->fj, c, call_free_any);
}

/* ------------------------------------------------------------ GET list */

enum MHD_Result route_filters_list(struct req *r)
{
    json_t *j = filter_store_list(r->srv->filter_store);
    if (!j)
        return http_send_errorf(r, GV_ENOMEM, "filter: out of memory");
    return http_send_json(r, 200, j);
}

/* ------------------------------------------------------------ GET one */

enum MHD_Result route_filter_get(struct req *r)
{
    struct gv_error err = {0};
    char *doc;
    size_t len;
    int stock;
    if (filter_store_get(r->srv->filter_store, r->param[0], &doc, &len, &stock,
                         &err) < 0)
        return http_send_error(r, &err);
    struct gv_filter_limits lim;
    limits(r->srv->cfg, &lim);
    struct gv_filter_graph *g = gv_filter_graph_parse(doc, len, &lim, &err);
    json_t *graph = json_loadb(doc, len, 0, NULL);
    free(doc);
    if (!g || !graph) {
        json_decref(graph);
        gv_filter_graph_free(g);
        return http_send_errorf(r, GV_EIO, "filter: stored graph '%s' no longer "
                                "parses: %s", r->param[0], g ? "bad JSON" : err.text);
    }
    json_t *j = json_pack("{s:s,s:b,s:o,s:o}", "id", r->param[0], "stock", stock,
                          "graph", graph, "plan", gv_filter_graph_describe(g));
    gv_filter_graph_free(g);
    if (!j)
        return http_send_errorf(r, GV_ENOMEM, "filter: out of memory");
    return http_send_json(r, 200, j);
}

/* ------------------------------------------------------------ DELETE */

enum MHD_Result route_filter_delete(struct req *r)
{
    enum MHD_Result ret;
    if (check_auth(r, &ret) < 0)
        return ret;
    struct gv_error err = {0};
    int rc = filter_store_delete(r->srv->filter_store, r->param[0], &err);
    if (rc == 1) {
        char msg[160], esc[80];
        snprintf(msg, sizeof msg, "filter: '%s' is a stock graph and cannot be "
                 "deleted", log_escape(esc, sizeof esc, r->param[0]));
        return http_send_fail(r, GV_EPERM, msg, NULL, NULL);
    }
    if (rc < 0)
        return http_send_error(r, &err);
    return http_send_empty(r, 204, NULL, NULL);
}

/* ------------------------------------------------------------ POST store */

static enum MHD_Result finish_store(struct req *r, struct call *c)
{
    if (c->fj.status != FILTER_JOB_DONE || c->fj.res.failed)
        return send_job_error(r, &c->fj);
    char id[GV_FILTER_ID_MAX];
    int created;
    struct gv_error err = {0};
    if (filter_store_put(r->srv->filter_store, c->doc, c->doc_len, id, &created,
                         &err) < 0)
        return http_send_error(r, &err);
    char base[300], where[400];
    http_base_url(r, base, sizeof base);
    snprintf(where, sizeof where, "%s/v1/filters/%s", base, id);
    log_msg(LOG_INFO, "filter", "%s graph %s (%zu bytes)",
            created ? "stored" : "already had", id, c->doc_len);
    return http_send_json_header(r, created ? 201 : 200,
                                 json_pack("{s:s,s:b,s:s}", "id", id, "created",
                                           created, "url", where),
                                 MHD_HTTP_HEADER_LOCATION, where);
}

enum MHD_Result route_filters_post(struct req *r)
{
    enum MHD_Result ret;
    struct call *c = filter_call_resumed(r);
    if (c) { /* resumed: the worker has compiled it, or failed */
        ret = finish_store(r, c);
        call_free(c);
        return ret;
    }
    if (check_auth(r, &ret) < 0)
        return ret;
    char why[320];
    if (!filter_store_writable(r->srv->filter_store, why, sizeof why))
        return http_send_fail(r, r->srv->cfg->filter_dir[0] ? GV_EUNAVAIL : GV_EPERM,
                              why, NULL, NULL);
    if (!r->body_len)
        return http_send_errorf(r, GV_EINVAL, "filter: the body must be a graph "
                                "document (docs/FILTERS.md)");
    struct gv_error err = {0};
    struct gv_filter_limits lim;
    limits(r->srv->cfg, &lim);
    struct gv_filter_graph *g = gv_filter_graph_parse(r->body, r->body_len, &lim, &err);
    if (!g) {
        invalid_graph(&err);
        return http_send_error(r, &err);
    }
    gv_filter_graph_free(g);
    if (!r->srv->filters)
        return send_no_filters(r);
    if (filter_jobs_reserve(r->srv->filters) < 0)
        return send_busy(r);
    c = calloc(1, sizeof *c);
    if (c)
        c->doc = malloc(r->body_len + 1);
    if (!c || !c->doc) {
        call_free(c);
        filter_jobs_unreserve(r->srv->filters);
        return http_send_errorf(r, GV_ENOMEM, "filter: out of memory");
    }
    memcpy(c->doc, r->body, r->body_len + 1);
    c->doc_len = r->body_len;
    c->fj.job.op = GV_WORKER_COMPILE;
    c->fj.timeout_ms = (int)r->srv->cfg->filter_compile_timeout_ms;
    c->fj.timeout_key = "filter_compile_timeout_ms";
    c->fj.job.lim = lim;
    c->fj.job.doc = c->doc;
    c->fj.job.doc_len = c->doc_len;
    return suspend_on(r, c);
}

/* ------------------------------------------------------------ POST run */

/* Integer member `key` of o in [lo, hi], or def if absent (def < 0:
 * required).  0 or -1 with *err. */
static int get_uint(const json_t *o, const char *key, int64_t def, int64_t lo,
                    int64_t hi, uint32_t *out, struct gv_error *err)
{
    json_t *v = json_object_get(o, key);
    if (!v && def >= 0) {
        *out = (uint32_t)def;
        return 0;
    }
    if (!json_is_integer(v) || json_integer_value(v) < lo ||
        json_integer_value(v) > hi)
        return gv_fail(err, GV_EINVAL, "filter: \"%s\" must be an integer in "
                       "%lld..%lld", key, (long long)lo, (long long)hi);
    *out = (uint32_t)json_integer_value(v);
    return 0;
}

/* An array of n integers, each in [lo, GV_MAX_DIM]. */
static int get_uints(const json_t *o, const char *key, size_t n, const int64_t *lo,
                     uint32_t *out, struct gv_error *err)
{
    json_t *a = json_object_get(o, key);
    if (!json_is_array(a) || json_array_size(a) != n)
        return gv_fail(err, GV_EINVAL, "filter: \"%s\" must be an array of %zu "
                       "integers", key, n);
    for (size_t i = 0; i < n; i++) {
        json_t *v = json_array_get(a, i);
        if (!json_is_integer(v) || json_integer_value(v) < lo[i] ||
            json_integer_value(v) > GV_MAX_DIM)
            return gv_fail(err, GV_EINVAL, "filter: \"%s\"[%zu] must be an "
                           "integer in %lld..%u", key, i, (long long)lo[i],
                           GV_MAX_DIM);
        out[i] = (uint32_t)json_integer_value(v);
    }
    return 0;
}

/* The request body as a JSON object with only the documented keys: a new
 * reference, or NULL with *err. */
static json_t *load_body(const struct req *r, struct gv_error *err)
{
    static const char *const keys[] = {"graph", "filter", "params", "level",
                                       "region", "format", "scale", "viewport"};
    json_error_t je;
    if (!r->body_len) {
        gv_fail(err, GV_EINVAL, "filter: the body must be a JSON object "
                "(docs/API.md, Filters)");
        return NULL;
    }
    json_t *b = json_loadb(r->body, r->body_len, JSON_REJECT_DUPLICATES, &je);
    if (!b) {
        gv_fail(err, GV_EINVAL, "filter: request body: JSON: %s at line %d "
                "column %d", je.text, je.line, je.column);
        return NULL;
    }
    if (!json_is_object(b)) {
        gv_fail(err, GV_EINVAL, "filter: the body must be a JSON object");
        json_decref(b);
        return NULL;
    }
    const char *k;
    json_t *v;
    json_object_foreach(b, k, v) {
        size_t i = 0;
        while (i < sizeof keys / sizeof keys[0] && strcmp(k, keys[i]))
            i++;
        if (i == sizeof keys / sizeof keys[0]) {
            char esc[80];
            gv_fail(err, GV_EINVAL, "filter: unknown key \"%s\" in the request",
                    log_escape(esc, sizeof esc, k));
            json_decref(b);
            return NULL;
        }
    }
    return b;
}

/* The graph document of body b into c->doc: "graph" inline, or "filter"
 * naming a stock or stored graph (GV_ENOTFOUND when there is none).  0 or
 * -1 with *err. */
static int load_document(struct req *r, const json_t *b, struct call *c,
                         struct gv_error *err)
{
    json_t *graph = json_object_get(b, "graph"), *fid = json_object_get(b, "filter");
    if (!graph == !fid)
        return gv_fail(err, GV_EINVAL, "filter: give exactly one of \"graph\" (a "
                       "graph document) and \"filter\" (a graph id)");
    if (graph) {
        if (!json_is_object(graph))
            return gv_fail(err, GV_EINVAL, "filter: \"graph\" must be a graph object");
        c->doc = json_dumps(graph, JSON_COMPACT);
        if (!c->doc)
            return gv_fail(err, GV_ENOMEM, "filter: out of memory");
        c->doc_len = strlen(c->doc);
        return 0;
    }
    int stock;
    if (!json_is_string(fid))
        return gv_fail(err, GV_EINVAL, "filter: \"filter\" must be a graph id");
    return filter_store_get(r->srv->filter_store, json_string_value(fid), &c->doc,
                            &c->doc_len, &stock, err);
}

/* Parse c's document into *g and the body's "params" into c->values. */
static int load_graph(struct req *r, const json_t *b, struct call *c,
                      struct gv_filter_graph **g, struct gv_error *err)
{
    struct gv_filter_limits lim;
    limits(r->srv->cfg, &lim);
    *g = gv_filter_graph_parse(c->doc, c->doc_len, &lim, err);
    if (!*g) {
        invalid_graph(err);
        return -1;
    }
    c->fj.job.lim = lim;
    c->channels = (*g)->output_channels;
    c->values = malloc(((size_t)(*g)->nparams + 1) * sizeof *c->values);
    if (!c->values)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    return gv_filter_params(*g, json_object_get(b, "params"), c->values, err);
}

/* "level", "region" (roi) and "viewport" (0, 0 when absent). */
static int load_area(const json_t *b, struct call *c, uint32_t *roi,
                     uint32_t *viewport, struct gv_error *err)
{
    static const int64_t lo4[4] = {0, 0, 1, 1}, lo2[2] = {1, 1};
    if (get_uint(b, "level", 0, 0, 255, &c->level, err) < 0 ||
        get_uints(b, "region", 4, lo4, roi, err) < 0)
        return -1;
    viewport[0] = viewport[1] = 0;
    if (json_object_get(b, "viewport") &&
        get_uints(b, "viewport", 2, lo2, viewport, err) < 0)
        return -1;
    return 0;
}

/* "format" (default png) and "scale" (default 65535). */
static int load_output(const json_t *b, struct call *c, struct gv_error *err)
{
    json_t *f = json_object_get(b, "format");
    c->form = FILTER_OUT_PNG;
    if (f && (!json_is_string(f) || filter_output_parse(json_string_value(f),
                                                        &c->form) < 0))
        return gv_fail(err, GV_EINVAL, "filter: \"format\" must be \"png\", "
                       "\"tiff16\", \"tiff32f\" or \"raw\"");
    json_t *s = json_object_get(b, "scale");
    c->scale = 65535;
    if (s) {
        c->scale = json_is_number(s) ? json_number_value(s) : NAN;
        if (!isfinite(c->scale) || c->scale <= 0)
            return gv_fail(err, GV_EINVAL, "filter: \"scale\" must be a positive "
                           "number");
    }
    return 0;
}

/* Parse the request body into c (doc, values, output form, level,
 * region, viewport) and *g, in the order of docs/API.md, so that the
 * first failure is the one reported.  0 or -1 with *err (GV_EINVAL,
 * GV_ENOTFOUND for an unknown stored graph, GV_ENOMEM). */
static int parse_request(struct req *r, struct call *c,
                         struct gv_filter_graph **g, uint32_t *roi,
                         uint32_t *viewport, struct gv_error *err)
{
    json_t *b = load_body(r, err);
    if (!b)
        return -1;
    int rc = load_document(r, b, c, err) < 0 || load_graph(r, b, c, g, err) < 0 ||
                     load_area(b, c, roi, viewport, err) < 0 ||
                     load_output(b, c, err) < 0
                 ? -1 : 0;
    json_decref(b);
    return rc;
}

/* Expand n pixels of c channels at buf to RGBA in place (buf holds
 * n * 4 bytes); gray becomes (g, g, g, 255), RGB gets alpha 255. */
static void expand_rgba(uint8_t *buf, size_t n, int c)
{
    for (size_t i = n; i-- > 0;) {
        const uint8_t *s = buf + i * (size_t)c;
        uint8_t r = s[0], g = c >= 3 ? s[1] : s[0], b = c >= 3 ? s[2] : s[0];
        uint8_t a = c == 4 ? s[3] : 255;
        uint8_t *o = buf + i * 4;
        o[0] = r;
        o[1] = g;
        o[2] = b;
        o[3] = a;
    }
}

static enum MHD_Result finish_run(struct req *r, struct call *c)
{
    if (c->fj.status != FILTER_JOB_DONE || c->fj.res.failed)
        return send_job_error(r, &c->fj);
    const struct gv_filter_input *in = &c->fj.job.in;
    uint8_t *out = NULL;
    size_t len;
    struct gv_error err = {0};
    if (filter_output_encode(c->form, c->fj.res.out, in->roi_w, in->roi_h,
                             c->channels, c->scale, &out, &len, &err) < 0)
        return http_send_error(r, &err);
    struct MHD_Response *resp =
        http_response_owned(out, len, filter_output_type(c->form));
    if (!resp)
        return http_send(r, 200, NULL, 0);
    const struct gv_filter_stats *st = &c->fj.res.stats;
    char s[96];
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    http_header_int(resp, "X-Gigaview-Width", in->roi_w);
    http_header_int(resp, "X-Gigaview-Height", in->roi_h);
    http_header_int(resp, "X-Gigaview-Channels", c->channels);
    http_header_int(resp, "X-Gigaview-Level", c->level);
    snprintf(s, sizeof s, "%u,%u,%u,%u", c->px, c->py, c->pw, c->ph);
    MHD_add_response_header(resp, "X-Gigaview-Padded-Region", s);
    http_header_int(resp, "X-Gigaview-Filter-Passes", st->passes);
    http_header_int(resp, "X-Gigaview-Filter-Textures", st->textures);
    http_header_int(resp, "X-Gigaview-Filter-Merges", st->merges);
    http_header_int(resp, "X-Gigaview-Filter-Merges-Skipped", st->merges_skipped);
    http_header_int(resp, "X-Gigaview-Filter-Line-Copies", st->line_copies);
    snprintf(s, sizeof s, "%.3f", st->gpu_ms);
    MHD_add_response_header(resp, "X-Gigaview-Filter-Gpu-Ms", s);
    snprintf(s, sizeof s, "%.3f", c->fj.worker_ms);
    MHD_add_response_header(resp, "X-Gigaview-Filter-Worker-Ms", s);
    if (r->srv->cfg->cors_origin[0])
        MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                                "X-Gigaview-Width, X-Gigaview-Height, "
                                "X-Gigaview-Channels, X-Gigaview-Level, "
                                "X-Gigaview-Padded-Region, X-Gigaview-Filter-Passes, "
                                "X-Gigaview-Filter-Textures, X-Gigaview-Filter-Merges, "
                                "X-Gigaview-Filter-Merges-Skipped, "
                                "X-Gigaview-Filter-Line-Copies, "
                                "X-Gigaview-Filter-Gpu-Ms, X-Gigaview-Filter-Worker-Ms");
    return http_send(r, 200, resp, len);
}

/*
 * The padded region of roi (x, y, w, h) that g reads, per docs/FILTERS.md
 * section 5: pad, align the left and top edges down to multiples of
 * g->align, clip to the level (lw x lh).  roi lies inside the level.
 */
static void pad_region(const struct gv_filter_graph *g, const uint32_t *roi,
                       uint32_t lw, uint32_t lh, struct call *c)
{
    int64_t a = g->align > 0 ? g->align : 1;
    int64_t x0 = (int64_t)roi[0] - g->pad_left, y0 = (int64_t)roi[1] - g->pad_top;
    int64_t x1 = (int64_t)roi[0] + roi[2] + g->pad_right;
    int64_t y1 = (int64_t)roi[1] + roi[3] + g->pad_bottom;
    x0 = x0 < 0 ? 0 : x0 - x0 % a;
    y0 = y0 < 0 ? 0 : y0 - y0 % a;
    x1 = x1 > lw ? lw : x1;
    y1 = y1 > lh ? lh : y1;
    c->px = (uint32_t)x0;
    c->py = (uint32_t)y0;
    c->pw = (uint32_t)(x1 - x0);
    c->ph = (uint32_t)(y1 - y0);
}

/* Check roi against c->level of img and set c's padded region, within
 * max_filter_pixels.  0 or -1 with *err. */
static int place_region(struct req *r, const struct image *img,
                        const struct gv_filter_graph *g, const uint32_t *roi,
                        struct call *c, struct gv_error *err)
{
    const struct gv_geometry *geo = &img->info->geometry;
    uint32_t lw, lh, x = roi[0], y = roi[1], w = roi[2], h = roi[3];
    if (gv_level_size(geo, (int)c->level, &lw, &lh) < 0)
        return gv_fail(err, GV_EINVAL, "filter: no level %u (0..%d)", c->level,
                       geo->root + geo->root_mips - 1);
    if ((uint64_t)x + w > lw || (uint64_t)y + h > lh)
        return gv_fail(err, GV_EINVAL, "filter: region %u,%u,%u,%u is outside "
                       "level %u (%ux%u)", x, y, w, h, c->level, lw, lh);
    pad_region(g, roi, lw, lh, c);
    uint64_t pixels = (uint64_t)c->pw * c->ph;
    if (pixels > r->srv->cfg->max_filter_pixels)
        return gv_fail(err, GV_ELIMIT, "filter: the padded region %lldx%lld "
                       "(%llu pixels) exceeds max_filter_pixels (%llu)",
                       (long long)c->pw, (long long)c->ph,
                       (unsigned long long)pixels,
                       (unsigned long long)r->srv->cfg->max_filter_pixels);
    return 0;
}

/* A store of codes' samples of c's padded region into c->codes,
 * little-endian, with its scale and offset (docs/FILTERS.md section 3.1,
 * values; an image's values are its picture, made by the worker). */
static int decode_values(struct gv_decoder *d, const struct gv_header *h, int channels,
                         struct call *c, struct gv_error *err)
{
    const size_t n = (size_t)c->pw * c->ph * (size_t)channels;
    if (!(c->codes = malloc(n * 2)))
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    if (gv_decoder_copy_region(d, "filter", (int)c->level, c->px, c->py, c->pw, c->ph,
                               c->codes, err) < 0)
        return -1;
    c->ncodes = channels;
    c->codes_scale = h->height_scale;
    c->codes_offset = h->height_offset;
    for (size_t i = 0; i < n; i++) {   /* host order to little-endian, in place */
        uint16_t v;
        memcpy(&v, c->codes + 2 * i, 2);
        gv_put16(c->codes + 2 * i, v);
    }
    return 0;
}

/* Decode c's padded region of img as RGBA (its 8-bit picture) into
 * c->rgba, and its samples where graph g reads values.  0 or -1. */
static int decode_input(struct image *img, const struct gv_filter_graph *g,
                        struct call *c, struct gv_error *err)
{
    size_t pixels = (size_t)c->pw * c->ph;
    const struct gv_header *h = &img->info->header;
    c->rgba = malloc(pixels * 4);
    struct gv_decoder *d = image_decoder_get(img);
    int rc = 0;
    if (!c->rgba || !d)
        rc = gv_fail(err, GV_ENOMEM, "filter: out of memory");
    else if (gv_decode_region(d, (int)c->level, c->px, c->py, c->pw, c->ph,
                              c->rgba, err) < 0)
        rc = -1;
    else if (g->value_channels && gv_header_codes(h) &&
             decode_values(d, h, img->info->geometry.channels, c, err) < 0)
        rc = -1;
    else
        expand_rgba(c->rgba, pixels, gv_display_channels(h));
    image_decoder_put(img, d);
    return rc;
}

/* The RUN job for c: its document and inputs, the region roi of the
 * padded region, in the level's coordinates at (px, py). */
static void fill_job(struct call *c, const struct gv_filter_graph *g,
                     const uint32_t *roi, const uint32_t *viewport)
{
    struct gv_worker_job *job = &c->fj.job;
    job->op = GV_WORKER_RUN;
    job->doc = c->doc;
    job->doc_len = c->doc_len;
    job->nparams = g->nparams;
    job->in.w = c->pw;
    job->in.h = c->ph;
    job->in.rgba = c->rgba;
    job->in.roi_x = roi[0] - c->px;
    job->in.roi_y = roi[1] - c->py;
    job->in.roi_w = roi[2];
    job->in.roi_h = roi[3];
    job->in.abs_x = c->px;
    job->in.abs_y = c->py;
    job->in.viewport_w = viewport[0];
    job->in.viewport_h = viewport[1];
    job->in.params = c->values;
    job->in.values = c->codes;
    job->in.nvalues = c->ncodes;
    job->in.values_scale = c->codes_scale;
    job->in.values_offset = c->codes_offset;
}

enum MHD_Result route_image_filter(struct req *r)
{
    enum MHD_Result ret;
    struct call *c = filter_call_resumed(r);
    if (c) { /* resumed */
        ret = finish_run(r, c);
        call_free(c);
        return ret;
    }
    if (!r->srv->filters)
        return send_no_filters(r);
    struct gv_error err = {0};
    gv_error_clear(&err);
    struct gv_filter_graph *g = NULL;
    struct image *img = NULL;
    int reserved = 0;
    uint32_t roi[4], viewport[2];
    c = calloc(1, sizeof *c);
    if (!c)
        return http_send_errorf(r, GV_ENOMEM, "filter: out of memory");
    if (parse_request(r, c, &g, roi, viewport, &err) < 0) {
        ret = http_send_error(r, &err);
        goto fail;
    }
    img = http_image(r, &ret);
    if (!img)
        goto fail;
    if (place_region(r, img, g, roi, c, &err) < 0) {
        ret = http_send_error(r, &err);
        goto fail;
    }
    if (filter_jobs_reserve(r->srv->filters) < 0) {
        ret = send_busy(r);
        goto fail;
    }
    reserved = 1;
    if (decode_input(img, g, c, &err) < 0) {
        ret = http_send_error(r, &err);
        goto fail;
    }
    image_put(img);
    fill_job(c, g, roi, viewport);
    gv_filter_graph_free(g);
    return suspend_on(r, c);
fail:
    image_put(img);
    if (reserved)
        filter_jobs_unreserve(r->srv->filters);
    gv_filter_graph_free(g);
    call_free(c);
    return ret;
}
