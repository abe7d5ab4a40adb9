/*
 * route_health.c - GET /healthz (liveness and a summary, JSON) and
 * GET /metrics (Prometheus text exposition format 0.0.4).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h" /* autoconf: PACKAGE_VERSION, GV_HAVE_GPU */

#include "filter_jobs.h"
#include "gpu/gpu.h"
#include "metrics.h"
#include "routes.h"

/* The start-up GPU context: {"available": true, "platform", "api",
 * "vendor", "renderer", "version"} or {"available": false, "reason"}, and
 * in a build configured --without-gpu {"available": false, "built": false,
 * "reason"}. */
static json_t *gpu_json(const struct server *srv)
{
#ifndef GV_HAVE_GPU
    return json_pack("{s:b,s:b,s:s}", "available", 0, "built", 0, "reason",
                     srv->gpu_reason);
#else
    if (!srv->gpu)
        return json_pack("{s:b,s:s}", "available", 0, "reason", srv->gpu_reason);
    const struct gv_gpu_info *in = gv_gpu_info(srv->gpu);
    return json_pack("{s:b,s:s,s:s,s:s,s:s,s:s}", "available", 1,
                     "platform", in->platform, "api", in->api,
                     "vendor", in->vendor, "renderer", in->renderer,
                     "version", in->version);
#endif
}

enum MHD_Result route_healthz(struct req *r)
{
    json_t *j = json_pack("{s:s,s:s,s:i,s:f,s:o,s:i,s:i}", "status", "ok",
                          "version", PACKAGE_VERSION,
                          "stores", catalog_count(r->srv->catalog),
                          "uptime_s", http_uptime(r->srv),
                          "gpu", gpu_json(r->srv),
                          "open_connections", atomic_load(&metrics.open_connections),
                          "in_flight", atomic_load(&metrics.in_flight));
    return http_send_json(r, 200, j);
}

/* A growing text buffer. */
struct text {
    char *s;
    size_t len, cap;
    int failed;
};

static void put(struct text *t, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
static void put(struct text *t, const char *fmt, ...)
{
    for (;;) {
        if (t->failed)
            return;
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(t->s + t->len, t->cap - t->len, fmt, ap);
        va_end(ap);
        if (n < 0) {
            t->failed = 1;
            return;
        }
        if ((size_t)n < t->cap - t->len) {
            t->len += (size_t)n;
            return;
        }
        size_t cap = 2 * t->cap + (size_t)n;
        char *s = realloc(t->s, cap);
        if (!s) {
            t->failed = 1;
            return;
        }
        t->s = s;
        t->cap = cap;
    }
}

enum MHD_Result route_metrics(struct req *r)
{
    struct text t = {malloc(16384), 0, 16384, 0};
    if (!t.s)
        return http_send_errorf(r, GV_ENOMEM, "metrics: out of memory");
    put(&t, "# HELP gigaview_http_requests_total HTTP requests by route and status.\n"
            "# TYPE gigaview_http_requests_total counter\n");
    for (int i = 0; i < metrics.nroutes; i++) {
        struct metrics_route *m = &metrics.route[i];
        if (!m->name)
            continue;
        int dup = 0;
        for (int k = 0; k < i; k++)
            dup |= metrics.route[k].name && !strcmp(metrics.route[k].name, m->name);
        if (dup)
            continue;
        for (int s = 0; s <= METRICS_STATUSES; s++) {
            uint64_t v = atomic_load(&m->by_status[s]);
            if (!v)
                continue;
            if (s < METRICS_STATUSES)
                put(&t, "gigaview_http_requests_total{route=\"%s\",status=\"%u\"} %llu\n",
                    m->name, metrics_status_codes[s], (unsigned long long)v);
            else
                put(&t, "gigaview_http_requests_total{route=\"%s\",status=\"other\"} %llu\n",
                    m->name, (unsigned long long)v);
        }
    }
    put(&t, "# HELP gigaview_http_request_duration_seconds Time from request "
            "headers to the end of the response.\n"
            "# TYPE gigaview_http_request_duration_seconds histogram\n");
    for (int i = 0; i < metrics.nroutes; i++) {
        struct metrics_route *m = &metrics.route[i];
        int dup = 0;
        for (int k = 0; k < i; k++)
            dup |= metrics.route[k].name && m->name &&
                   !strcmp(metrics.route[k].name, m->name);
        if (!m->name || dup)
            continue;
        uint64_t cum = 0;
        for (int b = 0; b < METRICS_BUCKETS; b++) {
            cum += atomic_load(&m->bucket[b]);
            put(&t, "gigaview_http_request_duration_seconds_bucket{route=\"%s\","
                    "le=\"%g\"} %llu\n", m->name, metrics_bucket_le[b],
                (unsigned long long)cum);
        }
        uint64_t count = atomic_load(&m->count);
        put(&t, "gigaview_http_request_duration_seconds_bucket{route=\"%s\","
                "le=\"+Inf\"} %llu\n", m->name, (unsigned long long)count);
        put(&t, "gigaview_http_request_duration_seconds_sum{route=\"%s\"} %.6f\n",
            m->name, (double)atomic_load(&m->usec_sum) / 1e6);
        put(&t, "gigaview_http_request_duration_seconds_count{route=\"%s\"} %llu\n",
            m->name, (unsigned long long)count);
    }
    struct page_cache_stats st;
    page_cache_stats(r->srv->pages, &st);
    put(&t,
        "# HELP gigaview_page_cache_hits_total Page cache hits.\n"
        "# TYPE gigaview_page_cache_hits_total counter\n"
        "gigaview_page_cache_hits_total %llu\n"
        "# HELP gigaview_page_cache_misses_total Page cache misses (pages read).\n"
        "# TYPE gigaview_page_cache_misses_total counter\n"
        "gigaview_page_cache_misses_total %llu\n"
        "# HELP gigaview_page_cache_evictions_total Pages evicted.\n"
        "# TYPE gigaview_page_cache_evictions_total counter\n"
        "gigaview_page_cache_evictions_total %llu\n"
        "# HELP gigaview_page_cache_bytes Bytes of pages cached.\n"
        "# TYPE gigaview_page_cache_bytes gauge\n"
        "gigaview_page_cache_bytes %llu\n"
        "# HELP gigaview_page_cache_limit_bytes The cache bound (cache_bytes).\n"
        "# TYPE gigaview_page_cache_limit_bytes gauge\n"
        "gigaview_page_cache_limit_bytes %llu\n"
        "# HELP gigaview_page_cache_pages Pages cached.\n"
        "# TYPE gigaview_page_cache_pages gauge\n"
        "gigaview_page_cache_pages %llu\n"
        "# HELP gigaview_page_errors_total Pages that failed their CRC or could not be read.\n"
        "# TYPE gigaview_page_errors_total counter\n"
        "gigaview_page_errors_total %llu\n"
        "# HELP gigaview_page_error_responses_total Tiles, batch entries, regions "
        "and IIIF images answered 500 because a page was damaged or unreadable.\n"
        "# TYPE gigaview_page_error_responses_total counter\n"
        "gigaview_page_error_responses_total %llu\n"
        "# HELP gigaview_open_connections Open HTTP connections.\n"
        "# TYPE gigaview_open_connections gauge\n"
        "gigaview_open_connections %d\n"
        "# HELP gigaview_http_requests_in_flight Requests being answered.\n"
        "# TYPE gigaview_http_requests_in_flight gauge\n"
        "gigaview_http_requests_in_flight %d\n"
        "# HELP gigaview_http_response_bytes_total Body bytes sent.\n"
        "# TYPE gigaview_http_response_bytes_total counter\n"
        "gigaview_http_response_bytes_total %llu\n"
        "# HELP gigaview_stores Stores served.\n"
        "# TYPE gigaview_stores gauge\n"
        "gigaview_stores %d\n"
        "# HELP gigaview_uptime_seconds Seconds since start.\n"
        "# TYPE gigaview_uptime_seconds gauge\n"
        "gigaview_uptime_seconds %.3f\n",
        (unsigned long long)st.hits, (unsigned long long)st.misses,
        (unsigned long long)st.evictions, (unsigned long long)st.bytes,
        (unsigned long long)st.max_bytes, (unsigned long long)st.pages,
        (unsigned long long)st.errors,
        (unsigned long long)atomic_load(&metrics.page_errors),
        atomic_load(&metrics.open_connections), atomic_load(&metrics.in_flight),
        (unsigned long long)atomic_load(&metrics.bytes_sent),
        catalog_count(r->srv->catalog), http_uptime(r->srv));
    char *fm = filter_jobs_metrics(r->srv->filters); /* filter workers */
    if (fm)
        put(&t, "%s", fm);
    else
        t.failed = 1;
    free(fm);
    if (t.failed) {
        free(t.s);
        return http_send_errorf(r, GV_ENOMEM, "metrics: out of memory");
    }
    return http_send_owned(r, 200, "text/plain; version=0.0.4; charset=utf-8",
                           t.s, t.len);
}
