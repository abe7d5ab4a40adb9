/*
 * http.c - libmicrohttpd set-up, routing, per-request state, responses
 * and the error table (see http.h).
 *
 * cfg->threads libmicrohttpd daemons, each one internal thread with its
 * own epoll set and no listen socket, so a handler may block (a page read,
 * a region render) without stalling connections on other threads.
 * acceptor.c accepts on the one listen socket and hands each connection
 * to the daemon with the fewest (MHD_add_connection, which needs
 * MHD_USE_ITC to wake the daemon's thread); SIGTERM stops the acceptor,
 * so no connection is accepted while requests in flight finish.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>

#include "acceptor.h"
#include "conn_watch.h"
#include "http.h"
#include "listen_fds.h"
#include "log.h"
#include "metrics.h"
#include "rate_limit.h"
#include "router.h"
#include "routes.h"

/* ---------------------------------------------------------- error table */

/* The one failure that only the HTTP layer has: a method the route does
 * not take.  Numbered after every gv_code, so that the table holds it. */
#define HTTP_EMETHOD (GV_CODE_MAX + 1)
/* A request target over max_url_bytes (414), a head over
 * max_header_bytes (431). */
#define HTTP_EURI (GV_CODE_MAX + 2)
#define HTTP_EHEAD (GV_CODE_MAX + 3)
/* A client past its rate_limit (429). */
#define HTTP_ERATE (GV_CODE_MAX + 4)

/* Every error status and JSON code gigaviewd answers with. */
static const struct {
    int code;              /* enum gv_code, or HTTP_EMETHOD */
    unsigned status;       /* /v1 routes */
    unsigned iiif_status;  /* IIIF routes: the spec knows no 413 */
    const char *name;
} error_table[] = {
    {GV_OK, 500, 500, "internal"},
    {GV_EINVAL, 400, 400, "bad_request"},
    {GV_ENOTFOUND, 404, 404, "not_found"},
    {GV_ELIMIT, 413, 400, "too_large"},
    {GV_EFORMAT, 501, 501, "not_implemented"},
    {GV_ECORRUPT, 500, 500, "corrupt"},
    {GV_EIO, 500, 500, "io_error"},
    {GV_ENOSPC, 507, 507, "no_space"},
    {GV_ENOMEM, 503, 503, "out_of_memory"},
    {GV_EUNAVAIL, 503, 503, "unavailable"},
    {GV_EBUSY, 503, 503, "busy"},
    {GV_ETIMEOUT, 504, 504, "timeout"},
    {GV_ECRASH, 500, 500, "worker_crashed"},
    {GV_EPERM, 403, 403, "forbidden"},
    {GV_EAUTH, 401, 401, "unauthorized"},
    {HTTP_EMETHOD, 405, 405, "method_not_allowed"},
    {HTTP_EURI, 414, 414, "uri_too_long"},
    {HTTP_EHEAD, 431, 431, "headers_too_large"},
    {HTTP_ERATE, 429, 429, "too_many_requests"},
};

/* The row of `code`; an unknown code is "internal" (500). */
static size_t error_row(int code)
{
    for (size_t k = 0; k < sizeof error_table / sizeof error_table[0]; k++)
        if (error_table[k].code == code)
            return k;
    return 0;
}

/* The status of table row i on r's route. */
static unsigned row_status(const struct req *r, size_t i)
{
    return r->iiif ? error_table[i].iiif_status : error_table[i].status;
}

unsigned http_error_status(const struct req *r, enum gv_code code)
{
    return row_status(r, error_row((int)code));
}

/* ------------------------------------------------------------ responses */

/* An answer that depends on the caller: no shared cache may keep it
 * ("public" becomes "private", other directives stay; no-store stays as
 * it is), and every cache keys it by the credentials. */
static void make_private(struct MHD_Response *resp)
{
    const char *cc = MHD_get_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL);
    if (!cc) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "private");
    } else if (!strstr(cc, "no-store") && !strstr(cc, "private")) {
        char old[256], now[300];
        snprintf(old, sizeof old, "%s", cc);
        if (!strncmp(old, "public", 6))
            snprintf(now, sizeof now, "private%s", old + 6);
        else
            snprintf(now, sizeof now, "private, %s", old);
        MHD_del_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, old);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, now);
    }
    const char *vary = MHD_get_response_header(resp, MHD_HTTP_HEADER_VARY);
    if (vary) {
        char old[256], now[300];
        snprintf(old, sizeof old, "%s", vary);
        snprintf(now, sizeof now, "%s, Authorization, Cookie", old);
        MHD_del_response_header(resp, MHD_HTTP_HEADER_VARY, old);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY, now);
    } else {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY,
                                "Authorization, Cookie");
    }
}

static void add_common_headers(struct req *r, struct MHD_Response *resp)
{
    const char *origin = r->iiif ? "*" : r->srv->cfg->cors_origin;
    if (origin[0]) {
        MHD_add_response_header(resp, "Access-Control-Allow-Origin", origin);
        MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                                "ETag, Link, Location, X-Width, X-Height, "
                                "X-Channels, X-Level");
    }
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    if (r->private_answer)
        make_private(resp);
}

enum MHD_Result http_send(struct req *r, unsigned status,
                          struct MHD_Response *resp, size_t body_len)
{
    if (!resp) {
        log_msg(LOG_ERROR, "http", "cannot create a response");
        r->status = 500;
        return MHD_NO;
    }
    add_common_headers(r, resp);
    r->status = status;
    r->bytes = r->head ? 0 : body_len;
    r->responded = 1;
    enum MHD_Result ret = MHD_queue_response(r->conn, status, resp);
    MHD_destroy_response(resp);
    return ret;
}

struct MHD_Response *http_response_copy(const void *body, size_t len,
                                        const char *type)
{
    struct MHD_Response *resp = MHD_create_response_from_buffer(
        len, (void *)body, MHD_RESPMEM_MUST_COPY);
    if (resp && type)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    return resp;
}

struct MHD_Response *http_response_owned(void *body, size_t len,
                                         const char *type)
{
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback(len, body, free);
    if (!resp) {
        free(body);
        return NULL;
    }
    if (type)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    return resp;
}

struct MHD_Response *http_response_json(json_t *json, size_t flags,
                                        const char *type, size_t *len)
{
    char *s = json ? json_dumps(json, flags) : NULL;
    json_decref(json);
    *len = 0;
    if (!s)
        return NULL;
    size_t n = strlen(s);
    s[n] = '\n'; /* json_dumps leaves room: replace the NUL, length + 1 */
    *len = n + 1;
    return http_response_owned(s, n + 1, type);
}

void http_header_int(struct MHD_Response *resp, const char *name, long long v)
{
    char s[32];
    snprintf(s, sizeof s, "%lld", v);
    MHD_add_response_header(resp, name, s);
}

void http_header_etag_hour(struct MHD_Response *resp, const char *etag)
{
    if (!resp)
        return;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, etag);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=3600");
}

enum MHD_Result http_send_owned(struct req *r, unsigned status,
                                const char *type, void *body, size_t len)
{
    return http_send(r, status, http_response_owned(body, len, type), len);
}

enum MHD_Result http_send_json_header(struct req *r, unsigned status,
                                      json_t *json, const char *name,
                                      const char *value)
{
    size_t len;
    struct MHD_Response *resp = http_response_json(
        json, JSON_COMPACT | JSON_REAL_PRECISION(8), "application/json", &len);
    if (resp && name)
        MHD_add_response_header(resp, name, value);
    return http_send(r, status, resp, len);
}

enum MHD_Result http_send_json(struct req *r, unsigned status, json_t *json)
{
    return http_send_json_header(r, status, json, NULL, NULL);
}

/* The error body of row `code` of the table, logged, with one extra
 * header (name NULL: none) and the members of `extra` (stolen; NULL:
 * none) beside "error". */
static enum MHD_Result send_error_with(struct req *r, int code,
                                       const char *message, const char *name,
                                       const char *value, json_t *extra)
{
    size_t i = error_row(code);
    unsigned status = row_status(r, i);
    const char *id = error_table[i].name;
    if (!message[0])
        message = "internal error";
    char esc[400];
    log_msg(status >= 500 ? LOG_WARN : LOG_DEBUG, "http", "%u %s: %s", status,
            id, log_escape(esc, sizeof esc, message));
    json_t *e = json_pack("{s:{s:i,s:s,s:s}}", "error", "status", (int)status,
                          "code", id, "message", message);
    if (e && extra)
        json_object_update_missing(e, extra);
    json_decref(extra);
    size_t len;
    struct MHD_Response *resp =
        http_response_json(e, JSON_COMPACT, "application/json", &len);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
        if (name)
            MHD_add_response_header(resp, name, value);
    }
    return http_send(r, status, resp, len);
}

static enum MHD_Result send_error(struct req *r, int code, const char *message,
                                  const char *name, const char *value)
{
    return send_error_with(r, code, message, name, value, NULL);
}

enum MHD_Result http_send_error(struct req *r, const struct gv_error *err)
{
    return send_error(r, (int)err->code, err->text, NULL, NULL);
}

enum MHD_Result http_send_fail(struct req *r, enum gv_code code,
                               const char *message, const char *name,
                               const char *value)
{
    return send_error(r, (int)code, message, name, value);
}

enum MHD_Result http_send_errorf(struct req *r, enum gv_code code,
                                 const char *fmt, ...)
{
    struct gv_error err = {0};
    err.code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err.text, sizeof err.text, fmt, ap);
    va_end(ap);
    return http_send_error(r, &err);
}

enum MHD_Result http_send_empty(struct req *r, unsigned status,
                                const char *header, const char *value)
{
    struct MHD_Response *resp =
        MHD_create_response_from_buffer(0, (void *)"", MHD_RESPMEM_PERSISTENT);
    if (resp && header)
        MHD_add_response_header(resp, header, value);
    return http_send(r, status, resp, 0);
}

/* ------------------------------------------------------------- requests */

const char *http_header(struct req *r, const char *name)
{
    return MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, name);
}

const char *http_query(struct req *r, const char *name)
{
    return MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, name);
}

/* Same shape as parse_uint in iiif.c: deliberately separate, iiif.c (pure,
 * fuzzed) parses a span up to GV_MAX_DIM without http.c. */
int http_parse_u32(const char *s, uint32_t max, uint32_t *out)
{
    if (!s || !*s)
        return -1;
    uint64_t v = 0;
    for (const char *p = s; *p; p++) {
        if (*p < '0' || *p > '9')
            return -1;
        v = v * 10 + (uint64_t)(*p - '0');
        if (v > max)
            return -1;
    }
    *out = (uint32_t)v;
    return 0;
}

void http_base_url(struct req *r, char *buf, size_t size)
{
    const struct settings *cfg = r->srv->cfg;
    if (cfg->public_url[0]) {
        snprintf(buf, size, "%s", cfg->public_url);
        size_t n = strlen(buf);
        while (n > 0 && buf[n - 1] == '/')
            buf[--n] = '\0';
        return;
    }
    const char *host = http_header(r, "Host");
    int good = host && *host && strlen(host) < 200;
    for (const char *p = host; good && *p; p++)
        good = (*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') ||
               (*p >= '0' && *p <= '9') || strchr(".-:[]_", *p);
    if (good)
        snprintf(buf, size, "http://%s", host);
    else if (strchr(cfg->listen, ':'))
        snprintf(buf, size, "http://[%s]:%u", cfg->listen, r->srv->port);
    else
        snprintf(buf, size, "http://%s:%u", cfg->listen, r->srv->port);
}

struct image *http_image(struct req *r, enum MHD_Result *ret)
{
    /* A hidden image the caller may not see is absent (guard_image):
     * every handler then answers exactly as it does for an absent one. */
    struct image *img = r->hidden ? NULL
                                  : catalog_get(r->srv->catalog, r->param[0]);
    if (!img)
        *ret = http_send_no_image(r);
    return img;
}

enum MHD_Result http_send_no_image(struct req *r)
{
    char esc[160];
    log_escape(esc, sizeof esc, r->param[0]);
    return http_send_errorf(r, GV_ENOTFOUND, "no image '%s'", esc);
}

const struct access_policy *http_policy(struct req *r)
{
    if (!r->policy_held) {
        r->policy = access_hold(r->srv->access);
        r->policy_held = 1;
    }
    return r->policy;
}

/* A Bearer token, or NULL. */
static const char *bearer(struct req *r)
{
    const char *h = http_header(r, "Authorization");
    if (!h || strncasecmp(h, "Bearer ", 7))
        return NULL;
    return h + 7 + strspn(h + 7, " ");
}

const struct access_claims *http_caller(struct req *r, int *refused)
{
    if (!r->caller_read) {
        r->caller_read = 1;
        const char *tokens[2] = {
            bearer(r), MHD_lookup_connection_value(r->conn, MHD_COOKIE_KIND,
                                                   HTTP_ACCESS_COOKIE)};
        for (int i = 0; i < 2 && r->caller_state != 1; i++) {
            if (!tokens[i] || !tokens[i][0])
                continue;
            enum access_token_status st =
                access_verify(r->srv->access, tokens[i], &r->caller);
            if (st == ACCESS_TOKEN_OK &&
                access_policy_revoked(http_policy(r), &r->caller)) {
                memset(&r->caller, 0, sizeof r->caller);
                st = ACCESS_TOKEN_REVOKED;
            }
            r->caller_state = st == ACCESS_TOKEN_OK ? 1 : -1;
            if (st != ACCESS_TOKEN_OK)
                log_msg(LOG_DEBUG, "access", "%s token refused: %s",
                        i ? "cookie" : "bearer", access_token_status_name(st));
        }
    }
    if (refused)
        *refused = r->caller_state < 0;
    return r->caller_state == 1 ? &r->caller : NULL;
}

enum access_verdict http_access(struct req *r, const char *id)
{
    const struct access_policy *p = http_policy(r);
    if (!p)
        return ACCESS_PUBLIC;
    enum access_verdict v = access_judge(p, http_caller(r, NULL), id, NULL);
    if (v == ACCESS_GRANTED || v == ACCESS_DENIED)
        r->private_answer = 1;
    return v;
}

/* The access check of a route that shows image param[0]: 0 when the
 * handler may run: the caller may see the image, or it is hidden from
 * them and the handler then finds no such image (http_image), so that
 * it answers exactly as for an absent one, whatever it checks first;
 * else -1 after queueing a 401 with WWW-Authenticate, and on info.json
 * the IIIF authorization services, so that a client learns where to
 * log in. */
static int guard_image(struct req *r, enum MHD_Result *ret)
{
    enum access_verdict v = http_access(r, r->param[0]);
    r->hidden = v == ACCESS_HIDDEN;
    if (v != ACCESS_DENIED)
        return 0;
    int refused;
    http_caller(r, &refused);
    char esc[160], msg[300];
    log_escape(esc, sizeof esc, r->param[0]);
    snprintf(msg, sizeof msg, "image '%s' is restricted: %s", esc,
             refused ? "the access token is invalid, expired or not of its "
                       "group" : "send an access token (Authorization: Bearer)");
    json_t *extra = NULL;
    if (r->route == ROUTE_IIIF_INFO)
        extra = json_pack("{s:o}", "service", auth_services_json(r, r->param[0]));
    *ret = send_error_with(r, GV_EAUTH, msg, "WWW-Authenticate",
                           refused ? "Bearer realm=\"gigaview\", "
                                     "error=\"invalid_token\""
                                   : "Bearer realm=\"gigaview\"", extra);
    return -1;
}

void http_page_error(const struct image *img, const char *module,
                     const char *where, const struct gv_error *err)
{
    if (err->code != GV_ECORRUPT && err->code != GV_EIO)
        return;
    atomic_fetch_add(&metrics.page_errors, 1);
    log_msg(LOG_ERROR, module, "%s: %s%s", img->id, where, err->text);
}

int http_authorized(struct req *r)
{
    const char *want = r->srv->cfg->auth_token;
    const char *got = http_header(r, "Authorization");
    if (!want[0] || !got || strncmp(got, "Bearer ", 7))
        return 0;
    got += 7;
    size_t n = strlen(want), m = strlen(got);
    /* Constant time in the token's content: always n comparisons. */
    unsigned char diff = (unsigned char)(n != m);
    for (size_t i = 0; i < n; i++)
        diff |= (unsigned char)(want[i] ^ (i < m ? got[i] : 0));
    return diff == 0;
}

double http_uptime(const struct server *srv)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)(now.tv_sec - srv->started.tv_sec) +
           (double)(now.tv_nsec - srv->started.tv_nsec) / 1e9;
}

int http_etag_listed(const char *inm, const char *etag)
{
    if (!inm || !etag)
        return 0;
    if (!strncmp(etag, "W/", 2))
        etag += 2;
    const size_t n = strlen(etag);
    const char *s = inm;
    for (;;) {
        s += strspn(s, " \t,");
        if (!*s)
            return 0;
        const char *tag = !strncmp(s, "W/", 2) ? s + 2 : s;
        const char *end = NULL;   /* past the entry when it is well formed */
        if (*s == '*')
            end = s + 1;
        else if (*tag == '"' && (end = strchr(tag + 1, '"')) != NULL)
            end++;
        const char *next = end ? end + strspn(end, " \t") : s;
        if (end && (!*next || *next == ',') &&
            (*s == '*' || ((size_t)(end - tag) == n && !memcmp(tag, etag, n))))
            return 1;
        s = next + strcspn(next, ",");
    }
}

/* Metrics id of a route: the first route with the same name. */
static int metrics_id(int route)
{
    if (route < 0)
        return -1;
    for (int i = 0; i < route; i++)
        if (!strcmp(router_routes[i].name, router_routes[route].name))
            return i;
    return route;
}

_Static_assert(HTTP_MAX_PARAMS >= ROUTER_MAX_PARAMS, "req.param[] too small");

/* Route the request (router.c) and run its handler, or answer 404, 405
 * or a CORS preflight. */
static enum MHD_Result dispatch(struct req *r)
{
    struct router_match m;
    enum router_result res = router_find(r->head ? "GET" : r->method,
                                         r->raw_path, &m);
    r->iiif = m.iiif;
    if (res == ROUTER_MATCH) {
        free(r->segbuf);
        r->segbuf = m.segbuf; /* freed with the request */
        for (int i = 0; i < m.nparam; i++)
            r->param[i] = m.param[i];
        r->nparam = m.nparam;
        r->route = m.route;
        enum MHD_Result ret;
        if (router_routes[m.route].image == ROUTER_IMAGE && m.nparam > 0 &&
            guard_image(r, &ret) < 0)
            return ret;
        return route_handlers[m.route](r);
    }
    router_match_free(&m);
    if (res == ROUTER_NOMEM)
        return http_send_errorf(r, GV_ENOMEM, "out of memory");
    if (res == ROUTER_NOT_FOUND)
        return http_send_errorf(r, GV_ENOTFOUND, "no such resource");
    const char *allow = m.allow;
    if (!strcmp(r->method, "OPTIONS")) { /* CORS preflight */
        struct MHD_Response *resp = MHD_create_response_from_buffer(
            0, (void *)"", MHD_RESPMEM_PERSISTENT);
        if (resp) {
            char methods[80];
            snprintf(methods, sizeof methods, "%s, OPTIONS", allow);
            MHD_add_response_header(resp, MHD_HTTP_HEADER_ALLOW, methods);
            MHD_add_response_header(resp, "Access-Control-Allow-Methods", methods);
            MHD_add_response_header(resp, "Access-Control-Allow-Headers",
                                    "Content-Type, If-None-Match, Authorization");
            MHD_add_response_header(resp, "Access-Control-Max-Age", "86400");
        }
        return http_send(r, 204, resp, 0);
    }
    char msg[128];
    snprintf(msg, sizeof msg, "method not allowed; allowed: %s", allow);
    return send_error(r, HTTP_EMETHOD, msg, MHD_HTTP_HEADER_ALLOW, allow);
}

/*
 * Percent-decoding of the path and the query arguments, in place: MHD's
 * own, except that "%00" stays undecoded (router_unescape).
 */
static size_t unescape(void *cls, struct MHD_Connection *conn, char *s)
{
    (void)cls;
    (void)conn;
    return router_unescape(s);
}

static void remote_address(struct MHD_Connection *conn, char *buf, size_t size)
{
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
    snprintf(buf, size, "-");
    if (!ci || !ci->client_addr)
        return;
    const struct sockaddr *sa = ci->client_addr;
    if (sa->sa_family == AF_INET)
        inet_ntop(AF_INET, &((const struct sockaddr_in *)sa)->sin_addr, buf,
                  (socklen_t)size);
    else if (sa->sa_family == AF_INET6)
        inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)sa)->sin6_addr, buf,
                  (socklen_t)size);
}

/* -1 after queueing a 429 when r's client is past rate_limit (docs/
 * OPERATIONS.md "Rate limits"); 0 otherwise.  The client is the
 * rate_limit_header's value when the request has one, else its address;
 * /healthz and /metrics, the operator's, are not counted. */
static int over_rate(struct req *r, enum MHD_Result *ret)
{
    struct rate_limit *rl = r->srv->rate;
    if (!rl || !strcmp(r->path, "/healthz") || !strcmp(r->path, "/metrics"))
        return 0;
    const char *h = r->srv->cfg->rate_limit_header;
    const char *key = h[0] ? MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, h) : NULL;
    if (!key || !key[0])
        key = r->remote;
    double wait = 0;   /* the request's arrival (r->t0) is its time */
    if (rate_limit_take(rl, key, strlen(key), (double)r->t0.tv_sec + r->t0.tv_nsec * 1e-9,
                        &wait))
        return 0;
    char secs[24], msg[160];
    snprintf(secs, sizeof secs, "%.0f", wait < 1 ? 1.0 : ceil(wait));
    snprintf(msg, sizeof msg, "too many requests from this client: at most %g a "
             "second after a burst of %g (rate_limit); retry after %s s",
             r->srv->cfg->rate_limit, r->srv->cfg->rate_limit_burst, secs);
    *ret = send_error(r, HTTP_ERATE, msg, "Retry-After", secs);
    return -1;
}

/* An announced body over its cap is read and dropped before the 413 when
 * it is at most this much (or the cap, if larger) over the cap. */
#define DRAIN_MIN (1u << 20)

/* The body cap: max_request_bytes, or simplify_max_bytes for a mesh
 * POSTed to /v1/meshes/simplify (route_mesh_simplify.c). */
static int is_simplify(const struct req *r)
{
    return !strcmp(r->path, "/v1/meshes/simplify") &&
           !strcmp(r->method, "POST");
}

static uint64_t body_cap(const struct req *r)
{
    return is_simplify(r) ? r->srv->cfg->simplify_max_bytes
                          : r->srv->cfg->max_request_bytes;
}

/* 413 for a body over the cap (announced or received): no
 * route has matched yet, so this is never an IIIF 400. */
static enum MHD_Result send_too_large(struct req *r)
{
    return http_send_errorf(r, GV_ELIMIT, "request body larger than %llu bytes "
                            "(%s)", (unsigned long long)body_cap(r),
                            is_simplify(r) ? "simplify_max_bytes"
                                           : "max_request_bytes");
}

/* The daemons, one per thread, the watchdog of their connections, and
 * what their callbacks need to tell the acceptor which one a connection
 * left or is busy. */
struct http_threads {
    int n;
    struct MHD_Daemon **daemon;
    struct http_thread {
        struct http_threads *all;
        int index;
    } *thread;
    struct acceptor *acceptor;
    struct conn_watch *watch;
};

/* The daemon this thread runs: set by its first connection's start,
 * which comes before any of its requests. */
static _Thread_local struct http_thread *this_thread;

/* Append one query argument to the string being built (struct query). */
struct query {
    char buf[1024];
    size_t len;
};

static enum MHD_Result add_query_arg(void *cls, enum MHD_ValueKind kind,
                                     const char *key, const char *value)
{
    (void)kind;
    struct query *q = cls;
    /* An access token (/iiif/auth/login?token=) is a credential: the log
     * shows that one was sent, not what it was. */
    if (value && !strcmp(key, "token"))
        value = "-";
    int n = snprintf(q->buf + q->len, sizeof q->buf - q->len, "%s%s%s%s",
                     q->len ? "&" : "", key, value ? "=" : "", value ? value : "");
    if (n < 0 || (size_t)n >= sizeof q->buf - q->len) {
        q->len = sizeof q->buf - 1;   /* truncated: the log shows the rest cut */
        return MHD_NO;
    }
    q->len += (size_t)n;
    return MHD_YES;
}

/* The request's query arguments as "k=v&k2=v2" (decoded, in the order
 * sent), malloc'ed, or NULL when there are none (or no memory). */
static char *query_string(struct MHD_Connection *conn)
{
    struct query q = {.len = 0};
    q.buf[0] = '\0';
    MHD_get_connection_values(conn, MHD_GET_ARGUMENT_KIND, add_query_arg, &q);
    return q.len ? strdup(q.buf) : NULL;
}

/* What the request head holds, for its limits (struct head_count). */
struct head_count {
    size_t bytes;          /* every header line, with ": " and CRLF */
    int content_length;    /* Content-Length headers */
    int length_differs;    /* ... with different values */
    const char *first_length;
    int chunked;           /* a Transfer-Encoding header */
};

static enum MHD_Result count_header(void *cls, enum MHD_ValueKind kind,
                                    const char *key, const char *value)
{
    (void)kind;
    struct head_count *h = cls;
    h->bytes += strlen(key) + (value ? strlen(value) : 0) + 4;
    if (!strcasecmp(key, "Content-Length")) {
        if (h->content_length++ && strcmp(h->first_length, value ? value : ""))
            h->length_differs = 1;
        else if (h->content_length == 1)
            h->first_length = value ? value : "";
    } else if (!strcasecmp(key, "Transfer-Encoding")) {
        h->chunked = 1;
    }
    return MHD_YES;
}

/* The query arguments in the raw target: '&'-separated pieces after '?'. */
static size_t count_args(const char *target)
{
    const char *q = strchr(target, '?');
    if (!q)
        return 0;
    size_t n = 0;
    for (const char *p = q + 1; *p;) {
        const char *e = strchr(p, '&');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        n += len > 0;
        p += len + (e != NULL);
    }
    return n;
}

/* The head's limits (max_url_bytes, max_header_bytes, max_query_args)
 * and its framing: one Content-Length at most (or equal ones), and not
 * with Transfer-Encoding (RFC 9112 section 6.3: a request that could be
 * framed two ways is refused, as a proxy in front may have framed it the
 * other way).  0, or -1 with the error answered (*ret). */
static int check_head(struct req *r, enum MHD_Result *ret)
{
    const struct settings *cfg = r->srv->cfg;
    size_t target = strlen(r->raw);
    if (target > cfg->max_url_bytes) {
        *ret = send_error(r, HTTP_EURI, "the request target is longer than "
                          "max_url_bytes", NULL, NULL);
        return -1;
    }
    struct head_count h = {0};
    MHD_get_connection_values(r->conn, MHD_HEADER_KIND, count_header, &h);
    if (target + h.bytes > cfg->max_header_bytes) {
        *ret = send_error(r, HTTP_EHEAD, "the request head is larger than "
                          "max_header_bytes", NULL, NULL);
        return -1;
    }
    size_t nargs = count_args(r->raw);
    if (nargs > cfg->max_query_args) {
        *ret = http_send_errorf(r, GV_EINVAL, "%zu query arguments, more than "
                                "max_query_args (%llu)", nargs,
                                (unsigned long long)cfg->max_query_args);
        return -1;
    }
    if (h.length_differs || (h.content_length && h.chunked)) {
        *ret = http_send_errorf(r, GV_EINVAL, "the request's length is "
                                "ambiguous: %s", h.chunked
                                ? "both Content-Length and Transfer-Encoding"
                                : "Content-Length headers that differ");
        return -1;
    }
    return 0;
}

/* Does the client wait for "100 Continue" before sending its body? */
static int expects_continue(struct req *r)
{
    const char *e = http_header(r, "Expect");
    return e && !strcasecmp(e, "100-continue");
}

/* libmicrohttpd's URI log callback: the first sight of a request, with
 * its target as sent (not yet percent-decoded).  The request's state is
 * made here, so that routing splits the raw path (an encoded '/' stays
 * inside its segment) and the limits see the target's real size.  What
 * this returns is the handler's *req_cls. */
static void *on_uri(void *cls, const char *uri, struct MHD_Connection *conn)
{
    struct req *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    r->raw = strdup(uri ? uri : "");
    if (!r->raw) {
        free(r);
        return NULL;
    }
    r->raw_path = strndup(r->raw, strcspn(r->raw, "?"));
    if (!r->raw_path) {
        free(r->raw);
        free(r);
        return NULL;
    }
    r->srv = cls;
    r->conn = conn;
    r->route = -1;
    const union MHD_ConnectionInfo *ci =
        MHD_get_connection_info(conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    r->watch = ci ? ci->socket_context : NULL;
    return r;
}

static struct conn_watch *watchdog(const struct req *r)
{
    return r->srv->http ? r->srv->http->watch : NULL;
}

const atomic_int *http_suspend(struct req *r, void *async,
                               void (*async_free)(void *async))
{
    r->async = async;
    r->async_free = async_free;
    r->suspended = 1;
    MHD_suspend_connection(r->conn);
    conn_watch_suspended(watchdog(r), r->watch, &r->gone);
    return &r->gone;
}

/* A suspended request runs again: stop watching for the hang-up; 1 when
 * the client hung up meanwhile. */
static int resumed_gone(struct req *r)
{
    if (!r->suspended)
        return 0;
    r->suspended = 0;
    conn_watch_resumed(watchdog(r), r->watch);
    return atomic_load(&r->gone);
}

static enum MHD_Result handle_request(void *cls, struct MHD_Connection *conn,
                                      const char *url, const char *method,
                                      const char *version, const char *upload,
                                      size_t *upload_size, void **req_cls)
{
    (void)version;
    (void)cls;
    struct req *r = *req_cls;
    if (!r) /* on_uri ran out of memory */
        return MHD_NO;
    if (!r->started) { /* first call: the head is in */
        r->started = 1;
        r->path = strdup(url);
        if (!r->path)
            return MHD_NO;
        r->query = query_string(conn);
        r->method = method;
        r->head = !strcmp(method, MHD_HTTP_METHOD_HEAD);
        clock_gettime(CLOCK_MONOTONIC, &r->t0);
        remote_address(conn, r->remote, sizeof r->remote);
        atomic_fetch_add(&metrics.in_flight, 1);
        enum MHD_Result ret;
        if (check_head(r, &ret) < 0 || over_rate(r, &ret) < 0)
            return ret;
        /* An announced oversized body: refused before it is sent when the
         * client waits for "100 Continue" or when it is far over the cap;
         * otherwise read and dropped, then refused, so that the client
         * reads the answer instead of a reset connection (libmicrohttpd
         * closes without reading what is left; request_timeout bounds the
         * reading). */
        const char *cl = MHD_lookup_connection_value(conn, MHD_HEADER_KIND,
                                                     "Content-Length");
        uint64_t cap = body_cap(r), drain = cap + (cap > DRAIN_MIN ? cap
                                                                   : DRAIN_MIN);
        uint32_t n;
        if (cl && (http_parse_u32(cl, (uint32_t)cap, &n) < 0)) {
            if (expects_continue(r) ||
                http_parse_u32(cl, (uint32_t)(drain < UINT32_MAX ? drain
                                              : UINT32_MAX), &n) < 0)
                return send_too_large(r);
            r->body_over = 1;
        }
        return MHD_YES;
    }
    if (resumed_gone(r)) { /* the job was skipped: nobody to answer */
        if (r->async && r->async_free)
            r->async_free(r->async);
        r->async = NULL;
        r->status = 499;
        return MHD_NO;
    }
    if (r->responded)
        return MHD_YES;
    if (*upload_size) {
        size_t n = *upload_size;
        *upload_size = 0;
        if (r->body_over || r->body_len + n > body_cap(r)) {
            r->body_over = 1;
            return MHD_YES;
        }
        char *b = realloc(r->body, r->body_len + n + 1);
        if (!b)
            return MHD_NO;
        memcpy(b + r->body_len, upload, n);
        r->body = b;
        r->body_len += n;
        r->body[r->body_len] = '\0';
        return MHD_YES;
    }
    if (!r->arrived) {
        r->arrived = 1;
        conn_watch_request_in(watchdog(r), r->watch);
    }
    if (r->body_over)
        return send_too_large(r);
    return dispatch(r);
}

/* The access handler: handle_request, with the acceptor told that this
 * thread is busy meanwhile. */
static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn,
                                  const char *url, const char *method,
                                  const char *version, const char *upload,
                                  size_t *upload_size, void **req_cls)
{
    struct http_thread *th = this_thread;
    if (th)
        acceptor_busy(th->all->acceptor, th->index, 1);
    enum MHD_Result ret = handle_request(cls, conn, url, method, version,
                                         upload, upload_size, req_cls);
    if (th)
        acceptor_busy(th->all->acceptor, th->index, 0);
    return ret;
}

static void free_req(struct req *r)
{
    if (r->policy_held)
        access_release(r->srv->access, r->policy);
    if (r->async && r->async_free)
        r->async_free(r->async);
    free(r->segbuf);
    free(r->body);
    free(r->path);
    free(r->query);
    free(r->raw_path);
    free(r->raw);
    free(r);
}

static void on_completed(void *cls, struct MHD_Connection *conn,
                         void **req_cls, enum MHD_RequestTerminationCode why)
{
    (void)cls;
    (void)conn;
    struct req *r = *req_cls;
    if (!r)
        return;
    *req_cls = NULL;
    resumed_gone(r);
    conn_watch_request_done(watchdog(r), r->watch);
    if (!r->started) { /* libmicrohttpd refused the head itself */
        free_req(r);
        return;
    }
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    uint64_t usec = (uint64_t)(now.tv_sec - r->t0.tv_sec) * 1000000u +
                    (uint64_t)((now.tv_nsec - r->t0.tv_nsec) / 1000);
    unsigned status = r->status;
    uint64_t bytes = r->bytes;
    /* Closed before the answer was complete, as nginx logs it; what was
     * queued but not sent is not counted. */
    if (why != MHD_REQUEST_TERMINATED_COMPLETED_OK &&
        (status == 0 || r->responded)) {
        status = 499;
        bytes = 0;
    }
    char target[2048];
    snprintf(target, sizeof target, "%s%s%s", r->path, r->query ? "?" : "",
             r->query ? r->query : "");
    log_access(r->remote, r->method, target, status,
               (unsigned long long)bytes, (unsigned long long)usec);
    metrics_record(metrics_id(r->route), status, usec, bytes);
    atomic_fetch_sub(&metrics.in_flight, 1);
    free_req(r);
}


static void on_connection(void *cls, struct MHD_Connection *conn,
                          void **socket_ctx, enum MHD_ConnectionNotificationCode t)
{
    struct http_thread *th = cls;
    this_thread = th;
    struct conn_watch *w = th->all->watch;
    if (t == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *ci =
            MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
        *socket_ctx = ci ? conn_watch_open(w, ci->connect_fd) : NULL;
    } else {
        conn_watch_close(w, *socket_ctx);
        *socket_ctx = NULL;
    }
    /* The acceptor first: once /metrics shows a connection closed, the
     * acceptor has counted it out too (tests/http_metrics.sh relies on
     * it). */
    if (t != MHD_CONNECTION_NOTIFY_STARTED)
        acceptor_closed(th->all->acceptor, th->index);
    metrics_connection(t == MHD_CONNECTION_NOTIFY_STARTED);
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
static void mhd_logger(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && msg[n - 1] == '\n')
        msg[--n] = '\0';
    char esc[600];
    /* A handler's MHD_NO is deliberate (a client gone while its request
     * was suspended; or out of memory, logged where it happened). */
    int ours = !strncmp(msg, "Application reported internal error", 35);
    log_msg(ours ? LOG_DEBUG : LOG_WARN, "mhd", "%s",
            log_escape(esc, sizeof esc, msg));
}
#pragma GCC diagnostic pop

/* The socket to accept on: the one systemd passed (listen_fds.h; made
 * non-blocking, its port into *port), else a socket of our own bound to
 * listen:port (acceptor_listen).  Returns it, or -1 after a message. */
static int open_listen_socket(const struct settings *cfg, uint16_t *port)
{
    struct gv_error err = {0};
    int fd = listen_fds_take(&err);
    if (fd == -2) {
        log_msg(LOG_ERROR, "http", "%s", err.text);
        return -1;
    }
    if (fd < 0) {
        fd = acceptor_listen(cfg->listen, (unsigned)cfg->port, port, &err);
        if (fd < 0)
            log_msg(LOG_ERROR, "http", "%s", err.text);
        return fd;
    }
    int fl = fcntl(fd, F_GETFL);
    if (fl < 0 || fcntl(fd, F_SETFL, fl | O_NONBLOCK) < 0) {
        log_msg(LOG_ERROR, "http", "the socket systemd passed: %s", strerror(errno));
        close(fd);
        return -1;
    }
    struct sockaddr_storage at;
    socklen_t len = sizeof at;
    char host[INET6_ADDRSTRLEN] = "?";
    int named = getsockname(fd, (struct sockaddr *)&at, &len) == 0;
    if (named && at.ss_family == AF_INET) {
        const struct sockaddr_in *a = (const struct sockaddr_in *)&at;
        inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
        *port = ntohs(a->sin_port);
    } else if (named && at.ss_family == AF_INET6) {
        const struct sockaddr_in6 *a = (const struct sockaddr_in6 *)&at;
        inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
        *port = ntohs(a->sin6_port);
    }
    log_msg(LOG_INFO, "http", "listening on the socket systemd passed (fd %d, %s "
            "port %u); listen and port are not used", fd, host, *port);
    return fd;
}

/* Stop the daemons started so far and free them (the acceptor stopped). */
static void stop_threads(struct http_threads *h)
{
    for (int i = 0; i < h->n; i++)
        if (h->daemon[i])
            MHD_stop_daemon(h->daemon[i]);
    acceptor_free(h->acceptor);
    conn_watch_stop(h->watch);
    free(h->daemon);
    free(h->thread);
    free(h);
}

/* libmicrohttpd's memory for one connection: the head must fit in it
 * (beyond, libmicrohttpd answers 414 or 431 itself, in HTML), so it holds
 * a head at our limits twice over (the target is part of the head), so
 * that our JSON answers those; then a header entry per query argument,
 * and the response's header lines (its body is sent from its own
 * buffer).  Kept no larger: libmicrohttpd zeroes half the pool (the read
 * buffer it starts each request with) between the requests of a
 * connection, which at 118 KiB (the 32K limit and 32 KiB of slack before
 * 2026-12-03) was a quarter of the CPU time of a raw tile. */
static size_t pool_bytes(const struct settings *cfg)
{
    size_t head = cfg->max_url_bytes > cfg->max_header_bytes
                      ? cfg->max_url_bytes : cfg->max_header_bytes;
    return 2 * head + 64 * (size_t)cfg->max_query_args + 8192;
}

/* One daemon without a listen socket, on its own internal thread. */
static struct MHD_Daemon *start_daemon(struct server *srv, struct http_thread *th)
{
    const struct settings *cfg = srv->cfg;
    /* MHD_ALLOW_SUSPEND_RESUME: filter requests wait for their worker
     * suspended, not blocking a thread (route_filters.c).  The acceptor
     * keeps connection_limit over all daemons, so none refuses one. */
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL |
                     MHD_USE_ITC | MHD_USE_ERROR_LOG | MHD_ALLOW_SUSPEND_RESUME |
                     MHD_USE_NO_LISTEN_SOCKET;
    return MHD_start_daemon(
        flags, 0, NULL, NULL, on_request, srv,
        MHD_OPTION_EXTERNAL_LOGGER, mhd_logger, NULL, /* first, MHD insists */
        MHD_OPTION_CONNECTION_LIMIT, (unsigned)cfg->connection_limit,
        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)cfg->connection_timeout,
        MHD_OPTION_NOTIFY_COMPLETED, on_completed, srv,
        MHD_OPTION_NOTIFY_CONNECTION, on_connection, th,
        MHD_OPTION_UNESCAPE_CALLBACK, unescape, NULL,
        MHD_OPTION_URI_LOG_CALLBACK, on_uri, srv,
        MHD_OPTION_CONNECTION_MEMORY_LIMIT, pool_bytes(cfg),
        MHD_OPTION_END);
}

/* Same shape as acceptor_start in acceptor.c: deliberately separate, each
 * allocates its own per-daemon arrays and reports in its own module. */
int http_start(struct server *srv)
{
    const struct settings *cfg = srv->cfg;
    static const char *names[METRICS_ROUTES];
    for (int i = 0; i < ROUTE_COUNT && i < METRICS_ROUTES - 1; i++) {
        names[i] = router_routes[i].name;
        if (!route_handlers[i]) {
            log_msg(LOG_ERROR, "http", "route '%s' has no handler", names[i]);
            return -1;
        }
        if (router_routes[i].image == ROUTER_IMAGE_UNSET) {
            log_msg(LOG_ERROR, "http", "route '%s' does not say whether it "
                    "shows an image (router.c)", names[i]);
            return -1;
        }
        /* Every route under an image's path shows that image: it must be
         * guarded, whatever its row says. */
        const char *pat = router_routes[i].pattern;
        if ((!strncmp(pat, "/v1/images/*", 12) || !strncmp(pat, "/iiif/3/*", 9)) &&
            router_routes[i].image != ROUTER_IMAGE) {
            log_msg(LOG_ERROR, "http", "route '%s' (%s) names an image but is "
                    "not marked ROUTER_IMAGE (router.c)", names[i], pat);
            return -1;
        }
    }
    metrics_init(names, ROUTE_COUNT);
    clock_gettime(CLOCK_MONOTONIC, &srv->started);

    struct gv_error err = {0};
    srv->listen_fd = open_listen_socket(cfg, &srv->port);
    if (srv->listen_fd < 0)
        return -1;
    int n = (int)cfg->threads;
    struct http_threads *h = calloc(1, sizeof *h);
    if (!h || !(h->daemon = calloc((size_t)n, sizeof *h->daemon)) ||
        !(h->thread = calloc((size_t)n, sizeof *h->thread))) {
        if (h)
            free(h->daemon);
        free(h);
        log_msg(LOG_ERROR, "http", "out of memory");
        close(srv->listen_fd);
        srv->listen_fd = -1;
        return -1;
    }
    h->n = n;
    h->watch = conn_watch_start((unsigned)cfg->request_timeout, &err);
    if (!h->watch) {
        log_msg(LOG_ERROR, "http", "%s", err.text);
        stop_threads(h);
        close(srv->listen_fd);
        srv->listen_fd = -1;
        return -1;
    }
    srv->http = h; /* the handlers' http_suspend finds the watchdog */
    for (int i = 0; i < n; i++) {
        h->thread[i].all = h;
        h->thread[i].index = i;
        if (!(h->daemon[i] = start_daemon(srv, &h->thread[i]))) {
            log_msg(LOG_ERROR, "http", "cannot start HTTP thread %d of %d", i + 1, n);
            srv->http = NULL;
            stop_threads(h);
            close(srv->listen_fd);
            srv->listen_fd = -1;
            return -1;
        }
    }
    h->acceptor = acceptor_start(srv->listen_fd, h->daemon, n,
                                 (unsigned)cfg->connection_limit, h->watch,
                                 &err);
    if (!h->acceptor) {
        log_msg(LOG_ERROR, "http", "%s", err.text);
        srv->http = NULL;
        stop_threads(h);
        close(srv->listen_fd);
        srv->listen_fd = -1;
        return -1;
    }
    srv->http = h;
    return 0;
}

void http_drain_and_stop(struct server *srv, unsigned timeout_s)
{
    if (!srv->http)
        return;
    acceptor_stop(srv->http->acceptor);
    /* New clients are refused from here on, not left in the backlog. */
    if (srv->listen_fd >= 0)
        close(srv->listen_fd);
    srv->listen_fd = -1;
    struct timespec t0, now;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int waited = 0;
    while (atomic_load(&metrics.in_flight) > 0) {
        clock_gettime(CLOCK_MONOTONIC, &now);
        /* Whole nanoseconds: seconds alone cut a drain begun at x.99 s
         * after 10 ms. */
        double spent = (double)(now.tv_sec - t0.tv_sec) +
                       (double)(now.tv_nsec - t0.tv_nsec) * 1e-9;
        if (spent >= (double)timeout_s) {
            log_msg(LOG_WARN, "http", "drain timeout: %d requests cut short",
                    atomic_load(&metrics.in_flight));
            break;
        }
        if (!waited++)
            log_msg(LOG_INFO, "http", "waiting for %d requests in flight",
                    atomic_load(&metrics.in_flight));
        struct timespec ts = {0, 20 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    stop_threads(srv->http);
    srv->http = NULL;
}
