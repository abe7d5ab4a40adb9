/*
 * metrics.c - lock-free request accounting and the Prometheus text writer
 * (see metrics.h).  The last route slot collects requests that matched no
 * route.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "metrics.h"

struct metrics metrics;

const double metrics_bucket_le[METRICS_BUCKETS] = {
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
    0.1, 0.25, 0.5, 1, 2.5, 5, 10};

_Static_assert(METRICS_BUCKETS <= METRICS_HIST_MAX, "bounds fit a histogram");

/* This thread's slot in the per-thread counters; -1 until its first
 * connection. */
static _Thread_local int thread_slot = -1;

void metrics_init(const char *const *names, int n)
{
    if (n > METRICS_ROUTES - 1)
        n = METRICS_ROUTES - 1;
    for (int i = 0; i < n; i++)
        metrics.route[i].name = names[i];
    metrics.route[n].name = "none";
    metrics.nroutes = n + 1;
}

void metrics_record(int route, unsigned status, uint64_t usec, uint64_t bytes)
{
    if (route < 0 || route >= metrics.nroutes - 1)
        route = metrics.nroutes - 1;
    if (route < 0)
        return;
    struct metrics_route *r = &metrics.route[route];
    int s = METRICS_STATUSES; /* "other" */
    if (status >= METRICS_STATUS_MIN && status <= METRICS_STATUS_MAX)
        s = (int)(status - METRICS_STATUS_MIN);
    atomic_fetch_add(&r->by_status[s], 1);
    metrics_hist_add(&r->duration, metrics_bucket_le, METRICS_BUCKETS,
                     (double)usec / 1e6);
    atomic_fetch_add(&metrics.bytes_sent, bytes);
}

void metrics_hist_add(struct metrics_hist *h, const double *le, int n,
                      double sec)
{
    for (int i = 0; i < n; i++)
        if (sec <= le[i]) {
            atomic_fetch_add(&h->bucket[i], 1);
            break;
        }
    atomic_fetch_add(&h->count, 1);
    atomic_fetch_add(&h->nsec_sum, (uint_fast64_t)(sec > 0 ? sec * 1e9 + 0.5 : 0));
}

void metrics_hist_write(struct prom *p, const char *name, const char *label,
                        const char *value, const double *le, int n,
                        const struct metrics_hist *h)
{
    /* "{label="value",", or "{" alone; closed after le or left out. */
    char lab[200];
    if (label)
        snprintf(lab, sizeof lab, "%s=\"%s\"", label, value);
    else
        lab[0] = '\0';
    const char *sep = label ? "," : "";
    uint64_t cum = 0;
    for (int b = 0; b < n; b++) {
        cum += atomic_load(&h->bucket[b]);
        prom_printf(p, "%s_bucket{%s%sle=\"%g\"} %llu\n", name, lab, sep,
                    le[b], (unsigned long long)cum);
    }
    uint64_t count = atomic_load(&h->count);
    prom_printf(p, "%s_bucket{%s%sle=\"+Inf\"} %llu\n", name, lab, sep,
                (unsigned long long)count);
    double sum = (double)atomic_load(&h->nsec_sum) / 1e9;
    if (label) {
        prom_printf(p, "%s_sum{%s} %.6f\n", name, lab, sum);
        prom_printf(p, "%s_count{%s} %llu\n", name, lab,
                    (unsigned long long)count);
    } else {
        prom_printf(p, "%s_sum %.6f\n%s_count %llu\n", name, sum, name,
                    (unsigned long long)count);
    }
}

void metrics_connection(int opened)
{
    if (thread_slot < 0) {
        int n = atomic_fetch_add(&metrics.nthreads, 1);
        thread_slot = n < METRICS_THREADS ? n : METRICS_THREADS - 1;
    }
    if (opened) {
        atomic_fetch_add(&metrics.open_connections, 1);
        atomic_fetch_add(&metrics.thread_open[thread_slot], 1);
        atomic_fetch_add(&metrics.thread_connections[thread_slot], 1);
    } else {
        atomic_fetch_sub(&metrics.open_connections, 1);
        atomic_fetch_sub(&metrics.thread_open[thread_slot], 1);
    }
}

/* ------------------------------------------------------- Prometheus text */

static void prom_vprintf(struct prom *p, const char *fmt, va_list ap)
{
    while (!p->failed) {
        size_t room = p->cap - p->len;
        va_list aq;
        va_copy(aq, ap);
        int n = vsnprintf(room ? p->s + p->len : NULL, room, fmt, aq);
        va_end(aq);
        if (n < 0) {
            p->failed = 1;
            return;
        }
        if ((size_t)n < room) {
            p->len += (size_t)n;
            return;
        }
        /* the whole text is some 10 KiB: start there, then double */
        size_t cap = p->cap ? 2 * p->cap + (size_t)n : 16384 + (size_t)n;
        char *s = realloc(p->s, cap);
        if (!s) {
            p->failed = 1;
            return;
        }
        p->s = s;
        p->cap = cap;
    }
}

void prom_printf(struct prom *p, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    prom_vprintf(p, fmt, ap);
    va_end(ap);
}

void prom_family(struct prom *p, const char *name, const char *type,
                 const char *help)
{
    prom_printf(p, "# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

void prom_metric(struct prom *p, const char *name, const char *type,
                 const char *help, const char *fmt, ...)
{
    prom_family(p, name, type, help);
    prom_printf(p, "%s ", name);
    va_list ap;
    va_start(ap, fmt);
    prom_vprintf(p, fmt, ap);
    va_end(ap);
    prom_printf(p, "\n");
}

/* 1 if route i has a name that no earlier route has. */
static int first_of_name(int i)
{
    const char *name = metrics.route[i].name;
    if (!name)
        return 0;
    for (int k = 0; k < i; k++)
        if (metrics.route[k].name && !strcmp(metrics.route[k].name, name))
            return 0;
    return 1;
}

static void write_requests(struct prom *p, const struct metrics_route *m)
{
    for (int s = 0; s <= METRICS_STATUSES; s++) {
        uint64_t v = atomic_load(&m->by_status[s]);
        if (!v)
            continue;
        if (s < METRICS_STATUSES)
            prom_printf(p, "gigaview_http_requests_total{route=\"%s\",status=\"%d\"} "
                        "%llu\n", m->name, METRICS_STATUS_MIN + s,
                        (unsigned long long)v);
        else
            prom_printf(p, "gigaview_http_requests_total{route=\"%s\",status=\"other\"} "
                        "%llu\n", m->name, (unsigned long long)v);
    }
}

static void write_durations(struct prom *p, const struct metrics_route *m)
{
    metrics_hist_write(p, "gigaview_http_request_duration_seconds", "route",
                       m->name, metrics_bucket_le, METRICS_BUCKETS,
                       &m->duration);
}

/* Connections by thread: how evenly the thread pool shares them. */
static void write_threads(struct prom *p)
{
    int n = atomic_load(&metrics.nthreads);
    if (n > METRICS_THREADS)
        n = METRICS_THREADS;
    prom_family(p, "gigaview_http_thread_connections_total", "counter",
                "Connections started, by the libmicrohttpd thread serving "
                "them (numbered as they first had one).");
    for (int t = 0; t < n; t++)
        prom_printf(p, "gigaview_http_thread_connections_total{thread=\"%d\"} "
                    "%llu\n", t, (unsigned long long)atomic_load(
                        &metrics.thread_connections[t]));
    prom_family(p, "gigaview_http_thread_open_connections", "gauge",
                "Open connections, by the libmicrohttpd thread serving them.");
    for (int t = 0; t < n; t++)
        prom_printf(p, "gigaview_http_thread_open_connections{thread=\"%d\"} %d\n",
                    t, atomic_load(&metrics.thread_open[t]));
}

void metrics_write(struct prom *p)
{
    prom_family(p, "gigaview_http_requests_total", "counter",
                "HTTP requests by route and status.");
    for (int i = 0; i < metrics.nroutes; i++)
        if (first_of_name(i))
            write_requests(p, &metrics.route[i]);
    prom_family(p, "gigaview_http_request_duration_seconds", "histogram",
                "Time from request headers to the end of the response.");
    for (int i = 0; i < metrics.nroutes; i++)
        if (first_of_name(i))
            write_durations(p, &metrics.route[i]);
    write_threads(p);
}
