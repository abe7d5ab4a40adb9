/*
 * http_fetch.c - libcurl transport for the native client (http_fetch.h).
 *
 * One curl multi handle lives as long as the struct gv_http, so its
 * connection cache keeps connections alive across calls; a batch of
 * transfers runs concurrently on up to MAX_CONNS connections.
 *
 * Tiles come in batch requests of up to BATCH_TILES (POST .../batch?etag=1),
 * which run concurrently like any transfers.  Each lists in If-None-Match
 * the ETags of its tiles found in the disk cache, and the answer's GVB2
 * frames (batch_frames.h) carry each tile's ETag (200) or confirm a cached
 * one (304): a warm cache costs one small request per BATCH_TILES tiles
 * instead of one request per tile.  A batch the server refuses (a smaller
 * batch_max_tiles: 413) is fetched tile by tile instead.
 *
 * gv_http_abort (any thread) sets a flag that run_all reads between two
 * curl_multi_poll calls, and wakes the poll with curl_multi_wakeup: the
 * transfers on the wire are removed from the multi handle (curl closes
 * their connections) and the call fails at once, instead of waiting out
 * --timeout on a server that holds its answer.
 */
#include <ctype.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include <curl/curl.h>
#include <jansson.h>

#include "config.h"
#include "base/ids.h"
#include "batch_frames.h"
#include "codec/samples_tile.h"
#include "codec/tile.h"
#include "http_fetch.h"

#define MAX_CONNS 8
#define MAX_BODY (64u << 20)
/* Tiles per batch request: a few views' worth, far below the server's
 * default batch_max_tiles (256), and headers of a few KiB. */
#define BATCH_TILES 64
#define ETAG_CAP 160
/* Bytes of an access token (GIGAVIEW_TOKEN): the server's own limit is
 * far below (server/access_token.h). */
#define TOKEN_MAX 4096

struct gv_http {
    char base[1024];
    long timeout_ms;
    int verbose;
    int batches;            /* gv_http_use_batches */
    char *auth;             /* "Authorization: Bearer TOKEN", or NULL */
    CURLM *multi;
    atomic_int aborted;     /* gv_http_abort */
    struct gv_http_stats st;
};

struct xfer {
    CURL *e;
    char url[1400];
    struct curl_slist *hdrs;
    uint8_t *body;
    size_t len, cap;
    int too_big;
    char etag[ETAG_CAP];
    int post;               /* a POST (for the log) */
    long status;
    CURLcode result;
    char errbuf[CURL_ERROR_SIZE];
};

static int curl_ready;

/* The access token of the environment's GIGAVIEW_TOKEN (docs/API.md,
 * "Access control"), as a header line in h->auth; none when it is unset
 * or empty.  -1 with err filled for a token of other characters than a
 * token's (base64url and dots) or longer than TOKEN_MAX. */
static int set_token(struct gv_http *h, struct gv_error *err)
{
    const char *t = getenv("GIGAVIEW_TOKEN");
    if (!t || !*t)
        return 0;
    size_t n = strlen(t);
    if (n > TOKEN_MAX || strspn(t, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnop"
                                   "qrstuvwxyz0123456789-_.") != n)
        return gv_fail(err, GV_EINVAL, "GIGAVIEW_TOKEN is not an access token "
                       "(base64url and dots, at most %d bytes)", TOKEN_MAX);
    if (!(h->auth = malloc(n + 32)))
        return gv_fail(err, GV_ENOMEM, "http: out of memory");
    snprintf(h->auth, n + 32, "Authorization: Bearer %s", t);
    return 0;
}

struct gv_http *gv_http_new(const char *base, long timeout_ms, int verbose,
                            struct gv_error *err)
{
    if (strncmp(base, "http://", 7) && strncmp(base, "https://", 8)) {
        gv_fail(err, GV_EINVAL, "%s: not an http:// or https:// URL", base);
        return NULL;
    }
    if (strlen(base) >= 1000) {
        gv_fail(err, GV_EINVAL, "URL too long");
        return NULL;
    }
    if (!curl_ready) {
        if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) {
            gv_fail(err, GV_EIO, "http: cannot initialise libcurl");
            return NULL;
        }
        curl_ready = 1;
    }
    struct gv_http *h = calloc(1, sizeof *h);
    if (!h || !(h->multi = curl_multi_init())) {
        free(h);
        gv_fail(err, GV_ENOMEM, "http: out of memory");
        return NULL;
    }
    if (set_token(h, err) < 0) {
        curl_multi_cleanup(h->multi);
        free(h);
        return NULL;
    }
    snprintf(h->base, sizeof h->base, "%s", base);
    size_t n = strlen(h->base);
    while (n > 0 && h->base[n - 1] == '/')
        h->base[--n] = 0;
    h->timeout_ms = timeout_ms;
    h->verbose = verbose;
    h->batches = 1;
    curl_multi_setopt(h->multi, CURLMOPT_MAX_HOST_CONNECTIONS, (long)MAX_CONNS);
    curl_multi_setopt(h->multi, CURLMOPT_MAX_TOTAL_CONNECTIONS, (long)MAX_CONNS);
    return h;
}

void gv_http_free(struct gv_http *h)
{
    if (!h)
        return;
    curl_multi_cleanup(h->multi);
    free(h->auth);
    free(h);
}

void gv_http_abort(struct gv_http *h)
{
    atomic_store(&h->aborted, 1);
    curl_multi_wakeup(h->multi);
}

void gv_http_use_batches(struct gv_http *h, int on)
{
    h->batches = on;
}

const char *gv_http_base(const struct gv_http *h)
{
    return h->base;
}

void gv_http_stats(const struct gv_http *h, struct gv_http_stats *st)
{
    *st = h->st;
}

static size_t on_body(char *p, size_t size, size_t nmemb, void *arg)
{
    struct xfer *x = arg;
    size_t n = size * nmemb;
    if (x->len + n > MAX_BODY) {
        x->too_big = 1;
        return 0;
    }
    if (x->len + n > x->cap) {
        size_t cap = x->cap ? x->cap : 65536;
        while (cap < x->len + n)
            cap *= 2;
        uint8_t *b = realloc(x->body, cap);
        if (!b)
            return 0;
        x->body = b;
        x->cap = cap;
    }
    memcpy(x->body + x->len, p, n);
    x->len += n;
    return n;
}

static size_t on_header(char *p, size_t size, size_t nmemb, void *arg)
{
    struct xfer *x = arg;
    size_t n = size * nmemb;
    if (n > 5 && !strncasecmp(p, "ETag:", 5)) {
        size_t i = 5, j = n;
        while (i < j && (p[i] == ' ' || p[i] == '\t'))
            i++;
        while (j > i && isspace((unsigned char)p[j - 1]))
            j--;
        if (j - i < sizeof x->etag) {
            memcpy(x->etag, p + i, j - i);
            x->etag[j - i] = 0;
        }
    }
    return n;
}

static int xfer_init(struct gv_http *h, struct xfer *x, const char *path,
                     const char *if_none_match)
{
    memset(x, 0, sizeof *x);
    snprintf(x->url, sizeof x->url, "%s%s", h->base, path);
    if (!(x->e = curl_easy_init()))
        return -1;
    curl_easy_setopt(x->e, CURLOPT_URL, x->url);
    curl_easy_setopt(x->e, CURLOPT_WRITEFUNCTION, on_body);
    curl_easy_setopt(x->e, CURLOPT_WRITEDATA, x);
    curl_easy_setopt(x->e, CURLOPT_HEADERFUNCTION, on_header);
    curl_easy_setopt(x->e, CURLOPT_HEADERDATA, x);
    curl_easy_setopt(x->e, CURLOPT_ERRORBUFFER, x->errbuf);
    curl_easy_setopt(x->e, CURLOPT_TIMEOUT_MS, h->timeout_ms);
    curl_easy_setopt(x->e, CURLOPT_CONNECTTIMEOUT_MS, h->timeout_ms);
    curl_easy_setopt(x->e, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(x->e, CURLOPT_USERAGENT, "gigaview/" PACKAGE_VERSION);
#if LIBCURL_VERSION_NUM >= 0x075500
    curl_easy_setopt(x->e, CURLOPT_PROTOCOLS_STR, "http,https");
#else
    curl_easy_setopt(x->e, CURLOPT_PROTOCOLS, (long)(CURLPROTO_HTTP | CURLPROTO_HTTPS));
#endif
    curl_easy_setopt(x->e, CURLOPT_PRIVATE, x);
    if (h->auth && !(x->hdrs = curl_slist_append(x->hdrs, h->auth)))
        return -1;
    if (if_none_match && *if_none_match) {
        size_t cap = strlen(if_none_match) + 32;
        char *hdr = malloc(cap);
        if (!hdr)
            return -1;
        snprintf(hdr, cap, "If-None-Match: %s", if_none_match);
        struct curl_slist *l = curl_slist_append(x->hdrs, hdr);
        free(hdr);
        if (!l)
            return -1;
        x->hdrs = l;
    }
    if (x->hdrs)
        curl_easy_setopt(x->e, CURLOPT_HTTPHEADER, x->hdrs);
    return 0;
}

/* Make x (after xfer_init) a POST of the JSON text json (copied).  0 or
 * -1 when memory runs out. */
static int xfer_post_json(struct xfer *x, const char *json)
{
    struct curl_slist *l = curl_slist_append(x->hdrs,
                                             "Content-Type: application/json");
    if (!l)
        return -1;
    x->hdrs = l;
    /* No "Expect: 100-continue" (curl's default past 1 KiB of body): a
     * round trip for nothing, the body is small. */
    if (!(l = curl_slist_append(x->hdrs, "Expect:")))
        return -1;
    x->hdrs = l;
    x->post = 1;
    curl_easy_setopt(x->e, CURLOPT_HTTPHEADER, x->hdrs);
    curl_easy_setopt(x->e, CURLOPT_POSTFIELDSIZE, (long)strlen(json));
    return curl_easy_setopt(x->e, CURLOPT_COPYPOSTFIELDS, json) == CURLE_OK ? 0 : -1;
}

static void xfer_done(struct xfer *x)
{
    if (x->e)
        curl_easy_cleanup(x->e);
    curl_slist_free_all(x->hdrs);
    free(x->body);
    x->e = NULL;
    x->hdrs = NULL;
    x->body = NULL;
}

/* Run transfers x[0..n) to completion on the shared multi handle, at most
 * IN_FLIGHT at a time (so that --timeout bounds each request, not its
 * wait in a queue).  Statuses and results land in each xfer. */
#define IN_FLIGHT (2 * MAX_CONNS)
static uint64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static int run_all(struct gv_http *h, struct xfer *x, size_t n,
                   struct gv_error *err)
{
    uint64_t t0 = now_us();
    size_t next = 0, active = 0;
    CURLMcode mc = CURLM_OK;
    int aborted = 0;
    while (next < n || active > 0) {
        if ((aborted = atomic_load(&h->aborted)))
            goto out;
        while (next < n && active < IN_FLIGHT) {
            if ((mc = curl_multi_add_handle(h->multi, x[next].e)) != CURLM_OK)
                goto out;
            next++;
            active++;
        }
        int running;
        if ((mc = curl_multi_perform(h->multi, &running)) != CURLM_OK)
            goto out;
        CURLMsg *m;
        int left;
        while ((m = curl_multi_info_read(h->multi, &left)))
            if (m->msg == CURLMSG_DONE) {
                struct xfer *t;
                curl_easy_getinfo(m->easy_handle, CURLINFO_PRIVATE, (char **)&t);
                t->result = m->data.result;
                curl_easy_getinfo(m->easy_handle, CURLINFO_RESPONSE_CODE, &t->status);
                curl_multi_remove_handle(h->multi, m->easy_handle);
                active--;
                h->st.requests++;
                h->st.bytes += t->len;
                if (h->verbose) {
                    const char *verb = t->post ? "POST" : "GET";
                    if (t->result == CURLE_OK)
                        fprintf(stderr, "http: %s %s -> %ld (%zu bytes)\n", verb,
                                t->url, t->status, t->len);
                    else
                        fprintf(stderr, "http: %s %s -> failed: %s\n", verb, t->url,
                                t->errbuf[0] ? t->errbuf
                                             : curl_easy_strerror(t->result));
                }
            }
        if (active > 0 && running > 0 &&
            (mc = curl_multi_poll(h->multi, NULL, 0, 1000, NULL)) != CURLM_OK)
            goto out;
    }
out:
    for (size_t i = 0; i < next; i++)
        curl_multi_remove_handle(h->multi, x[i].e);   /* no-op when done */
    h->st.wait_us += now_us() - t0;
    if (aborted)
        return gv_fail(err, GV_EIO, "http: stopped (the client is closing)");
    if (mc != CURLM_OK)
        return gv_fail(err, GV_EIO, "http: %s", curl_multi_strerror(mc));
    return 0;
}

/* Turn a finished transfer into 0 (status 200 or, if allow_304, 304) or
 * -1 with a message naming `what` failed: too large a body, a transport
 * error, or another status (with the server's JSON message if any). */
static int xfer_check(const struct gv_http *h, const struct xfer *x,
                      const char *what, int allow_304, struct gv_error *err)
{
    if (x->too_big)
        return gv_fail(err, GV_ECORRUPT, "%s: response larger than %u bytes",
                       what, MAX_BODY);
    switch (x->result) {
    case CURLE_OK:
        break;
    case CURLE_COULDNT_CONNECT:
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_RESOLVE_PROXY:
        return gv_fail(err, GV_EIO, "cannot reach the server %s: %s", h->base,
                       x->errbuf[0] ? x->errbuf : curl_easy_strerror(x->result));
    case CURLE_OPERATION_TIMEDOUT:
        return gv_fail(err, GV_EIO, "%s: no complete answer from %s within %ld ms "
                       "(--timeout)", what, h->base, h->timeout_ms);
    case CURLE_PARTIAL_FILE:
    case CURLE_RECV_ERROR:
    case CURLE_GOT_NOTHING:
        return gv_fail(err, GV_ECORRUPT, "%s: truncated response from %s: %s",
                       what, h->base,
                       x->errbuf[0] ? x->errbuf : curl_easy_strerror(x->result));
    default:
        return gv_fail(err, GV_EIO, "%s: %s", what,
                       x->errbuf[0] ? x->errbuf : curl_easy_strerror(x->result));
    }
    if (x->status == 200 || (allow_304 && x->status == 304))
        return 0;
    /* The server's JSON error message, when there is one. */
    char msg[200] = "";
    json_error_t je;
    json_t *j = x->len ? json_loadb((const char *)x->body, x->len, 0, &je) : NULL;
    const char *m = NULL;
    json_unpack(j, "{s:{s:s}}", "error", "message", &m);
    if (m)
        snprintf(msg, sizeof msg, ": %s", m);
    json_decref(j);
    if (x->status == 401)   /* a restricted image (docs/API.md) */
        return gv_fail(err, GV_EAUTH, "%s: the server answered HTTP 401%s (a "
                       "restricted image: GIGAVIEW_TOKEN must hold an access token "
                       "of its group, not expired nor revoked)", what, msg);
    return gv_fail(err, x->status == 404 ? GV_ENOTFOUND
                        : x->status == 429 || x->status == 503 ? GV_EBUSY : GV_EIO,
                   "%s: the server answered HTTP %ld%s", what, x->status, msg);
}

/* GET path and parse the body as JSON. */
static json_t *get_json(struct gv_http *h, const char *path, const char *what,
                        struct gv_error *err)
{
    struct xfer x;
    if (xfer_init(h, &x, path, NULL) < 0) {
        xfer_done(&x);
        gv_fail(err, GV_ENOMEM, "http: out of memory");
        return NULL;
    }
    json_t *j = NULL;
    if (run_all(h, &x, 1, err) == 0 && xfer_check(h, &x, what, 0, err) == 0) {
        json_error_t je;
        j = json_loadb((const char *)x.body, x.len, 0, &je);
        if (!j)
            gv_fail(err, GV_ECORRUPT, "%s: the server sent malformed JSON (%s)",
                    what, je.text);
    }
    xfer_done(&x);
    return j;
}

int gv_http_print_images(struct gv_http *h, FILE *out, struct gv_error *err)
{
    json_t *j = get_json(h, "/v1/images", "image list", err);
    if (!j)
        return -1;
    json_t *arr = json_object_get(j, "images");
    if (!json_is_array(arr)) {
        json_decref(j);
        return gv_fail(err, GV_ECORRUPT, "image list: no \"images\" array");
    }
    fprintf(out, "server       %s\nimages       %zu\n", h->base, json_array_size(arr));
    if (json_array_size(arr))
        fprintf(out, "\n%-32s %10s %10s %6s %8s %14s\n", "id", "width", "height",
                "levels", "channels", "bytes");
    size_t i;
    json_t *v;
    json_array_foreach(arr, i, v) {
        const char *id = "?";
        json_int_t w = 0, hh = 0, bytes = 0;
        int levels = 0, ch = 0;
        json_unpack(v, "{s:s,s:I,s:I,s:i,s:i,s:I}", "id", &id, "width", &w,
                    "height", &hh, "levels", &levels, "channels", &ch, "bytes",
                    &bytes);
        fprintf(out, "%-32s %10lld %10lld %6d %8d %14lld\n", id, (long long)w,
                (long long)hh, levels, ch, (long long)bytes);
    }
    json_decref(j);
    return 0;
}

int gv_http_image(struct gv_http *h, const char *id,
                  struct gv_remote_image *img, struct gv_error *err)
{
    if (!gv_image_id_valid(id))
        return gv_fail(err, GV_ENOTFOUND, "'%s' is not a valid image id", id);
    char path[300], what[200];
    snprintf(path, sizeof path, "/v1/images/%s", id);
    snprintf(what, sizeof what, "image '%s'", id);
    json_t *j = get_json(h, path, what, err);
    if (!j) {
        if (err && err->code == GV_ENOTFOUND) {   /* said for this image */
            gv_error_clear(err);
            gv_fail(err, GV_ENOTFOUND, "no image '%s' on %s", id, h->base);
        }
        return -1;
    }
    memset(img, 0, sizeof *img);
    snprintf(img->id, sizeof img->id, "%s", id);
    json_int_t w = 0, hh = 0, rw = 0, rh = 0, side = 512;
    /* root.side: servers before format version 6 do not say it (512). */
    int rc = json_unpack(j, "{s:I,s:I,s:i,s:i,s:{s:I,s:I,s:i,s?I}}", "width", &w,
                         "height", &hh, "channels", &img->channels,
                         "levels_tiled", &img->levels_tiled, "root", "width", &rw,
                         "height", &rh, "mip_count", &img->root_mips, "side", &side);
    /* Height and sample stores (docs/FORMAT.md sections 12 and 13): tiles
     * of 16-bit codes, and what their picture is made from. */
    json_t *el = json_object_get(j, "elevation"), *sa = json_object_get(j, "samples");
    const char *win = json_string_value(json_object_get(j, "window"));
    if (win && strlen(win) < sizeof img->window)
        snprintf(img->window, sizeof img->window, "%s", win);
    int codes_ok = 1;
    if (el) {
        img->kind = GV_KIND_HEIGHT;
        codes_ok = json_unpack(el, "{s:F,s:F,s:F,s:F}", "scale", &img->scale, "offset",
                               &img->offset, "min", &img->min, "max", &img->max) == 0;
    } else if (sa) {
        int lo = -1, hi = -1;
        img->kind = GV_KIND_SAMPLES;
        codes_ok = json_unpack(sa, "{s:F,s:F,s:i,s:i}", "scale", &img->scale, "offset",
                               &img->offset, "code_min", &lo, "code_max", &hi) == 0 &&
                   lo >= 0 && hi >= lo && hi <= 65535;
        img->code_min = (unsigned)lo;
        img->code_max = (unsigned)hi;
        const char *col = json_string_value(
            json_object_get(json_object_get(j, "metadata"), "display.colours"));
        if (col && strlen(col) < sizeof img->colours)
            snprintf(img->colours, sizeof img->colours, "%s", col);
    }
    json_t *mpp = json_object_get(json_object_get(j, "metadata"), "slide.mpp_x");
    if (json_is_number(mpp) && json_number_value(mpp) > 0 &&
        json_number_value(mpp) < 1e6)
        img->mpp = json_number_value(mpp);
    json_decref(j);
    const int max_channels = img->kind == GV_KIND_SAMPLES ? GV_SAMPLES_MAX_CHANNELS
                           : img->kind == GV_KIND_HEIGHT ? 1 : 3;
    if (!codes_ok || img->channels < 1 || img->channels > max_channels ||
        (img->kind == GV_KIND_IMAGE && img->channels == 2))
        return gv_fail(err, GV_ECORRUPT, "%s: unexpected metadata from the server",
                       what);
    if (rc < 0 || w <= 0 || hh <= 0 || w > 0x7fffffff || hh > 0x7fffffff ||
        rw <= 0 || rh <= 0 ||
        rw > 512 || rh > 512 || side < 1 || side > 512 || img->levels_tiled < 0 ||
        img->root_mips < 1)
        return gv_fail(err, GV_ECORRUPT, "%s: unexpected metadata from the server",
                       what);
    img->width = (uint32_t)w;
    img->height = (uint32_t)hh;
    img->root_w = (uint32_t)rw;
    img->root_h = (uint32_t)rh;
    img->root_side = (uint32_t)side;
    return 0;
}

/* The body of finished transfer x, checked (xfer_check; a 304 is allowed
 * when there is cached data): on a 200 returns 0 and moves x's body to
 * *out (a 1-byte buffer when empty); on a 304 returns 1 and moves *cached
 * (cached_len bytes) to *out, setting *cached to NULL.  Returns -1 with
 * *err filled otherwise; *cached then stays the caller's. */
static int settle(struct gv_http *h, struct xfer *x, const char *what,
                  uint8_t **cached,
                  size_t cached_len, uint8_t **out, size_t *len,
                  struct gv_error *err)
{
    if (xfer_check(h, x, what, *cached != NULL, err) < 0)
        return -1;
    if (x->status == 304) {
        *out = *cached;
        *len = cached_len;
        *cached = NULL;
        return 1;
    }
    *out = x->body ? x->body : malloc(1);
    if (!*out)
        return gv_fail(err, GV_ENOMEM, "http: out of memory");
    *len = x->len;
    x->body = NULL;
    return 0;
}

void gv_remote_mip_size(const struct gv_remote_image *img, int mip, uint32_t *w,
                        uint32_t *h)
{
    *w = img->root_w;
    *h = img->root_h;
    for (int m = 0; m < mip; m++) {
        *w = (*w + 1) / 2;
        *h = (*h + 1) / 2;
    }
}

/* GET path through the disk cache entry `name` of dc (may be NULL): a
 * cached entry (of want bytes, when want > 0) is revalidated with its
 * ETag, a 200 replaces it.  0 with *out (malloc'ed) and *len, or -1 with
 * *err; *status is the HTTP status (0 when there was none). */
static int get_cached(struct gv_http *h, const char *path, const char *name,
                      const char *what, size_t want, struct gv_disk_cache *dc,
                      uint8_t **out, size_t *len, long *status,
                      struct gv_error *err)
{
    char etag[160] = "";
    uint8_t *cached = NULL;
    size_t clen = 0;
    *status = 0;
    if (gv_disk_cache_get(dc, name, &cached, &clen, etag, sizeof etag) < 0 ||
        (want && clen != want)) {
        free(cached);
        cached = NULL;
        etag[0] = 0;
    }
    struct xfer x;
    if (xfer_init(h, &x, path, cached ? etag : NULL) < 0) {
        xfer_done(&x);
        free(cached);
        return gv_fail(err, GV_ENOMEM, "http: out of memory");
    }
    *out = NULL;
    *len = 0;
    int rc = run_all(h, &x, 1, err);
    if (rc == 0) {
        *status = x.status;
        rc = settle(h, &x, what, &cached, clen, out, len, err);
    }
    if (rc >= 0 && want && *len != want) {
        rc = gv_fail(err, GV_ECORRUPT, "%s: %zu bytes from the server, expected "
                     "%zu", what, *len, want);
    } else if (rc == 0) {
        gv_disk_cache_put(dc, name, *out, *len, x.etag);
    }
    xfer_done(&x);
    free(cached);
    if (rc < 0) {
        free(*out);
        *out = NULL;
        return -1;
    }
    return 0;
}

int gv_remote_sample_bytes(const struct gv_remote_image *img)
{
    return img->kind == GV_KIND_IMAGE ? 1 : 2;
}

struct gv_height_meta gv_remote_height_meta(const struct gv_remote_image *img)
{
    return (struct gv_height_meta){.scale = img->scale, .offset = img->offset,
                                   .min = img->min, .max = img->max};
}

struct gv_header gv_remote_header(const struct gv_remote_image *img)
{
    return (struct gv_header){.kind = (uint8_t)img->kind, .channels = (uint8_t)img->channels,
                              .samples_lo = (uint16_t)img->code_min,
                              .samples_hi = (uint16_t)img->code_max};
}

/* A tile buffer of img checked as its kind of store wants. */
static int tile_check(const struct gv_remote_image *img, const uint8_t *buf,
                      size_t len, struct gv_error *err)
{
    return img->kind != GV_KIND_IMAGE ? gv_samples_tile_check(buf, len, img->channels, err)
                      : gv_tilebuf_check(buf, len, img->channels, err);
}

int gv_http_root(struct gv_http *h, const struct gv_remote_image *img, int mip,
                 struct gv_disk_cache *dc, uint8_t **pixels, uint32_t *w,
                 uint32_t *hh, struct gv_error *err)
{
    uint32_t mw, mh;
    gv_remote_mip_size(img, mip, &mw, &mh);
    const size_t want = (size_t)mw * mh * img->channels * gv_remote_sample_bytes(img);
    char path[400], name[32], what[64];
    snprintf(path, sizeof path, "/v1/images/%s/root?mip=%d&format=raw", img->id, mip);
    snprintf(name, sizeof name, "root-%d", mip);
    snprintf(what, sizeof what, "root mip %d (%ux%ux%d)", mip, mw, mh,
             img->channels);
    size_t len;
    long status;
    if (get_cached(h, path, name, what, want, dc, pixels, &len, &status, err) < 0)
        return -1;
    *w = mw;
    *hh = mh;
    return 0;
}

int gv_http_root_webp(struct gv_http *h, const struct gv_remote_image *img,
                      struct gv_disk_cache *dc, uint8_t **webp, size_t *len,
                      struct gv_error *err)
{
    char path[400];
    snprintf(path, sizeof path, "/v1/images/%s/root?format=webp", img->id);
    long status;
    struct gv_error e = {0};
    if (get_cached(h, path, "root-webp", "root (WebP)", 0, dc, webp, len,
                   &status, &e) == 0)
        return 0;
    if (status == 400 || status == 404)
        return 1;
    if (err)
        *err = e;
    return -1;
}

/* Fetch t[0..n) with one request each (If-None-Match from dc). */
static int tiles_one_by_one(struct gv_http *h, const struct gv_remote_image *img,
                            struct gv_tile_want *t, size_t n,
                            struct gv_disk_cache *dc, struct gv_error *err)
{
    if (n == 0)
        return 0;
    struct xfer *x = calloc(n, sizeof *x);
    uint8_t **cached = calloc(n, sizeof *cached);
    size_t *clen = calloc(n, sizeof *clen);
    int rc = 0;
    if (!x || !cached || !clen) {
        rc = gv_fail(err, GV_ENOMEM, "http: out of memory");
        goto out;
    }
    for (size_t i = 0; i < n && rc == 0; i++) {
        char path[400], name[64], etag[160] = "";
        snprintf(path, sizeof path, "/v1/images/%s/tiles/%d/%u/%u", img->id,
                 t[i].level, t[i].tx, t[i].ty);
        snprintf(name, sizeof name, "%d-%u-%u", t[i].level, t[i].tx, t[i].ty);
        if (gv_disk_cache_get(dc, name, &cached[i], &clen[i], etag, sizeof etag) == 0 &&
            tile_check(img, cached[i], clen[i], NULL) < 0) {
            free(cached[i]);   /* damaged entry: fetch afresh */
            cached[i] = NULL;
        }
        if (xfer_init(h, &x[i], path, cached[i] ? etag : NULL) < 0)
            rc = gv_fail(err, GV_ENOMEM, "http: out of memory");
    }
    if (rc == 0)
        rc = run_all(h, x, n, err);
    for (size_t i = 0; i < n && rc == 0; i++) {
        char what[96], name[64];
        snprintf(what, sizeof what, "tile %d/%u/%u", t[i].level, t[i].tx, t[i].ty);
        snprintf(name, sizeof name, "%d-%u-%u", t[i].level, t[i].tx, t[i].ty);
        int s = settle(h, &x[i], what, &cached[i], clen[i], &t[i].buf,
                       &t[i].len, err);
        if (s < 0) {
            rc = -1;
            break;
        }
        struct gv_error te = {0};
        if (tile_check(img, t[i].buf, t[i].len, &te) < 0) {
            rc = gv_fail(err, GV_ECORRUPT, "%s from %s is corrupt (%zu bytes): %s",
                         what, h->base, t[i].len, te.text);
            break;
        }
        if (s == 1)
            h->st.revalidated++;
        else {
            h->st.downloaded++;
            gv_disk_cache_put(dc, name, t[i].buf, t[i].len, x[i].etag);
        }
    }
out:
    for (size_t i = 0; x && i < n; i++)
        xfer_done(&x[i]);
    for (size_t i = 0; cached && i < n; i++)
        free(cached[i]);
    free(x);
    free(cached);
    free(clen);
    return rc;
}

/* The disk cache entry of a tile, if it passes gv_tilebuf_check: *data
 * (malloc'ed) and etag, else *data NULL. */
static void cached_tile(struct gv_disk_cache *dc, const struct gv_remote_image *img,
                        const struct gv_tile_want *t, uint8_t **data,
                        size_t *len, char *etag)
{
    char name[64];
    snprintf(name, sizeof name, "%d-%u-%u", t->level, t->tx, t->ty);
    etag[0] = 0;
    if (gv_disk_cache_get(dc, name, data, len, etag, ETAG_CAP) < 0) {
        *data = NULL;
    } else if (tile_check(img, *data, *len, NULL) < 0) {
        free(*data);   /* damaged entry: fetch afresh */
        *data = NULL;
    }
}

/* One batch request: tiles t[0..n) (n <= BATCH_TILES) with their cache
 * entries, and its transfer. */
struct batch_req {
    struct gv_tile_want *t;
    size_t n;
    uint8_t **cached;
    size_t *clen;
    char (*etag)[ETAG_CAP];
    struct xfer *x;         /* in the array run_all runs */
};

/* Set up b's transfer: POST {"tiles": [...]} to .../batch?etag=1 with the
 * cached ETags in If-None-Match.  0 or -1 (out of memory). */
static int batch_init(struct gv_http *h, const struct gv_remote_image *img,
                      struct batch_req *b)
{
    size_t jcap = 32 + b->n * 40, icap = 1 + b->n * (ETAG_CAP + 2), jl = 0, il = 0;
    char *json = malloc(jcap), *inm = malloc(icap);
    int rc = -1;
    if (!json || !inm)
        goto out;
    jl += (size_t)snprintf(json + jl, jcap - jl, "{\"tiles\":[");
    inm[0] = 0;
    for (size_t i = 0; i < b->n; i++) {
        jl += (size_t)snprintf(json + jl, jcap - jl, "%s[%d,%u,%u]", i ? "," : "",
                               b->t[i].level, b->t[i].tx, b->t[i].ty);
        if (b->cached[i] && b->etag[i][0])
            il += (size_t)snprintf(inm + il, icap - il, "%s%s", il ? ", " : "",
                                   b->etag[i]);
    }
    snprintf(json + jl, jcap - jl, "]}");
    char path[400];
    snprintf(path, sizeof path, "/v1/images/%s/batch?etag=1", img->id);
    if (xfer_init(h, b->x, path, inm) == 0 && xfer_post_json(b->x, json) == 0)
        rc = 0;
out:
    free(json);
    free(inm);
    return rc;
}

/* Tile i of b from its frame: a 200 is checked and goes to the disk cache
 * with its ETag; a 304 takes the cached entry.  0 or -1. */
static int batch_take(struct gv_http *h, const struct gv_remote_image *img,
                      struct gv_disk_cache *dc, struct batch_req *b, size_t i,
                      const struct gv_batch_frame *f, struct gv_error *err)
{
    struct gv_tile_want *t = &b->t[i];
    char what[96], name[64], etag[ETAG_CAP];
    snprintf(what, sizeof what, "tile %d/%u/%u", t->level, t->tx, t->ty);
    snprintf(name, sizeof name, "%d-%u-%u", t->level, t->tx, t->ty);
    if (f->level != (uint32_t)t->level || f->tx != t->tx || f->ty != t->ty)
        return gv_fail(err, GV_ECORRUPT, "%s: the batch answered tile %u/%u/%u "
                       "in its place", what, f->level, f->tx, f->ty);
    if (f->status == 304 && b->cached[i]) {
        t->buf = b->cached[i];
        t->len = b->clen[i];
        b->cached[i] = NULL;
        h->st.revalidated++;
        return 0;
    }
    if (f->status != 200)
        return gv_fail(err, f->status == 404 ? GV_ENOTFOUND : GV_EIO,
                       "%s: the server answered HTTP %u in a batch", what,
                       f->status);
    if (!(t->buf = malloc(f->len ? f->len : 1)))
        return gv_fail(err, GV_ENOMEM, "http: out of memory");
    memcpy(t->buf, f->data, f->len);
    t->len = f->len;
    struct gv_error te = {0};
    if (tile_check(img, t->buf, t->len, &te) < 0)
        return gv_fail(err, GV_ECORRUPT, "%s from %s is corrupt (%zu bytes): %s",
                       what, h->base, t->len, te.text);
    h->st.downloaded++;
    size_t el = f->etag_len < ETAG_CAP ? f->etag_len : 0;
    memcpy(etag, f->etag, el);
    etag[el] = 0;
    gv_disk_cache_put(dc, name, t->buf, t->len, etag);
    return 0;
}

/* The answer to batch b: its frames into b's tiles; a 413 (the server
 * allows fewer tiles per batch) fetches them one by one.  0 or -1. */
static int batch_settle(struct gv_http *h, const struct gv_remote_image *img,
                        struct gv_disk_cache *dc, struct batch_req *b,
                        struct gv_error *err)
{
    if (b->x->result == CURLE_OK && b->x->status == 413)
        return tiles_one_by_one(h, img, b->t, b->n, dc, err);
    if (xfer_check(h, b->x, "batch", 0, err) < 0)
        return -1;
    struct gv_batch_frame *f = calloc(b->n, sizeof *f);
    if (!f)
        return gv_fail(err, GV_ENOMEM, "http: out of memory");
    int rc = gv_batch_frames_parse(b->x->body, b->x->len, b->n, f, err);
    for (size_t i = 0; i < b->n && rc == 0; i++)
        rc = batch_take(h, img, dc, b, i, &f[i], err);
    free(f);
    return rc;
}

int gv_http_tiles(struct gv_http *h, const struct gv_remote_image *img,
                  struct gv_tile_want *t, size_t n, struct gv_disk_cache *dc,
                  struct gv_error *err)
{
    if (n == 0)
        return 0;
    if (!h->batches)
        return tiles_one_by_one(h, img, t, n, dc, err);
    size_t nb = (n + BATCH_TILES - 1) / BATCH_TILES;
    struct batch_req *b = calloc(nb, sizeof *b);
    struct xfer *x = calloc(nb, sizeof *x);
    uint8_t **cached = calloc(n, sizeof *cached);
    size_t *clen = calloc(n, sizeof *clen);
    char (*etag)[ETAG_CAP] = calloc(n, sizeof *etag);
    int rc = 0;
    if (!b || !x || !cached || !clen || !etag) {
        rc = gv_fail(err, GV_ENOMEM, "http: out of memory");
        goto out;
    }
    for (size_t i = 0; i < n; i++)
        cached_tile(dc, img, &t[i], &cached[i], &clen[i], etag[i]);
    for (size_t j = 0; j < nb && rc == 0; j++) {
        size_t i0 = j * BATCH_TILES;
        b[j] = (struct batch_req){&t[i0], n - i0 < BATCH_TILES ? n - i0 : BATCH_TILES,
                                  &cached[i0], &clen[i0], &etag[i0], &x[j]};
        if (batch_init(h, img, &b[j]) < 0)
            rc = gv_fail(err, GV_ENOMEM, "http: out of memory");
    }
    if (rc == 0)
        rc = run_all(h, x, nb, err);
    for (size_t j = 0; j < nb && rc == 0; j++)
        rc = batch_settle(h, img, dc, &b[j], err);
out:
    for (size_t j = 0; x && j < nb; j++)
        xfer_done(&x[j]);
    for (size_t i = 0; cached && i < n; i++)
        free(cached[i]);
    free(b);
    free(x);
    free(cached);
    free(clen);
    free(etag);
    return rc;
}
