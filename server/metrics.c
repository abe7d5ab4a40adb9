/*
 * metrics.c - lock-free request accounting (see metrics.h).  The last
 * route slot collects requests that matched no route.
 */
#include "metrics.h"

struct metrics metrics;

const double metrics_bucket_le[METRICS_BUCKETS] = {
    0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
    0.1, 0.25, 0.5, 1, 2.5, 5, 10};

const unsigned metrics_status_codes[METRICS_STATUSES] = {
    200, 204, 303, 304, 400, 401, 403, 404, 405, 413, 415, 500, 501, 503,
    507, 416};

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
    int s = METRICS_STATUSES;
    for (int i = 0; i < METRICS_STATUSES; i++)
        if (metrics_status_codes[i] == status)
            s = i;
    atomic_fetch_add(&r->by_status[s], 1);
    double sec = (double)usec / 1e6;
    for (int i = 0; i < METRICS_BUCKETS; i++)
        if (sec <= metrics_bucket_le[i]) {
            atomic_fetch_add(&r->bucket[i], 1);
            break;
        }
    atomic_fetch_add(&r->count, 1);
    atomic_fetch_add(&r->usec_sum, usec);
    atomic_fetch_add(&metrics.bytes_sent, bytes);
}
