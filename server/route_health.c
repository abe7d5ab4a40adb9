/*
 * route_health.c - GET /healthz (liveness and a summary, JSON) and
 * GET /metrics (Prometheus text exposition format 0.0.4).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h" /* autoconf: PACKAGE_VERSION, GV_HAVE_GPU */

#include "filter_jobs.h"
#include "gpu/gpu.h"
#include "metrics.h"
#include "output_cache.h"
#include "render_pool.h"
#include "render_stages.h"
#include "render/tile_cache.h"
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

/* The page cache's counters and the server's gauges. */
static void write_server(struct prom *p, struct server *srv)
{
    struct page_cache_stats st;
    page_cache_stats(srv->pages, &st);
    prom_metric(p, "gigaview_page_cache_hits_total", "counter",
                "Page cache hits.", "%llu", (unsigned long long)st.hits);
    prom_metric(p, "gigaview_page_cache_misses_total", "counter",
                "Page cache misses (pages read).", "%llu",
                (unsigned long long)st.misses);
    prom_metric(p, "gigaview_page_cache_evictions_total", "counter",
                "Pages evicted.", "%llu", (unsigned long long)st.evictions);
    prom_metric(p, "gigaview_page_cache_bytes", "gauge",
                "Bytes of pages cached.", "%llu", (unsigned long long)st.bytes);
    prom_metric(p, "gigaview_page_cache_limit_bytes", "gauge",
                "The cache bound (cache_bytes).", "%llu",
                (unsigned long long)st.max_bytes);
    prom_metric(p, "gigaview_page_cache_pages", "gauge", "Pages cached.", "%llu",
                (unsigned long long)st.pages);
    prom_metric(p, "gigaview_page_errors_total", "counter",
                "Pages that failed their CRC or could not be read.", "%llu",
                (unsigned long long)st.errors);
    prom_metric(p, "gigaview_page_error_responses_total", "counter",
                "Tiles, batch entries, regions and IIIF images answered 500 "
                "because a page was damaged or unreadable.", "%llu",
                (unsigned long long)atomic_load(&metrics.page_errors));
    prom_metric(p, "gigaview_open_connections", "gauge", "Open HTTP connections.",
                "%d", atomic_load(&metrics.open_connections));
    prom_metric(p, "gigaview_http_requests_in_flight", "gauge",
                "Requests being answered.", "%d", atomic_load(&metrics.in_flight));
    prom_metric(p, "gigaview_http_response_bytes_total", "counter",
                "Body bytes sent.", "%llu",
                (unsigned long long)atomic_load(&metrics.bytes_sent));
    prom_metric(p, "gigaview_stores", "gauge", "Stores served.", "%d",
                catalog_count(srv->catalog));
    prom_metric(p, "gigaview_uptime_seconds", "gauge", "Seconds since start.",
                "%.3f", http_uptime(srv));
}

/* The decoded-tile cache, the render pool and the output cache. */
static void write_rendering(struct prom *p, struct server *srv)
{
    struct gv_tile_cache_stats st;
    gv_tile_cache_stats(srv->tiles, &st);
    prom_metric(p, "gigaview_tile_cache_hits_total", "counter",
                "Decoded tiles found in the shared tile cache.", "%llu",
                (unsigned long long)st.hits);
    prom_metric(p, "gigaview_tile_cache_misses_total", "counter",
                "Tiles decoded into the shared tile cache (one decode each).",
                "%llu", (unsigned long long)st.misses);
    prom_metric(p, "gigaview_tile_cache_waits_total", "counter",
                "Requests for a tile that waited for another thread's decode "
                "of it.", "%llu", (unsigned long long)st.waits);
    prom_metric(p, "gigaview_tile_cache_evictions_total", "counter",
                "Decoded tiles evicted.", "%llu",
                (unsigned long long)st.evictions);
    prom_metric(p, "gigaview_tile_cache_lent_total", "counter",
                "Level-0 tiles decoded outside the cache, for a request "
                "that covered them whole.", "%llu",
                (unsigned long long)st.lent);
    prom_metric(p, "gigaview_tile_cache_bytes", "gauge",
                "Bytes of decoded tiles held.", "%llu",
                (unsigned long long)st.bytes);
    prom_metric(p, "gigaview_tile_cache_mapped_bytes", "gauge",
                "Bytes of memory mapped for decoded tiles: those held, "
                "slots free for the next decodes and one empty chunk.",
                "%llu", (unsigned long long)st.mapped);
    prom_metric(p, "gigaview_tile_cache_limit_bytes", "gauge",
                "The tile cache bound (decoder_cache_bytes).", "%llu",
                (unsigned long long)st.limit);
    render_pool_metrics(srv->render, p);
    render_stages_write(p);
    output_cache_metrics(srv->outputs, p);
}

enum MHD_Result route_metrics(struct req *r)
{
    struct prom p = {0};
    metrics_write(&p);
    write_server(&p, r->srv);
    filter_jobs_metrics(r->srv->filters, &p);
    write_rendering(&p, r->srv);
    if (p.failed) {
        free(p.s);
        return http_send_errorf(r, GV_ENOMEM, "metrics: out of memory");
    }
    return http_send_owned(r, 200, "text/plain; version=0.0.4; charset=utf-8",
                           p.s, p.len);
}
