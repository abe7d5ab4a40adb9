/*
 * metrics.h - request counters and latency histograms for /metrics.
 *
 * Counters are C11 atomics indexed by route (the route table's order) and
 * by status code, so recording a request takes no lock.  Rendering in the
 * Prometheus text format 0.0.4 is in route_health.c.
 */
#ifndef GV_SERVER_METRICS_H
#define GV_SERVER_METRICS_H

#include <stdatomic.h>
#include <stdint.h>

#define METRICS_ROUTES 32
/* Histogram bounds in seconds: 0.5 ms to 10 s covers a cached tile up to
 * a large region render. */
#define METRICS_BUCKETS 14
extern const double metrics_bucket_le[METRICS_BUCKETS];
/* Status codes counted one by one; anything else counts as "other". */
#define METRICS_STATUSES 16
extern const unsigned metrics_status_codes[METRICS_STATUSES];

struct metrics_route {
    const char *name;
    atomic_uint_fast64_t by_status[METRICS_STATUSES + 1];
    atomic_uint_fast64_t bucket[METRICS_BUCKETS]; /* non-cumulative */
    atomic_uint_fast64_t count;
    atomic_uint_fast64_t usec_sum;
};

struct metrics {
    struct metrics_route route[METRICS_ROUTES];
    int nroutes;
    atomic_int open_connections;
    atomic_int in_flight;
    atomic_uint_fast64_t page_errors;   /* answers (tiles, batch entries,
                                           regions, IIIF images) that failed
                                           on a damaged or unreadable page */
    atomic_uint_fast64_t bytes_sent;
};

extern struct metrics metrics;

/* Register route names (index = route id); call once before serving. */
void metrics_init(const char *const *names, int n);

/* Record one finished request of route `route` (-1: no route matched). */
void metrics_record(int route, unsigned status, uint64_t usec, uint64_t bytes);

#endif
