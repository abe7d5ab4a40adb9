/*
 * http.h - the HTTP layer of gigaviewd over libmicrohttpd.
 *
 * http.c owns the daemons (one libmicrohttpd daemon over epoll per
 * thread, fed by acceptor.c's one accepting thread, which keeps the
 * connection limit; the idle timeout), the access handler that matches a request against the route
 * table (routes.c) and the per-request state (struct req, kept in
 * libmicrohttpd's *req_cls and freed in the completion callback, which
 * also writes the access line and the metrics).  It also owns the one
 * table that maps a gv_code to an HTTP status and a JSON error body:
 *
 *     {"error": {"status": 404, "code": "not_found", "message": "..."}}
 *
 * Every error answer comes from that table: handlers report a gv_code
 * (http_send_error*), never a status of their own.  Handlers (route_*.c)
 * build a response with the http_send* helpers, or make one with
 * http_response_* and add headers, then http_send: that adds the CORS
 * header, records the status and queues the response.
 * Every handler runs on a pool thread; struct server is read-only there
 * except for its thread-safe members (catalog, page cache, metrics,
 * filters).  A handler may suspend its connection (MHD_suspend_connection)
 * and keep its state in req.async; it is called again once resumed.
 */
#ifndef GV_SERVER_HTTP_H
#define GV_SERVER_HTTP_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include <jansson.h>
#include <microhttpd.h>

#include "access.h"
#include "catalog.h"
#include "settings.h"
#include "base/error.h"
#include "page_cache.h"

struct gv_gpu;
struct gv_tile_cache;
struct output_cache;
struct render_pool;
struct filter_jobs;
struct filter_store;
struct http_threads;

struct server {
    const struct settings *cfg;
    struct catalog *catalog;
    struct page_cache *pages;
    struct http_threads *http; /* http.c: the daemons and the acceptor */
    int listen_fd;            /* closed after the daemons stop */
    uint16_t port;
    struct timespec started;  /* CLOCK_MONOTONIC */
    /* The EGL context opened at start-up (gpu = auto), closed after the
     * drain; NULL when disabled, when no context could be made or in a
     * build configured --without-gpu, and then gpu_reason says why.  Set
     * before http_start, read-only after.  No route draws with it: /healthz
     * reports it, and filter graphs run in worker processes with contexts
     * of their own, started only when this one opened. */
    struct gv_gpu *gpu;
    char gpu_reason[sizeof ((struct gv_error *)0)->text];
    /* Filter graphs (route_filters.c): the pool of sandboxed worker
     * processes, NULL when filters cannot run (then filter_reason says
     * why: gpu = off, no EGL, no worker program), and the stock and stored
     * graphs.  Set before http_start; both are thread-safe. */
    struct filter_jobs *filters;
    struct filter_store *filter_store;
    char filter_reason[sizeof ((struct gv_error *)0)->text + 64];
    enum gv_code filter_code; /* the error then: GV_EUNAVAIL (503), or
                                 GV_EFORMAT (501) in a build configured
                                 --without-gpu */
    /* IIIF images and regions: the decoded-tile cache every decoder
     * shares, the threads that render, and the encoded outputs kept by
     * canonical request.  Set before http_start; all thread-safe. */
    struct gv_tile_cache *tiles;
    struct render_pool *render;
    struct output_cache *outputs;
    /* Access control (access.h): the policy, the token secret; NULL
     * only in tests that build a server by hand (everything public).
     * Thread-safe. */
    struct access *access;
    /* Requests per client (rate_limit.h); NULL: no limit.  Thread-safe. */
    struct rate_limit *rate;
};

#define HTTP_MAX_PARAMS 8

struct conn_entry;

struct req {
    struct server *srv;
    struct MHD_Connection *conn;
    struct conn_entry *watch; /* its connection in the watchdog (conn_watch.h) */
    const char *method;       /* as received; HEAD is routed as GET */
    char *raw;                /* the request target as sent, owned */
    char *raw_path;           /* its path, not decoded (routing), owned */
    char *path;               /* decoded path, owned */
    char *query;              /* "k=v&..." as decoded, for the access log; owned, NULL for none */
    int head;                 /* HEAD request: headers only */
    int route;                /* enum route_id (router.h), -1 none */
    int iiif;                 /* IIIF route: IIIF statuses, CORS "*" */
    const char *param[HTTP_MAX_PARAMS]; /* the route's '*' segments */
    int nparam;
    char *segbuf;             /* storage of param[] */
    char *body;               /* POST body, NUL-terminated */
    size_t body_len;
    int body_over;            /* body exceeded the cap (discarded) */
    int started;              /* the head was seen by the handler */
    int arrived;              /* the whole request was received */
    int responded;
    int suspended;            /* between http_suspend and the next call */
    atomic_int gone;          /* the client hung up while suspended */
    /* A handler's state while its connection is suspended (filter jobs:
     * route_filters.c; renders: render_call.c); the handler runs again
     * when it is resumed, and frees this before answering. */
    void *async;
    /* Frees async if the request ends without its handler running again
     * (the client closed the connection while it was suspended); NULL:
     * nothing to free. */
    void (*async_free)(void *async);
    unsigned status;
    uint64_t bytes;
    struct timespec t0;
    char remote[64];
    /* Access control: the policy snapshot the request judges by (held on
     * first use, released with the request) and the caller's token, read
     * once (http_caller). */
    const struct access_policy *policy;
    int policy_held;
    int caller_read;          /* caller_state is set */
    int caller_state;         /* 0 no token, 1 valid (caller), -1 refused */
    struct access_claims caller;
    /* The answer depends on who asks (a protected image shown to its
     * group, a list with protected images): http_send makes it
     * "Cache-Control: private" and adds "Vary: Authorization, Cookie". */
    int private_answer;
    /* param[0] is an image hidden from the caller: http_image finds none. */
    int hidden;
};

/*
 * Suspend r's connection while a job runs on another thread, keeping
 * `async` (freed by async_free, which may be NULL, if the request ends
 * without its handler running again).  The job resumes the connection
 * with MHD_resume_connection when done; the handler is then called again
 * and finds r->async.  Meanwhile the client's hang-up is watched: the
 * flag returned turns 1 when it hangs up, so the job may skip its work;
 * the request then ends as 499 without its handler running again.  The
 * flag stays valid until the job has resumed the connection.
 */
const atomic_int *http_suspend(struct req *r, void *async,
                               void (*async_free)(void *async));

/* Start serving on cfg's address and port.  Returns 0 (srv->port holds
 * the bound port) or -1 (logged). */
int http_start(struct server *srv);

/* Stop accepting, wait up to timeout_s for requests in flight, stop. */
void http_drain_and_stop(struct server *srv, unsigned timeout_s);

/* ---- helpers for handlers ---- */

/* Queue resp with `status` (adds CORS and common headers, records status
 * and body size, destroys resp).  resp NULL: logged, the request fails
 * (status 500 in the access log) and MHD_NO is returned. */
enum MHD_Result http_send(struct req *r, unsigned status,
                          struct MHD_Response *resp, size_t body_len);

/*
 * Responses to add headers to before http_send: `len` bytes of body with
 * Content-Type `type` (NULL: none).  http_response_copy copies body;
 * http_response_owned takes a malloc'ed body, which the response frees
 * (or which is freed here on failure).  NULL on allocation failure.
 */
struct MHD_Response *http_response_copy(const void *body, size_t len,
                                        const char *type);
struct MHD_Response *http_response_owned(void *body, size_t len,
                                         const char *type);

/* The one JSON serializer: json (stolen: decref'ed here, may be NULL)
 * dumped with jansson's `flags` and a final newline, as a response with
 * Content-Type `type`; *len is the body's length.  NULL if json is NULL or
 * on allocation failure. */
struct MHD_Response *http_response_json(json_t *json, size_t flags,
                                        const char *type, size_t *len);

/* Add header `name` with the decimal value v. */
void http_header_int(struct MHD_Response *resp, const char *name, long long v);

/* Add ETag: etag, then Cache-Control: public, max-age=3600 (an answer
 * that may change when the store is replaced: an hour, revalidated by its
 * ETag).  A NULL resp (a failed response) does nothing. */
void http_header_etag_hour(struct MHD_Response *resp, const char *etag);

/* A malloc'ed body that the response frees. */
enum MHD_Result http_send_owned(struct req *r, unsigned status,
                                const char *type, void *body, size_t len);

/* json (stolen), compact, as application/json; http_send_json_header
 * adds one header (name NULL: none). */
enum MHD_Result http_send_json(struct req *r, unsigned status, json_t *json);
enum MHD_Result http_send_json_header(struct req *r, unsigned status,
                                      json_t *json, const char *name,
                                      const char *value);

/* The JSON error for err->code, through the one error table (an unknown
 * code is 500 "internal"), with Cache-Control: no-store.  The message is
 * err->text ("internal error" when empty). */
enum MHD_Result http_send_error(struct req *r, const struct gv_error *err);

/* Same from a code and a message of any length, with one more header
 * (Retry-After, WWW-Authenticate; name NULL: none). */
enum MHD_Result http_send_fail(struct req *r, enum gv_code code,
                               const char *message, const char *name,
                               const char *value);

/* Same, built from a code and a message. */
enum MHD_Result http_send_errorf(struct req *r, enum gv_code code,
                                 const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* The status the error table gives `code` on r's route, for a failure
 * reported inside a response rather than as one (a batch's tile). */
unsigned http_error_status(const struct req *r, enum gv_code code);

/* A header response with no body (304, 303 with Location). */
enum MHD_Result http_send_empty(struct req *r, unsigned status,
                                const char *header, const char *value);

/* Request header / query argument, or NULL. */
const char *http_header(struct req *r, const char *name);
const char *http_query(struct req *r, const char *name);

/*
 * 1 if an If-None-Match value (NULL: the header is absent) matches etag
 * (a strong ETag with its quotes), else 0: the value is "*", or one of
 * its comma-separated entity tags, with or without the weak "W/" prefix,
 * has etag's opaque tag (RFC 9110 section 13.1.2: the weak comparison).
 * A malformed entry matches nothing and the entries after it are still
 * read.  The one matcher of every route.  Pure; any thread.
 */
int http_etag_listed(const char *if_none_match, const char *etag);

/* Strict unsigned parse: digits only, value <= max.  0 or -1. */
int http_parse_u32(const char *s, uint32_t max, uint32_t *out);

/* "http://host:port" (or cfg public_url) for absolute links, no trailing
 * slash.  Only a well-formed Host header is trusted. */
void http_base_url(struct req *r, char *buf, size_t size);

/* Look up the image named by param[0]: a reference, or NULL after
 * queueing a 404 (*ret holds the result to return), also when the access
 * policy hides that image from the caller.  The one lookup of every
 * route that shows an image: catalog_get there would bypass the hiding. */
struct image *http_image(struct req *r, enum MHD_Result *ret);

/* After a failure that may come from img's store: a damaged or unreadable
 * page (GV_ECORRUPT, GV_EIO) is counted (gigaview_page_error_responses_total)
 * and logged as an error under `module`, "ID: WHERE MESSAGE".  Other codes
 * are not the store's: nothing happens. */
void http_page_error(const struct image *img, const char *module,
                     const char *where, const struct gv_error *err);

/* 1 if the request carries "Authorization: Bearer <auth_token>" and a
 * token is configured (compared in constant time), else 0.  For the write
 * endpoints: storing and deleting filter graphs. */
int http_authorized(struct req *r);

/* The cookie that carries an access token (route_auth.c sets it). */
#define HTTP_ACCESS_COOKIE "gigaview_access"

/* The policy r judges by (NULL: every image public), held until the
 * request ends. */
const struct access_policy *http_policy(struct req *r);

/* r's caller: the claims of a valid token ("Authorization: Bearer T",
 * else the gigaview_access cookie), or NULL; *refused (may be NULL) is
 * 1 when a token was sent and none was valid.  Read once per request. */
const struct access_claims *http_caller(struct req *r, int *refused);

/* The policy's verdict on image `id` for r's caller.  A protected image
 * shown to its group makes the answer private (req.private_answer). */
enum access_verdict http_access(struct req *r, const char *id);

/* The 404 of an absent image, "no image 'ID'" (param[0]): also the
 * answer for a hidden one, byte for byte. */
enum MHD_Result http_send_no_image(struct req *r);

/* Seconds since the server started. */
double http_uptime(const struct server *srv);

#endif
