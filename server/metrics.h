/*
 * metrics.h - request counters and latency histograms for /metrics.
 *
 * Counters are C11 atomics indexed by route (the route table's order) and
 * by status code, so recording a request takes no lock.  Every status
 * from 100 to 599 has its own counter, so whatever gigaviewd sends (the
 * error table's, 201, 303, 304, 499 for a client gone before the answer)
 * is counted under its own label; connections are also counted per
 * libmicrohttpd thread, to show how evenly the pool shares them.  The one writer
 * of the Prometheus text format 0.0.4 is here too (struct prom): these
 * counters, the page cache's and the filter pool's are all written with
 * it, and route_health.c serves the text at /metrics.
 */
#ifndef GV_SERVER_METRICS_H
#define GV_SERVER_METRICS_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define METRICS_ROUTES 32
/* Histogram bounds in seconds: 0.5 ms to 10 s covers a cached tile up to
 * a large region render. */
#define METRICS_BUCKETS 14
extern const double metrics_bucket_le[METRICS_BUCKETS];
/* Status codes METRICS_STATUS_MIN..MAX are counted one by one; anything
 * else (never sent) would count as "other". */
#define METRICS_STATUS_MIN 100
#define METRICS_STATUS_MAX 599
#define METRICS_STATUSES (METRICS_STATUS_MAX - METRICS_STATUS_MIN + 1)
/* Threads whose connections are counted one by one (the settings' largest
 * thread pool); connections of further threads count under the last. */
#define METRICS_THREADS 256

/* A histogram of seconds, lock-free: non-cumulative counts over the
 * caller's bounds (at most METRICS_HIST_MAX; a value past the last
 * counts only in +Inf), the count and the sum in nanoseconds.  The one
 * histogram of /metrics: requests by route, render stages, the render
 * queue's wait. */
#define METRICS_HIST_MAX 20
struct metrics_hist {
    atomic_uint_fast64_t bucket[METRICS_HIST_MAX];
    atomic_uint_fast64_t count;
    atomic_uint_fast64_t nsec_sum;
};

struct metrics_route {
    const char *name;
    atomic_uint_fast64_t by_status[METRICS_STATUSES + 1];
    struct metrics_hist duration;
};

struct metrics {
    struct metrics_route route[METRICS_ROUTES];
    int nroutes;
    atomic_int open_connections;
    /* By thread, numbered in the order the threads first had a
     * connection: connections started, and open now. */
    atomic_uint_fast64_t thread_connections[METRICS_THREADS];
    atomic_int thread_open[METRICS_THREADS];
    atomic_int nthreads;      /* slots numbered so far */
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

/* A connection started (opened 1) or closed (opened 0) on the calling
 * thread: the open-connection gauges, and the per-thread counters.  Call
 * it on the thread that serves the connection (libmicrohttpd's connection
 * notifications are). */
void metrics_connection(int opened);

/*
 * A Prometheus text being written: s holds len bytes (malloc'ed, the
 * caller frees it; start from {0}).  After an allocation failure failed
 * is set and every later call does nothing.  One thread.
 */
struct prom {
    char *s;
    size_t len, cap;
    int failed;
};

/* The "# HELP" and "# TYPE" lines of metric `name`; its samples follow
 * with prom_printf. */
void prom_family(struct prom *p, const char *name, const char *type,
                 const char *help);

/* Append printf-formatted text (sample lines). */
void prom_printf(struct prom *p, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* A metric with one unlabelled sample: its HELP and TYPE lines, then
 * "name VALUE", VALUE formatted by fmt. */
void prom_metric(struct prom *p, const char *name, const char *type,
                 const char *help, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

/* Count `sec` seconds in h, whose n bounds are le. */
void metrics_hist_add(struct metrics_hist *h, const double *le, int n,
                      double sec);

/* h (bounds le, n of them) as the samples of histogram family `name`
 * (its prom_family written by the caller), each with the label
 * label="value" (label NULL: no label). */
void metrics_hist_write(struct prom *p, const char *name, const char *label,
                        const char *value, const double *le, int n,
                        const struct metrics_hist *h);

/* The request counters by route and status and the latency histograms by
 * route, each route name once (routes that share a name share counters),
 * and the connections by thread. */
void metrics_write(struct prom *p);

#endif
