/*
 * worker.c - the filter job protocol (worker.h): framing, both ends'
 * encoders and validating decoders, and the worker's loop (filter graphs
 * and mesh simplification jobs).
 *
 * The server's end is non-blocking and every read or write waits in
 * poll() for what is left of the job's deadline, so a worker that stops
 * reading or writing costs the server its time limit and no more.  The
 * worker's end blocks: the server bounds it.  Bodies are decoded through
 * a cursor that fails on any read past the frame, and every length is
 * compared with what the job implies before anything is allocated.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "config.h"
#include "worker.h"
#ifdef GV_HAVE_GPU
#include "gpu/gpu_cluster.h"
#endif

/* Largest graph document a frame may carry, whatever the limits say: the
 * configured max_json_bytes is far below (64 KiB by default). */
#define DOC_MAX (16u << 20)
/* Parameters per run: GV_FILTER_MAX_PARAMS per module, 64 modules at
 * most (graph.c caps max_modules there). */
#define PARAMS_MAX (64 * GV_FILTER_MAX_PARAMS)
#define LIMITS_BYTES 28   /* u64 + u32 + u32 + u64 + u32 */
#define GEOMETRY_BYTES 68 /* 6 u32, 2 i64, 2 u32; values: u32, 2 f64 */
#define VALUES_MAX 8      /* channels of values a run may carry */
#define STATS_BYTES 36    /* 5 u32, f64, roi_w, roi_h */
#define HELLO_FIXED 12

int64_t gv_worker_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* ------------------------------------------------------------ raw IO */

/* Wait until fd is ready for `events` or the deadline passes. */
static int wait_fd(int fd, short events, int64_t deadline, struct gv_error *err)
{
    for (;;) {
        int ms = -1;
        if (deadline >= 0) {
            int64_t left = deadline - gv_worker_now_ms();
            if (left <= 0) {
                gv_fail(err, GV_EIO, "worker: job time limit reached");
                return GV_WORKER_TIMEOUT;
            }
            ms = left > INT_MAX ? INT_MAX : (int)left;
        }
        struct pollfd p = {fd, events, 0};
        int n = poll(&p, 1, ms);
        if (n > 0)
            return 0; /* ready, or POLLHUP/POLLERR: the next call says */
        if (n < 0 && errno != EINTR) {
            gv_fail_errno(err, errno, "worker: poll");
            return GV_WORKER_BAD;
        }
    }
}

static int io_write(int fd, const void *buf, size_t n, int64_t deadline,
                    struct gv_error *err)
{
    const uint8_t *p = buf;
    while (n > 0) {
        ssize_t k = send(fd, p, n, MSG_NOSIGNAL);
        if (k > 0) {
            p += k;
            n -= (size_t)k;
            continue;
        }
        if (k < 0 && errno == EINTR)
            continue;
        if (k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            int rc = wait_fd(fd, POLLOUT, deadline, err);
            if (rc)
                return rc;
            continue;
        }
        if (k < 0 && (errno == EPIPE || errno == ECONNRESET)) {
            gv_fail(err, GV_EIO, "worker: connection closed by the peer");
            return GV_WORKER_EOF;
        }
        gv_fail_errno(err, errno, "worker: send");
        return GV_WORKER_BAD;
    }
    return 0;
}

static int io_read(int fd, void *buf, size_t n, int64_t deadline,
                   struct gv_error *err)
{
    uint8_t *p = buf;
    while (n > 0) {
        ssize_t k = recv(fd, p, n, 0);
        if (k > 0) {
            p += k;
            n -= (size_t)k;
            continue;
        }
        if (k == 0 || (k < 0 && errno == ECONNRESET)) {
            gv_fail(err, GV_EIO, "worker: connection closed by the peer");
            return GV_WORKER_EOF;
        }
        if (errno == EINTR)
            continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
            int rc = wait_fd(fd, POLLIN, deadline, err);
            if (rc)
                return rc;
            continue;
        }
        gv_fail_errno(err, errno, "worker: recv");
        return GV_WORKER_BAD;
    }
    return 0;
}

/* ------------------------------------------------------ encode, decode */

struct wbuf {
    uint8_t b[128];
    size_t n;
};

static void put_u32(struct wbuf *w, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        w->b[w->n++] = (uint8_t)(v >> (8 * i));
}

static void put_u64(struct wbuf *w, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        w->b[w->n++] = (uint8_t)(v >> (8 * i));
}

static void put_f64(struct wbuf *w, double v)
{
    memcpy(w->b + w->n, &v, 8);
    w->n += 8;
}

static void put_header(struct wbuf *w, enum gv_worker_msg type, uint64_t len)
{
    put_u32(w, GV_WORKER_MAGIC);
    put_u32(w, (uint32_t)type);
    put_u64(w, len);
}

/* A read cursor over a body: reads past the end set `bad` and give 0. */
struct rbuf {
    const uint8_t *p;
    size_t n, off;
    int bad;
};

static const uint8_t *take(struct rbuf *r, size_t k)
{
    if (r->bad || k > r->n - r->off) {
        r->bad = 1;
        return NULL;
    }
    const uint8_t *p = r->p + r->off;
    r->off += k;
    return p;
}

static uint32_t get_u32(struct rbuf *r)
{
    const uint8_t *p = take(r, 4);
    if (!p)
        return 0;
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static uint64_t get_u64(struct rbuf *r)
{
    uint64_t lo = get_u32(r);
    return lo | (uint64_t)get_u32(r) << 32;
}

static double get_f64(struct rbuf *r)
{
    double v = 0;
    const uint8_t *p = take(r, 8);
    if (p)
        memcpy(&v, p, 8);
    return v;
}

/* Read a header; check the magic.  *type and *len set. */
static int recv_header(int fd, int64_t deadline, uint32_t *type, uint64_t *len,
                       struct gv_error *err)
{
    uint8_t h[GV_WORKER_HEADER];
    int rc = io_read(fd, h, sizeof h, deadline, err);
    if (rc)
        return rc;
    struct rbuf r = {h, sizeof h, 0, 0};
    if (get_u32(&r) != GV_WORKER_MAGIC) {
        gv_fail(err, GV_EIO, "worker: bad frame magic");
        return GV_WORKER_BAD;
    }
    *type = get_u32(&r);
    *len = get_u64(&r);
    return 0;
}

/* Copy n bytes of untrusted text into dst (size >= 1) as printable
 * ASCII, so that it is safe in logs and valid UTF-8 in JSON. */
static void copy_text(char *dst, size_t size, const uint8_t *src, size_t n)
{
    if (n >= size)
        n = size - 1;
    for (size_t i = 0; i < n; i++)
        dst[i] = src[i] >= 0x20 && src[i] < 0x7f ? (char)src[i]
                 : src[i] == '\n'                ? ' '
                                                 : '?';
    dst[n] = '\0';
}

/* Body size of a job, or 0 if it cannot be framed. */
static uint64_t job_body_len(const struct gv_worker_job *job)
{
    if (job->op == GV_WORKER_SIMPLIFY)
        return job->mesh_len > GV_WORKER_MESH_MAX
                   ? 0 : GV_WORKER_SIMPLIFY_FIXED + (uint64_t)job->mesh_len;
    if (job->doc_len > DOC_MAX)
        return 0;
    uint64_t n = LIMITS_BYTES + 4 + job->doc_len;
    if (job->op == GV_WORKER_RUN) {
        if (job->nparams < 0 || job->nparams > PARAMS_MAX)
            return 0;
        if (job->in.nvalues < 0 || job->in.nvalues > VALUES_MAX)
            return 0;
        n += 4 + 8 * (uint64_t)job->nparams + GEOMETRY_BYTES +
             (uint64_t)job->in.w * job->in.h * (4 + 2 * (uint64_t)job->in.nvalues);
    }
    return n;
}

static void put_limits(struct wbuf *w, const struct gv_filter_limits *lim)
{
    put_u64(w, lim->max_json_bytes);
    put_u32(w, (uint32_t)lim->max_json_depth);
    put_u32(w, (uint32_t)lim->max_modules);
    put_u64(w, lim->max_glsl_bytes);
    put_u32(w, (uint32_t)lim->max_padding);
}

int gv_worker_send_job(int fd, const struct gv_worker_job *job,
                       int64_t deadline, struct gv_error *err)
{
    uint64_t len = job_body_len(job);
    if (len == 0 || (job->op != GV_WORKER_COMPILE && job->op != GV_WORKER_RUN &&
                     job->op != GV_WORKER_SIMPLIFY)) {
        gv_fail(err, GV_EINVAL, "worker: job cannot be framed");
        return GV_WORKER_BAD;
    }
    struct wbuf w = {.n = 0};
    put_header(&w, (enum gv_worker_msg)job->op, len);
    if (job->op == GV_WORKER_SIMPLIFY) {
        const struct gv_simplify_opts *o = &job->simplify;
        put_u64(&w, o->faces);
        put_f64(&w, o->ratio);
        put_u32(&w, (uint32_t)o->mode);
        put_u32(&w, (uint32_t)o->format);
        put_u64(&w, o->lim.max_bytes);
        put_u32(&w, o->lim.max_verts);
        put_u32(&w, o->lim.max_tris);
        put_u32(&w, o->max_faces);
        put_f64(&w, o->time_limit);
        put_u64(&w, (uint64_t)job->mesh_len);
        int rc = io_write(fd, w.b, w.n, deadline, err);
        return rc ? rc : io_write(fd, job->mesh, job->mesh_len, deadline, err);
    }
    put_limits(&w, &job->lim);
    put_u32(&w, (uint32_t)job->doc_len);
    int rc = io_write(fd, w.b, w.n, deadline, err);
    if (!rc)
        rc = io_write(fd, job->doc, job->doc_len, deadline, err);
    if (rc || job->op == GV_WORKER_COMPILE)
        return rc;
    const struct gv_filter_input *in = &job->in;
    w.n = 0;
    put_u32(&w, (uint32_t)job->nparams);
    rc = io_write(fd, w.b, w.n, deadline, err);
    for (int i = 0; !rc && i < job->nparams; i++) {
        w.n = 0;
        put_f64(&w, in->params[i]);
        rc = io_write(fd, w.b, w.n, deadline, err);
    }
    if (rc)
        return rc;
    w.n = 0;
    put_u32(&w, in->w);
    put_u32(&w, in->h);
    put_u32(&w, in->roi_x);
    put_u32(&w, in->roi_y);
    put_u32(&w, in->roi_w);
    put_u32(&w, in->roi_h);
    put_u64(&w, (uint64_t)in->abs_x);
    put_u64(&w, (uint64_t)in->abs_y);
    put_u32(&w, in->viewport_w);
    put_u32(&w, in->viewport_h);
    put_u32(&w, (uint32_t)in->nvalues);
    put_f64(&w, in->values_scale);
    put_f64(&w, in->values_offset);
    rc = io_write(fd, w.b, w.n, deadline, err);
    if (!rc)
        rc = io_write(fd, in->rgba, (size_t)in->w * in->h * 4, deadline, err);
    if (!rc && in->nvalues)
        rc = io_write(fd, in->values, (size_t)in->w * in->h * 2 * (size_t)in->nvalues,
                      deadline, err);
    return rc;
}

int gv_worker_recv_hello(int fd, int64_t deadline, int *ok, char *text,
                         size_t size, struct gv_error *err)
{
    uint32_t type;
    uint64_t len;
    int rc = recv_header(fd, deadline, &type, &len, err);
    if (rc)
        return rc;
    if (type != GV_WORKER_HELLO || len < HELLO_FIXED ||
        len > HELLO_FIXED + GV_WORKER_MSG_MAX) {
        gv_fail(err, GV_EIO, "worker: expected a hello frame");
        return GV_WORKER_BAD;
    }
    uint8_t b[HELLO_FIXED + GV_WORKER_MSG_MAX];
    if ((rc = io_read(fd, b, (size_t)len, deadline, err)))
        return rc;
    struct rbuf r = {b, (size_t)len, 0, 0};
    uint32_t version = get_u32(&r), good = get_u32(&r), n = get_u32(&r);
    if (version != GV_WORKER_VERSION) {
        gv_fail(err, GV_EIO, "worker: speaks protocol %u, expected %d", version,
                GV_WORKER_VERSION);
        return GV_WORKER_BAD;
    }
    if (good > 1 || n != len - HELLO_FIXED) {
        gv_fail(err, GV_EIO, "worker: malformed hello");
        return GV_WORKER_BAD;
    }
    *ok = (int)good;
    copy_text(text, size, b + HELLO_FIXED, n);
    return 0;
}

/* The DONE answer to a SIMPLIFY job (header read: type, len): counts
 * within the job's limits and a file of at most job->max_out bytes. */
/* Same shape as recv_job below: deliberately separate, each unpacks its own
 * message of the worker protocol. */
static int recv_simplified(int fd, const struct gv_worker_job *job,
                           uint32_t type, uint64_t len, int64_t deadline,
                           struct gv_worker_result *res, struct gv_error *err)
{
    if (type != GV_WORKER_DONE || len < GV_WORKER_SIMPLIFIED_FIXED ||
        len - GV_WORKER_SIMPLIFIED_FIXED > job->max_out ||
        len - GV_WORKER_SIMPLIFIED_FIXED > SIZE_MAX - 1) {
        gv_fail(err, GV_EIO, "worker: unexpected frame (type %u, %llu bytes)",
                type, (unsigned long long)len);
        return GV_WORKER_BAD;
    }
    uint8_t b[GV_WORKER_SIMPLIFIED_FIXED];
    int rc = io_read(fd, b, sizeof b, deadline, err);
    if (rc)
        return rc;
    struct rbuf r = {b, sizeof b, 0, 0};
    struct gv_simplify_stats *st = &res->sstats;
    st->in_verts = get_u32(&r);
    st->in_tris = get_u32(&r);
    st->out_verts = get_u32(&r);
    st->out_tris = get_u32(&r);
    st->asked = get_u64(&r);
    st->level = get_u32(&r);
    st->nnodes = get_u32(&r);
    double *ms[4] = {&st->read_ms, &st->build_ms, &st->select_ms, &st->write_ms};
    for (int i = 0; i < 4; i++) {
        double v = get_f64(&r);
        *ms[i] = isfinite(v) && v >= 0 ? v : 0;
    }
    uint64_t n = get_u64(&r);
    const struct gv_mesh_limits *lim = &job->simplify.lim;
    if (n != len - GV_WORKER_SIMPLIFIED_FIXED || st->in_tris > lim->max_tris ||
        st->in_verts > lim->max_verts || st->out_tris > st->in_tris ||
        st->out_verts > st->in_verts) {
        gv_fail(err, GV_EIO, "worker: malformed simplification answer");
        return GV_WORKER_BAD;
    }
    res->mesh = malloc(n ? (size_t)n : 1);
    if (!res->mesh) {
        gv_fail(err, GV_ENOMEM, "worker: out of memory for a mesh of %llu bytes",
                (unsigned long long)n);
        return GV_WORKER_BAD;
    }
    if ((rc = io_read(fd, res->mesh, (size_t)n, deadline, err))) {
        free(res->mesh);
        res->mesh = NULL;
        return rc;
    }
    res->mesh_len = (size_t)n;
    return 0;
}

int gv_worker_recv_result(int fd, const struct gv_worker_job *job,
                          int64_t deadline, struct gv_worker_result *res,
                          struct gv_error *err)
{
    memset(res, 0, sizeof *res);
    uint32_t type;
    uint64_t len;
    int rc = recv_header(fd, deadline, &type, &len, err);
    if (rc)
        return rc;
    if (type == GV_WORKER_FAILED) {
        uint8_t b[8 + GV_WORKER_MSG_MAX];
        if (len < 8 || len > sizeof b) {
            gv_fail(err, GV_EIO, "worker: malformed failure frame");
            return GV_WORKER_BAD;
        }
        if ((rc = io_read(fd, b, (size_t)len, deadline, err)))
            return rc;
        struct rbuf r = {b, (size_t)len, 0, 0};
        uint32_t code = get_u32(&r), n = get_u32(&r);
        if (code <= GV_OK || code > GV_CODE_MAX || n != len - 8) {
            gv_fail(err, GV_EIO, "worker: malformed failure frame");
            return GV_WORKER_BAD;
        }
        res->failed = 1;
        res->err.code = (enum gv_code)code;
        copy_text(res->err.text, sizeof res->err.text, b + 8, n);
        return 0;
    }
    if (job->op == GV_WORKER_SIMPLIFY)
        return recv_simplified(fd, job, type, len, deadline, res, err);
    uint64_t want = 0;
    if (job->op == GV_WORKER_RUN)
        want = STATS_BYTES + (uint64_t)job->in.roi_w * job->in.roi_h * 16;
    if (type != GV_WORKER_DONE || len != want || want > SIZE_MAX) {
        gv_fail(err, GV_EIO, "worker: unexpected frame (type %u, %llu bytes)",
                type, (unsigned long long)len);
        return GV_WORKER_BAD;
    }
    if (job->op == GV_WORKER_COMPILE)
        return 0;
    uint8_t b[STATS_BYTES];
    if ((rc = io_read(fd, b, sizeof b, deadline, err)))
        return rc;
    struct rbuf r = {b, sizeof b, 0, 0};
    uint32_t v[5];
    for (int i = 0; i < 5; i++)
        v[i] = get_u32(&r);
    double ms = get_f64(&r);
    uint32_t w = get_u32(&r), h = get_u32(&r);
    if (w != job->in.roi_w || h != job->in.roi_h) {
        gv_fail(err, GV_EIO, "worker: result of %ux%u for a %ux%u region", w, h,
                job->in.roi_w, job->in.roi_h);
        return GV_WORKER_BAD;
    }
    res->stats.passes = v[0] > INT_MAX ? INT_MAX : (int)v[0];
    res->stats.merges = v[1] > INT_MAX ? INT_MAX : (int)v[1];
    res->stats.merges_skipped = v[2] > INT_MAX ? INT_MAX : (int)v[2];
    res->stats.line_copies = v[3] > INT_MAX ? INT_MAX : (int)v[3];
    res->stats.textures = v[4] > INT_MAX ? INT_MAX : (int)v[4];
    res->stats.gpu_ms = isfinite(ms) && ms >= 0 ? ms : 0;
    size_t nbytes = (size_t)(len - STATS_BYTES);
    res->out = malloc(nbytes);
    if (!res->out) {
        gv_fail(err, GV_ENOMEM, "worker: out of memory for a result of %zu bytes",
                nbytes);
        return GV_WORKER_BAD;
    }
    if ((rc = io_read(fd, res->out, nbytes, deadline, err))) {
        free(res->out);
        res->out = NULL;
    }
    return rc;
}

/* ------------------------------------------------------- worker's side */

static int send_hello(int fd, int ok, const char *text, struct gv_error *err)
{
    size_t n = strlen(text);
    if (n > GV_WORKER_MSG_MAX)
        n = GV_WORKER_MSG_MAX;
    struct wbuf w = {.n = 0};
    put_header(&w, GV_WORKER_HELLO, HELLO_FIXED + n);
    put_u32(&w, GV_WORKER_VERSION);
    put_u32(&w, (uint32_t)ok);
    put_u32(&w, (uint32_t)n);
    int rc = io_write(fd, w.b, w.n, -1, err);
    return rc ? rc : io_write(fd, text, n, -1, err);
}

static int send_failed(int fd, const struct gv_error *e, struct gv_error *err)
{
    size_t n = strnlen(e->text, GV_WORKER_MSG_MAX);
    struct wbuf w = {.n = 0};
    put_header(&w, GV_WORKER_FAILED, 8 + n);
    put_u32(&w, e->code == GV_OK ? (uint32_t)GV_EIO : (uint32_t)e->code);
    put_u32(&w, (uint32_t)n);
    int rc = io_write(fd, w.b, w.n, -1, err);
    return rc ? rc : io_write(fd, e->text, n, -1, err);
}

static int send_simplified(int fd, const uint8_t *mesh, size_t n,
                           const struct gv_simplify_stats *st,
                           struct gv_error *err)
{
    struct wbuf w = {.n = 0};
    put_header(&w, GV_WORKER_DONE, GV_WORKER_SIMPLIFIED_FIXED + (uint64_t)n);
    put_u32(&w, st->in_verts);
    put_u32(&w, st->in_tris);
    put_u32(&w, st->out_verts);
    put_u32(&w, st->out_tris);
    put_u64(&w, st->asked);
    put_u32(&w, st->level);
    put_u32(&w, st->nnodes);
    put_f64(&w, st->read_ms);
    put_f64(&w, st->build_ms);
    put_f64(&w, st->select_ms);
    put_f64(&w, st->write_ms);
    put_u64(&w, (uint64_t)n);
    int rc = io_write(fd, w.b, w.n, -1, err);
    return rc ? rc : io_write(fd, mesh, n, -1, err);
}

static int send_done(int fd, const struct gv_worker_job *job, const float *out,
                     const struct gv_filter_stats *st, struct gv_error *err)
{
    struct wbuf w = {.n = 0};
    if (job->op == GV_WORKER_COMPILE) {
        put_header(&w, GV_WORKER_DONE, 0);
        return io_write(fd, w.b, w.n, -1, err);
    }
    size_t nbytes = (size_t)job->in.roi_w * job->in.roi_h * 16;
    put_header(&w, GV_WORKER_DONE, STATS_BYTES + (uint64_t)nbytes);
    int s[5] = {st->passes, st->merges, st->merges_skipped, st->line_copies,
                st->textures};
    for (int i = 0; i < 5; i++)
        put_u32(&w, s[i] < 0 ? 0 : (uint32_t)s[i]);
    put_f64(&w, st->gpu_ms);
    put_u32(&w, job->in.roi_w);
    put_u32(&w, job->in.roi_h);
    int rc = io_write(fd, w.b, w.n, -1, err);
    return rc ? rc : io_write(fd, out, nbytes, -1, err);
}

/* Read a body of len bytes into *body (malloc'ed; free it whatever is
 * returned).  The buffer grows with what arrives, so a header that
 * announces more than is sent costs what was sent, not what it said. */
static int read_body(int fd, size_t len, uint8_t **body, struct gv_error *err)
{
    size_t cap = len < 65536 ? len : 65536, got = 0;
    *body = malloc(cap ? cap : 1);
    while (*body) {
        int rc = io_read(fd, *body + got, cap - got, -1, err);
        if (rc || cap == len)
            return rc;
        got = cap;
        cap = len - cap < cap ? len : 2 * cap;
        uint8_t *b = realloc(*body, cap);
        if (!b)
            break;
        *body = b;
    }
    gv_fail(err, GV_ENOMEM, "worker: out of memory for a job of %zu bytes", len);
    return GV_WORKER_BAD;
}

/* The body of a SIMPLIFY job (r) into job; a request the options reject
 * (an unknown mode or format) is 0 with jerr set. */
static int decode_simplify(struct rbuf *r, struct gv_worker_job *job,
                           struct gv_error *jerr, struct gv_error *err)
{
    struct gv_simplify_opts *o = &job->simplify;
    o->faces = get_u64(r);
    o->ratio = get_f64(r);
    uint32_t mode = get_u32(r), format = get_u32(r);
    o->lim.max_bytes = get_u64(r);
    o->lim.max_verts = get_u32(r);
    o->lim.max_tris = get_u32(r);
    o->max_faces = get_u32(r);
    o->time_limit = get_f64(r);
    uint64_t n = get_u64(r);
    if (r->bad || n != r->n - r->off) {
        gv_fail(err, GV_EIO, "worker: malformed simplification job");
        return GV_WORKER_BAD;
    }
    job->mesh = take(r, (size_t)n);
    job->mesh_len = (size_t)n;
    o->mode = mode == GV_CLUSTER_PAPER ? GV_CLUSTER_PAPER : GV_CLUSTER_EXACT;
    o->format = (enum gv_mesh_format)format;
    if (mode > GV_CLUSTER_PAPER ||
        (format != GV_MESH_GLB && format != GV_MESH_PLY && format != GV_MESH_OBJ))
        gv_fail(jerr, GV_EINVAL, "worker: simplification mode %u, format %u",
                mode, format);
    else if (!isfinite(o->time_limit) || o->time_limit < 0)
        gv_fail(jerr, GV_EINVAL, "worker: simplification time limit %g",
                o->time_limit);
    return 0;
}

/*
 * Read one job into *job; its pointers point into *body (free it) and
 * *params.  Returns 0, GV_WORKER_EOF at a clean end, or an error.
 * A job that is well framed but inconsistent is 0 with jerr set.
 */
/* Same shape as recv_simplified above: deliberately separate, each unpacks its
 * own message of the worker protocol. */
static int recv_job(int fd, uint64_t max_pixels, struct gv_worker_job *job,
                    uint8_t **body, double *params, struct gv_error *jerr,
                    struct gv_error *err)
{
    uint32_t type;
    uint64_t len;
    memset(job, 0, sizeof *job);
    *body = NULL;
    gv_error_clear(jerr);
    int rc = recv_header(fd, -1, &type, &len, err);
    if (rc)
        return rc;
    uint64_t cap = LIMITS_BYTES + 4 + DOC_MAX + 4 + 8 * PARAMS_MAX +
                   GEOMETRY_BYTES + max_pixels * (4 + 2 * VALUES_MAX);
    if (type == GV_WORKER_SIMPLIFY)
        cap = GV_WORKER_SIMPLIFY_FIXED + GV_WORKER_MESH_MAX;
    if ((type != GV_WORKER_COMPILE && type != GV_WORKER_RUN &&
         type != GV_WORKER_SIMPLIFY) || len > cap || len > SIZE_MAX) {
        gv_fail(err, GV_EIO, "worker: bad job frame (type %u, %llu bytes)", type,
                (unsigned long long)len);
        return GV_WORKER_BAD;
    }
    if ((rc = read_body(fd, (size_t)len, body, err)))
        return rc;
    struct rbuf r = {*body, (size_t)len, 0, 0};
    job->op = (int)type;
    if (type == GV_WORKER_SIMPLIFY)
        return decode_simplify(&r, job, jerr, err);
    job->lim.max_json_bytes = (size_t)get_u64(&r);
    job->lim.max_json_depth = (int)(get_u32(&r) & INT_MAX);
    job->lim.max_modules = (int)(get_u32(&r) & INT_MAX);
    job->lim.max_glsl_bytes = (size_t)get_u64(&r);
    job->lim.max_padding = (int)(get_u32(&r) & INT_MAX);
    job->doc_len = get_u32(&r);
    job->doc = (const char *)take(&r, job->doc_len);
    if (type == GV_WORKER_RUN) {
        uint32_t np = get_u32(&r);
        if (np > PARAMS_MAX) {
            gv_fail(err, GV_EIO, "worker: %u parameters", np);
            return GV_WORKER_BAD;
        }
        job->nparams = (int)np;
        for (uint32_t i = 0; i < np; i++)
            params[i] = get_f64(&r);
        struct gv_filter_input *in = &job->in;
        in->w = get_u32(&r);
        in->h = get_u32(&r);
        in->roi_x = get_u32(&r);
        in->roi_y = get_u32(&r);
        in->roi_w = get_u32(&r);
        in->roi_h = get_u32(&r);
        in->abs_x = (int64_t)get_u64(&r);
        in->abs_y = (int64_t)get_u64(&r);
        in->viewport_w = get_u32(&r);
        in->viewport_h = get_u32(&r);
        uint32_t nv = get_u32(&r);
        in->values_scale = get_f64(&r);
        in->values_offset = get_f64(&r);
        in->params = params;
        uint64_t px = (uint64_t)in->w * in->h;
        if (!r.bad && (nv > VALUES_MAX || (len - r.off) != px * (4 + 2 * (uint64_t)nv))) {
            gv_fail(err, GV_EIO, "worker: %llu texel bytes for %ux%u and %u channels "
                    "of values", (unsigned long long)(len - r.off), in->w, in->h, nv);
            return GV_WORKER_BAD;
        }
        in->nvalues = (int)nv;
        in->rgba = take(&r, (size_t)(px * 4));
        in->values = nv ? take(&r, (size_t)(px * 2 * nv)) : NULL;
        if (!r.bad && (in->w == 0 || in->h == 0 || px > max_pixels ||
                       in->roi_w == 0 || in->roi_h == 0 ||
                       in->roi_x >= in->w || in->roi_w > in->w - in->roi_x ||
                       in->roi_y >= in->h || in->roi_h > in->h - in->roi_y))
            gv_fail(jerr, GV_ELIMIT,
                    "worker: region %ux%u (ROI %u,%u %ux%u) is empty, "
                    "inconsistent or larger than %llu pixels",
                    in->w, in->h, in->roi_x, in->roi_y, in->roi_w, in->roi_h,
                    (unsigned long long)max_pixels);
    }
    if (r.bad || r.off != r.n) {
        gv_fail(err, GV_EIO, "worker: malformed job body");
        return GV_WORKER_BAD;
    }
    return 0;
}

#ifdef GV_TEST_HOOKS
#include <signal.h>
/* Test builds only: with GV_TEST_WORKER_SIMPLIFY set, a mesh file that
 * starts with "#gv-test:crash" kills the worker with SIGSEGV (as a reader
 * bug would), one that starts with "#gv-test:hang" never ends (as a mesh
 * that loops a reader would): tests/http_simplify.sh. */
static void test_hostile_mesh(const struct gv_worker_job *job)
{
    const char *on = getenv("GV_TEST_WORKER_SIMPLIFY");
    if (!on || !*on)
        return;
    if (job->mesh_len >= 14 && !memcmp(job->mesh, "#gv-test:crash", 14))
        raise(SIGSEGV);
    if (job->mesh_len >= 13 && !memcmp(job->mesh, "#gv-test:hang", 13)) {
        for (;;) {
            struct timespec ts = {1, 0};
            nanosleep(&ts, NULL);
        }
    }
}
#endif

/* Run a SIMPLIFY job: on the worker's context when it has one, else on
 * the CPU (the same file).  0 with *mesh, *len and *st, or -1 with *jerr. */
static int run_simplify(struct gv_gpu *gpu, const struct gv_worker_job *job,
                        uint8_t **mesh, size_t *len,
                        struct gv_simplify_stats *st, struct gv_error *jerr)
{
    struct gv_simplify_opts o = job->simplify;
    o.select = NULL;
    o.select_ctx = NULL;
#ifdef GV_HAVE_GPU
    if (gpu) {
        o.select = gv_gpu_cluster_run;
        o.select_ctx = gpu;
    }
#else
    (void)gpu;
#endif
#ifdef GV_TEST_HOOKS
    test_hostile_mesh(job);
#endif
    return gv_simplify(job->mesh, job->mesh_len, &o, mesh, len, st, jerr);
}

/* Run one decoded job; 0 with *out (RUN) or -1 with *jerr. */
static int run_job(struct gv_gpu *gpu, const struct gv_worker_job *job,
                   float **out, struct gv_filter_stats *st,
                   struct gv_error *jerr)
{
    if (!gpu)
        return gv_fail(jerr, GV_EUNAVAIL, "worker: no GPU context");
    struct gv_filter_graph *g =
        gv_filter_graph_parse(job->doc, job->doc_len, &job->lim, jerr);
    if (!g)
        return -1;
    int rc = -1;
    if (job->op == GV_WORKER_COMPILE) {
        rc = gv_filter_compile(gpu, g, jerr);
        goto out;
    }
    if (job->nparams != g->nparams) {
        gv_fail(jerr, GV_EINVAL, "worker: %d parameter values for %d parameters",
                job->nparams, g->nparams);
        goto out;
    }
    for (int i = 0; i < g->nmodules; i++)
        for (int p = 0; p < g->module[i].nparams; p++) {
            const struct gv_filter_param *pp = &g->module[i].param[p];
            double v = job->in.params[g->module[i].param_base + p];
            if (!(v >= pp->min && v <= pp->max)) {
                gv_fail(jerr, GV_EINVAL, "worker: %s.%s = %g is outside [%g, %g]",
                        g->module[i].id, pp->name, v, pp->min, pp->max);
                goto out;
            }
        }
    rc = gv_filter_run(gpu, g, &job->in, out, st, jerr);
out:
    gv_filter_graph_free(g);
    return rc;
}

#ifdef GV_TEST_HOOKS
#include <fcntl.h>
/* Test builds only (tests/gigaview-filter-worker-hooks): with
 * GV_TEST_WORKER_SYSCALL set, each job first makes that call, which the
 * seccomp filter answers: socket and execve kill the process (SIGSYS),
 * open-write (openat for writing) fails with EPERM.  A call that returns
 * fails the job with what it returned. */
static int test_forbidden_call(struct gv_error *jerr)
{
    const char *call = getenv("GV_TEST_WORKER_SYSCALL");
    long rc;
    if (!call || !*call)
        return 0;
    if (!strcmp(call, "socket")) {
        rc = socket(AF_INET, SOCK_STREAM, 0);
    } else if (!strcmp(call, "execve")) {
        char *argv[] = {(char *)"/bin/true", NULL};
        rc = execve("/bin/true", argv, argv + 1);
    } else if (!strcmp(call, "open-write")) {
        rc = open("/dev/null", O_WRONLY);
    } else {
        return gv_fail(jerr, GV_EINVAL, "test hook: unknown call %s", call);
    }
    return gv_fail(jerr, GV_EINVAL, "test hook: %s returned %ld (%s)", call, rc,
                   rc < 0 ? strerror(errno) : "no error");
}
#endif

int gv_worker_serve(int fd, struct gv_gpu *gpu, const char *hello_text,
                    uint64_t max_pixels, struct gv_error *err)
{
    int rc = send_hello(fd, gpu != NULL, hello_text, err);
    if (rc)
        return -1;
    double *params = malloc(PARAMS_MAX * sizeof *params);
    if (!params)
        return gv_fail(err, GV_ENOMEM, "worker: out of memory");
    for (;;) {
        struct gv_worker_job job;
        struct gv_error jerr = {0};
        uint8_t *body;
        rc = recv_job(fd, max_pixels, &job, &body, params, &jerr, err);
        if (rc) {
            free(body);
            break;
        }
        float *out = NULL;
        uint8_t *mesh = NULL;
        size_t mesh_len = 0;
        struct gv_filter_stats st;
        struct gv_simplify_stats sst;
        memset(&st, 0, sizeof st);
#ifdef GV_TEST_HOOKS
        if (jerr.code == GV_OK)
            test_forbidden_call(&jerr);
#endif
        if (jerr.code == GV_OK && job.op == GV_WORKER_SIMPLIFY)
            rc = run_simplify(gpu, &job, &mesh, &mesh_len, &sst, &jerr) == 0
                     ? send_simplified(fd, mesh, mesh_len, &sst, err)
                     : send_failed(fd, &jerr, err);
        else if (jerr.code == GV_OK && run_job(gpu, &job, &out, &st, &jerr) == 0)
            rc = send_done(fd, &job, out, &st, err);
        else
            rc = send_failed(fd, &jerr, err);
        free(out);
        free(mesh);
        free(body);
        if (rc)
            break;
    }
    free(params);
    if (rc == GV_WORKER_EOF) {
        gv_error_clear(err);
        return 0;
    }
    return -1;
}
