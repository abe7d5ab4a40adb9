/*
 * route_mesh_simplify.c - POST /v1/meshes/simplify?faces=N|ratio=R
 *                         &format=glb|ply|obj&interp=exact|paper
 *
 * The body is a triangle mesh (PLY ascii or binary, OBJ, GLB; sniffed);
 * the answer is the same mesh simplified by vertex clustering with
 * face-count control (Kanaya et al.; lib/mesh/cluster.h), exactly what
 * `gigaview simplify` writes.  X-Faces-Asked, X-Faces and X-Vertices tell
 * the counts.
 *
 * Reading the file and simplifying it are a job for the sandboxed filter
 * worker processes (server/filter_jobs.c, GV_WORKER_SIMPLIFY in
 * filters/worker.h): the readers parse what a client sent, so they run
 * under the workers' seccomp filter and memory limit, and a reader that
 * crashes or loops costs a worker, not gigaviewd.  The handler checks the
 * query, holds an admission place (503 busy as for filters), suspends the
 * connection and queues the job with the body, borrowed until the job is
 * done; the pool's callback resumes the connection, and the handler,
 * called again, answers.  The worker selects on its own EGL context (the
 * same mesh as the CPU's, byte for byte).  With no worker pool (gpu =
 * off, no EGL, filter_workers = 0) the answer is the filters' 503, and
 * 501 in a build without the GPU.
 *
 * Limits, each a configuration key: the body (simplify_max_bytes, 413,
 * refused before reading when announced), the input's triangles and the
 * faces asked (simplify_max_faces, 413; vertices up to three times that),
 * and the job's time in the worker (simplify_time_limit, 504: the octree
 * build stops at it, and the worker is killed if the job as a whole runs
 * past it).  A malformed file is 400 with the reader's message, an
 * unsupported variant (big-endian PLY, external glTF buffers) 501, a
 * worker that dies during the job 500.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "filter_call.h"
#include "filter_jobs.h"
#include "mesh/cluster_run.h"
#include "routes.h"

/* A request waiting for a worker (r->async). */
struct call {
    struct filter_job fj;
};

static void call_free(struct call *c)
{
    if (!c)
        return;
    free(c->fj.res.mesh);
    free(c->fj.res.out);
    free(c);
}

/* r->async_free: the client went away while the job ran. */
static void call_free_any(void *c)
{
    call_free(c);
}

static int parse(struct req *r, struct gv_simplify_opts *o,
                 struct gv_error *err)
{
    const struct settings *cfg = r->srv->cfg;
    memset(o, 0, sizeof *o);
    o->ratio = -1;
    const char *f = http_query(r, "faces"), *ra = http_query(r, "ratio");
    if (!f == !ra)
        return gv_fail(err, GV_EINVAL, "simplify: give faces=N or ratio=R "
                       "(one of them)");
    if (f) {
        uint32_t n;
        if (http_parse_u32(f, UINT32_MAX, &n) < 0 || n == 0)
            return gv_fail(err, GV_EINVAL, "simplify: faces must be a "
                           "positive integer");
        o->faces = n;
    } else {
        char *end;
        o->ratio = strtod(ra, &end);
        if (end == ra || *end || !(o->ratio >= 0 && o->ratio <= 1))
            return gv_fail(err, GV_EINVAL, "simplify: ratio must be a number "
                           "in [0, 1]");
    }
    const char *fmt = http_query(r, "format");
    if (!fmt)
        fmt = "glb";
    if (gv_mesh_format_parse(fmt, &o->format) < 0 ||
        o->format == GV_MESH_QMESH)
        return gv_fail(err, GV_EINVAL, "simplify: format must be glb, ply or "
                       "obj");
    const char *in = http_query(r, "interp");
    if (in && strcmp(in, "paper") == 0)
        o->mode = GV_CLUSTER_PAPER;
    else if (in && strcmp(in, "exact") != 0)
        return gv_fail(err, GV_EINVAL, "simplify: interp must be exact or "
                       "paper");
    if (!r->body_len)
        return gv_fail(err, GV_EINVAL, "simplify: the body must be a mesh "
                       "file (PLY, OBJ or GLB)");
    uint64_t mf = cfg->simplify_max_faces;
    o->max_faces = (uint32_t)mf;
    o->lim.max_bytes = cfg->simplify_max_bytes;
    o->lim.max_tris = (uint32_t)mf;
    o->lim.max_verts = 3 * mf > UINT32_MAX ? UINT32_MAX : (uint32_t)(3 * mf);
    o->time_limit = cfg->simplify_time_limit;
    return 0;
}

/* The worker's verdict on a failed job, or what became of the job. */
static enum MHD_Result send_job_error(struct req *r, struct filter_job *j)
{
    if (j->status == FILTER_JOB_DONE) {
        struct gv_error err = j->res.err;
        if (err.code == GV_ELIMIT && strstr(err.text, "limit"))
            strncat(err.text, " (simplify_max_faces or simplify_max_bytes)",
                    sizeof err.text - strlen(err.text) - 1);
        /* the client's file, not our data */
        gv_error_recode(&err, GV_ECORRUPT, GV_EINVAL);
        return http_send_error(r, &err);
    }
    if (j->status == FILTER_JOB_UNAVAILABLE || j->status == FILTER_JOB_CANCELLED)
        return http_send_fail(r, j->err.code, j->err.text, "Retry-After", "5");
    return http_send_error(r, &j->err);
}

static enum MHD_Result finish(struct req *r, struct call *c)
{
    struct filter_job *j = &c->fj;
    if (j->status != FILTER_JOB_DONE || j->res.failed)
        return send_job_error(r, j);
    const struct gv_simplify_stats *st = &j->res.sstats;
    size_t len = j->res.mesh_len;
    struct MHD_Response *resp = http_response_owned(
        j->res.mesh, len, gv_mesh_format_mime(j->job.simplify.format));
    j->res.mesh = NULL; /* the response's now, or freed */
    if (!resp)
        return http_send_errorf(r, GV_ENOMEM, "simplify: out of memory");
    char ms[32];
    http_header_int(resp, "X-Faces-Asked", (long long)st->asked);
    http_header_int(resp, "X-Faces", st->out_tris);
    http_header_int(resp, "X-Vertices", st->out_verts);
    snprintf(ms, sizeof ms, "%.3f", j->worker_ms);
    MHD_add_response_header(resp, "X-Gigaview-Worker-Ms", ms);
    MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                            "X-Faces-Asked, X-Faces, X-Vertices, "
                            "X-Gigaview-Worker-Ms");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    return http_send(r, 200, resp, len);
}

enum MHD_Result route_mesh_simplify(struct req *r)
{
    enum MHD_Result ret;
    struct call *c = filter_call_resumed(r);
    if (c) { /* resumed: the worker has answered, or the job failed */
        ret = finish(r, c);
        call_free(c);
        return ret;
    }
    struct gv_error err = {0};
    struct gv_simplify_opts o;
    if (parse(r, &o, &err) < 0)
        return http_send_error(r, &err);
    if (o.faces > o.max_faces) /* refused before it reaches a worker */
        return http_send_errorf(r, GV_ELIMIT, "simplify: %llu faces asked, "
                                "the limit is %u (simplify_max_faces or "
                                "simplify_max_bytes)",
                                (unsigned long long)o.faces, o.max_faces);
    if (!r->srv->filters)
        return http_send_fail(r, r->srv->filter_code, r->srv->filter_reason,
                              NULL, NULL);
    if (filter_jobs_reserve(r->srv->filters) < 0) {
        char msg[160];
        snprintf(msg, sizeof msg, "simplify: %llu filter or simplify jobs are "
                 "queued or running (filter_max_jobs), or the server is "
                 "stopping; try again",
                 (unsigned long long)r->srv->cfg->filter_max_jobs);
        return http_send_fail(r, GV_EBUSY, msg, "Retry-After", "1");
    }
    c = calloc(1, sizeof *c);
    if (!c) {
        filter_jobs_unreserve(r->srv->filters);
        return http_send_errorf(r, GV_ENOMEM, "simplify: out of memory");
    }
    struct gv_worker_job *job = &c->fj.job;
    job->op = GV_WORKER_SIMPLIFY;
    job->mesh = (const uint8_t *)r->body; /* lives as long as r */
    job->mesh_len = r->body_len;
    job->simplify = o;
    /* The answer's cap: a text vertex or triangle takes well under 64
     * bytes (OBJ with %.9g coordinates). */
    job->max_out = 65536 + 64 * ((uint64_t)o.lim.max_verts + o.lim.max_tris);
    double ms = ceil(r->srv->cfg->simplify_time_limit * 1000);
    c->fj.timeout_ms = ms > 3600000 ? 3600000 : (int)ms;
    c->fj.timeout_key = "simplify_time_limit";
    return filter_call_suspend(r, &c->fj, c, call_free_any);
}
