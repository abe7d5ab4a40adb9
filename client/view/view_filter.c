/*
 * view_filter.c - the filter thread of `gigaview view` (view_filter.h).
 *
 * A plain pthread, one request at a time: a filter job is one request
 * that the server may take seconds over.  Each request runs on the
 * thread's own curl multi handle, only so that vx_free can end it at once
 * (a flag, and curl_multi_wakeup to break the poll) rather than wait out
 * the request timeout on a server that holds its answer.  The PNG
 * answer is written to a private temporary file and decoded there with
 * the OpenImageIO bridge (lib/imageio reads files only).  Server answers
 * are outside input: sizes are bounded (max_pixels below) and every JSON
 * field is checked for its type.
 */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <curl/curl.h>
#include <jansson.h>

#include "config.h"
#include "base/ids.h"
#include "imageio/imageio.h"
#include "view_filter.h"

/* A filter id (base/ids.h) fits every name field of struct vx_graph. */
_Static_assert(GV_FILTER_ID_LEN < sizeof ((struct vx_graph *)0)->module &&
               GV_FILTER_ID_LEN < sizeof ((struct vx_graph *)0)->name &&
               GV_FILTER_ID_LEN < sizeof ((struct vx_graph *)0)->id,
               "filter ids fit struct vx_graph");

#define MAX_BODY ((size_t)256 << 20)
#define MAX_PIXELS ((uint64_t)64 << 20)

struct vx {
    char url[1024];
    long timeout_ms;
    int verbose;
    pthread_t thread;
    CURLM *multi;                /* the thread's requests run on it */
    atomic_int abort;            /* vx_free: end the request in progress */
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int stop, listing;
    struct vx_graph graphs[VX_MAX_GRAPHS];
    int ngraphs;
    struct vx_job job;           /* the next job, when have_job */
    int have_job, running;
    unsigned serial;             /* bumped by every vx_run */
    struct vx_result out;        /* the last result, when have_out */
    int have_out;
};

struct body {
    char *p;
    size_t n;
};

static size_t on_body(char *p, size_t size, size_t nmemb, void *arg)
{
    struct body *b = arg;
    size_t n = size * nmemb;
    if (b->n + n > MAX_BODY)
        return 0;
    char *q = realloc(b->p, b->n + n + 1);
    if (!q)
        return 0;
    memcpy(q + b->n, p, n);
    b->p = q;
    b->n += n;
    b->p[b->n] = 0;
    return n;
}

/* One request: GET path, or POST json when json is not NULL.  Returns the
 * HTTP status (0 when there was no answer, msg says why) and the body. */
static long request(struct vx *x, const char *path, const char *json, struct body *b,
                    char *msg, size_t cap)
{
    char url[1400];
    snprintf(url, sizeof url, "%s%s", x->url, path);
    CURL *e = curl_easy_init();
    if (!e) {
        snprintf(msg, cap, "filter: no curl handle");
        return 0;
    }
    char errbuf[CURL_ERROR_SIZE] = "";
    struct curl_slist *hdrs = NULL;
    curl_easy_setopt(e, CURLOPT_URL, url);
    curl_easy_setopt(e, CURLOPT_WRITEFUNCTION, on_body);
    curl_easy_setopt(e, CURLOPT_WRITEDATA, b);
    curl_easy_setopt(e, CURLOPT_ERRORBUFFER, errbuf);
    curl_easy_setopt(e, CURLOPT_TIMEOUT_MS, x->timeout_ms);
    curl_easy_setopt(e, CURLOPT_CONNECTTIMEOUT_MS, x->timeout_ms);
    curl_easy_setopt(e, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(e, CURLOPT_USERAGENT, "gigaview/" PACKAGE_VERSION);
    if (json) {
        hdrs = curl_slist_append(hdrs, "Content-Type: application/json");
        curl_easy_setopt(e, CURLOPT_HTTPHEADER, hdrs);
        curl_easy_setopt(e, CURLOPT_POSTFIELDSIZE, (long)strlen(json));
        curl_easy_setopt(e, CURLOPT_COPYPOSTFIELDS, json);
    }
    long status = 0;
    CURLcode rc = CURLE_OK;
    CURLMcode mc = curl_multi_add_handle(x->multi, e);
    for (int done = 0; mc == CURLM_OK && !done;) {
        if (atomic_load(&x->abort)) {
            rc = CURLE_ABORTED_BY_CALLBACK;
            snprintf(errbuf, sizeof errbuf, "stopped (the viewer is closing)");
            break;
        }
        int running;
        mc = curl_multi_perform(x->multi, &running);
        CURLMsg *m;
        int left;
        while ((m = curl_multi_info_read(x->multi, &left)))
            if (m->msg == CURLMSG_DONE) {
                rc = m->data.result;
                done = 1;
            }
        if (!done && mc == CURLM_OK)
            mc = curl_multi_poll(x->multi, NULL, 0, 1000, NULL);
    }
    curl_multi_remove_handle(x->multi, e);
    if (mc != CURLM_OK)
        snprintf(msg, cap, "filter: %.100s: %.180s", url, curl_multi_strerror(mc));
    else if (rc != CURLE_OK)
        snprintf(msg, cap, "filter: %.100s: %.180s", url, errbuf[0] ? errbuf : curl_easy_strerror(rc));
    else
        curl_easy_getinfo(e, CURLINFO_RESPONSE_CODE, &status);
    curl_slist_free_all(hdrs);
    curl_easy_cleanup(e);
    if (x->verbose)
        fprintf(stderr, "view: filter %s %s -> %ld\n", json ? "POST" : "GET", path, status);
    return status;
}

/* The message of an error answer: its JSON "error.message", else the
 * status alone. */
static void error_message(long status, const struct body *b, char *msg, size_t cap)
{
    json_t *j = b->p ? json_loadb(b->p, b->n, 0, NULL) : NULL;
    const char *m = json_string_value(json_object_get(json_object_get(j, "error"), "message"));
    snprintf(msg, cap, "filter: HTTP %ld%s%.200s", status, m ? ": " : "", m ? m : "");
    json_decref(j);
}

/* GET /v1/filters into x->graphs. */
static void list_graphs(struct vx *x)
{
    struct body b = {0};
    char msg[320] = "";
    long st = request(x, "/v1/filters", NULL, &b, msg, sizeof msg);
    struct vx_graph *g = calloc(VX_MAX_GRAPHS, sizeof *g);
    int n = 0;
    json_t *j = st == 200 && b.p ? json_loadb(b.p, b.n, 0, NULL) : NULL;
    json_t *arr = json_object_get(j, "filters");
    for (size_t i = 0; g && json_is_array(arr) && i < json_array_size(arr) && n < VX_MAX_GRAPHS;
         i++) {
        json_t *f = json_array_get(arr, i);
        const char *id = json_string_value(json_object_get(f, "id"));
        if (!id || !gv_filter_id_valid(id))
            continue;
        snprintf(g[n].id, sizeof g[n].id, "%s", id);
        json_t *p = json_array_get(json_object_get(f, "params"), 0);
        const char *mod = json_string_value(json_object_get(p, "module"));
        const char *name = json_string_value(json_object_get(p, "name"));
        json_t *mn = json_object_get(p, "min"), *mx = json_object_get(p, "max"),
               *df = json_object_get(p, "default");
        if (mod && name && gv_filter_id_valid(mod) && gv_filter_id_valid(name) &&
            json_is_number(mn) && json_is_number(mx) && json_is_number(df)) {
            g[n].has_param = 1;
            snprintf(g[n].module, sizeof g[n].module, "%s", mod);
            snprintf(g[n].name, sizeof g[n].name, "%s", name);
            g[n].min = json_number_value(mn);
            g[n].max = json_number_value(mx);
            g[n].def = json_number_value(df);
        }
        n++;
    }
    json_decref(j);
    free(b.p);
    if (!n && x->verbose)
        fprintf(stderr, "view: no filter graphs listed (%s)\n", msg[0] ? msg : "none");
    pthread_mutex_lock(&x->mu);
    if (g)
        memcpy(x->graphs, g, (size_t)n * sizeof *g);
    x->ngraphs = n;
    x->listing = 0;
    pthread_mutex_unlock(&x->mu);
    free(g);
}

/* Decode a PNG body into r->rgba. */
static int decode(const struct body *b, struct vx_result *r)
{
    const char *dir = getenv("TMPDIR");
    char path[1100];
    snprintf(path, sizeof path, "%s/gigaview-filter-XXXXXX.png", dir && *dir ? dir : "/tmp");
    int fd = mkstemps(path, 4);
    if (fd < 0) {
        snprintf(r->msg, sizeof r->msg, "filter: cannot make a temporary file in %.200s",
                 dir && *dir ? dir : "/tmp");
        return -1;
    }
    int rc = -1;
    size_t off = 0;
    while (off < b->n) {
        ssize_t k = write(fd, b->p + off, b->n - off);
        if (k <= 0)
            break;
        off += (size_t)k;
    }
    close(fd);
    struct gv_image_info info;
    struct gv_error err = {0};
    struct gv_image_in *in = NULL;
    uint8_t *px = NULL;
    if (off != b->n) {
        snprintf(r->msg, sizeof r->msg, "filter: cannot write %.200s", path);
        goto done;
    }
    if (!(in = gv_image_open(path, MAX_PIXELS, &info, &err))) {
        snprintf(r->msg, sizeof r->msg, "filter: %.300s", err.text);
        goto done;
    }
    if (info.sample != GV_SAMPLE_U8 || info.channels < 1 || info.channels > 4) {
        snprintf(r->msg, sizeof r->msg, "filter: the answer is not an 8-bit picture");
        goto done;
    }
    const size_t np = (size_t)info.width * info.height;
    if (!(px = malloc(np * (size_t)info.channels)) || !(r->rgba = malloc(np * 4))) {
        snprintf(r->msg, sizeof r->msg, "filter: out of memory");
        goto done;
    }
    if (gv_image_read(in, info.height, px, &err) < 0) {
        snprintf(r->msg, sizeof r->msg, "filter: %.300s", err.text);
        goto done;
    }
    const int c = info.channels;
    for (size_t i = 0; i < np; i++) {
        const uint8_t *s = px + i * (size_t)c;
        uint8_t *d = r->rgba + i * 4;
        d[0] = s[0];
        d[1] = c >= 3 ? s[1] : s[0];
        d[2] = c >= 3 ? s[2] : s[0];
        d[3] = c == 2 ? s[1] : c == 4 ? s[3] : 255;
    }
    r->w = info.width;
    r->h = info.height;
    rc = 0;
done:
    gv_image_close(in);
    free(px);
    unlink(path);
    if (rc < 0) {
        free(r->rgba);
        r->rgba = NULL;
    }
    return rc;
}

/* Run job j into *r. */
static void run_job(struct vx *x, const struct vx_job *j, struct vx_result *r)
{
    memset(r, 0, sizeof *r);
    r->job = *j;
    json_t *body = json_pack("{s:s, s:i, s:[i,i,i,i], s:s}", "filter", j->g.id, "level",
                             j->level, "region", (int)j->x, (int)j->y, (int)j->w, (int)j->h,
                             "format", "png");
    if (body && j->g.has_param)
        json_object_set_new(body, "params",
                            json_pack("{s:{s:f}}", j->g.module, j->g.name, j->param));
    char *text = body ? json_dumps(body, JSON_COMPACT) : NULL;
    json_decref(body);
    char *id = curl_easy_escape(NULL, j->image, 0);
    char path[600];
    snprintf(path, sizeof path, "/v1/images/%s/filter", id ? id : "");
    curl_free(id);
    struct body b = {0};
    if (!text) {
        snprintf(r->msg, sizeof r->msg, "filter: out of memory");
    } else {
        long st = request(x, path, text, &b, r->msg, sizeof r->msg);
        if (st == 200)
            r->ok = decode(&b, r) == 0;
        else if (st)
            error_message(st, &b, r->msg, sizeof r->msg);
    }
    free(text);
    free(b.p);
}

static void *thread_main(void *arg)
{
    struct vx *x = arg;
    list_graphs(x);
    pthread_mutex_lock(&x->mu);
    while (!x->stop) {
        if (!x->have_job) {
            pthread_cond_wait(&x->cv, &x->mu);
            continue;
        }
        struct vx_job j = x->job;
        unsigned serial = x->serial;
        x->have_job = 0;
        x->running = 1;
        pthread_mutex_unlock(&x->mu);
        struct vx_result r;
        run_job(x, &j, &r);
        pthread_mutex_lock(&x->mu);
        x->running = 0;
        if (serial != x->serial || x->stop) {
            free(r.rgba);        /* replaced meanwhile */
            continue;
        }
        if (x->have_out)
            free(x->out.rgba);
        x->out = r;
        x->have_out = 1;
    }
    pthread_mutex_unlock(&x->mu);
    return NULL;
}

struct vx *vx_new(const char *url, long timeout_ms, int verbose, struct gv_error *err)
{
    struct vx *x = calloc(1, sizeof *x);
    if (!x) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    snprintf(x->url, sizeof x->url, "%s", url);
    for (size_t n = strlen(x->url); n && x->url[n - 1] == '/'; n--)
        x->url[n - 1] = 0;
    x->timeout_ms = timeout_ms;
    x->verbose = verbose;
    x->listing = 1;
    if (!(x->multi = curl_multi_init())) {
        free(x);
        gv_fail(err, GV_ENOMEM, "filter: no curl multi handle");
        return NULL;
    }
    pthread_mutex_init(&x->mu, NULL);
    pthread_cond_init(&x->cv, NULL);
    if (pthread_create(&x->thread, NULL, thread_main, x) != 0) {
        pthread_mutex_destroy(&x->mu);
        pthread_cond_destroy(&x->cv);
        curl_multi_cleanup(x->multi);
        free(x);
        gv_fail(err, GV_EIO, "filter: cannot start a thread");
        return NULL;
    }
    return x;
}

void vx_free(struct vx *x)
{
    if (!x)
        return;
    pthread_mutex_lock(&x->mu);
    x->stop = 1;
    pthread_cond_signal(&x->cv);
    pthread_mutex_unlock(&x->mu);
    atomic_store(&x->abort, 1);  /* a request the server holds ends now */
    curl_multi_wakeup(x->multi);
    pthread_join(x->thread, NULL);
    curl_multi_cleanup(x->multi);
    if (x->have_out)
        free(x->out.rgba);
    pthread_mutex_destroy(&x->mu);
    pthread_cond_destroy(&x->cv);
    free(x);
}

int vx_graphs(struct vx *x, struct vx_graph *out, int max)
{
    pthread_mutex_lock(&x->mu);
    int n = x->ngraphs < max ? x->ngraphs : max;
    memcpy(out, x->graphs, (size_t)n * sizeof *out);
    pthread_mutex_unlock(&x->mu);
    return n;
}

void vx_run(struct vx *x, const struct vx_job *j)
{
    pthread_mutex_lock(&x->mu);
    x->job = *j;
    x->have_job = 1;
    x->serial++;
    if (x->have_out) {           /* an older answer is no longer wanted */
        free(x->out.rgba);
        x->have_out = 0;
    }
    pthread_cond_signal(&x->cv);
    pthread_mutex_unlock(&x->mu);
}

int vx_poll(struct vx *x, struct vx_result *r)
{
    pthread_mutex_lock(&x->mu);
    int have = x->have_out;
    if (have) {
        *r = x->out;
        x->have_out = 0;
    }
    pthread_mutex_unlock(&x->mu);
    return have;
}

int vx_busy(struct vx *x)
{
    pthread_mutex_lock(&x->mu);
    int busy = x->listing || x->have_job || x->running || x->have_out;
    pthread_mutex_unlock(&x->mu);
    return busy;
}
