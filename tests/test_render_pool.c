/*
 * test_render_pool.c - gigaviewd's render pool (server/render_pool.h): the
 * queue limit (a reservation past render_queue waiting jobs is refused,
 * and counted), FIFO order, every queued job run when the pool stops, no
 * reservation after, and the metrics (depth, running, wait histogram).
 *
 * The first job holds the only thread on a gate the test opens; the test
 * knows it runs from a flag the job sets, never from a sleep.
 */
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "metrics.h"
#include "render_pool.h"
#include "util.h"

static pthread_mutex_t gate_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t gate_cond = PTHREAD_COND_INITIALIZER;
static int gate_open;
static atomic_int started;
static char order[8];
static atomic_int norder;

struct job {
    struct render_job rj;   /* first */
    char name;
    int gated;
};

static void run(struct render_job *j)
{
    struct job *t = (struct job *)j;
    atomic_fetch_add(&started, 1);
    if (t->gated) {
        pthread_mutex_lock(&gate_lock);
        while (!gate_open)
            pthread_cond_wait(&gate_cond, &gate_lock);
        pthread_mutex_unlock(&gate_lock);
    }
    order[atomic_fetch_add(&norder, 1)] = t->name;
}

/* The value of sample `name` in the pool's metrics, or -1. */
static long long sample(struct render_pool *p, const char *name)
{
    struct prom out = {0};
    render_pool_metrics(p, &out);
    long long v = -1;
    size_t n = strlen(name);
    for (char *s = out.s; s && (s = strstr(s, name)) != NULL; s += n)
        if ((s == out.s || s[-1] == '\n') && s[n] == ' ') {
            v = atoll(s + n + 1);
            break;
        }
    free(out.s);
    return v;
}

int main(void)
{
    struct render_pool *p = render_pool_new(1, 2);
    if (!p)
        fail("render_pool_new");
    struct job a = {.rj.run = run, .name = 'A', .gated = 1};
    struct job b = {.rj.run = run, .name = 'B'};
    struct job c = {.rj.run = run, .name = 'C'};
    check(render_pool_reserve(p) == 0, "reserve A");
    render_pool_submit(p, &a.rj);
    while (atomic_load(&started) == 0)
        sched_yield();
    check(render_pool_reserve(p) == 0 && render_pool_reserve(p) == 0,
          "two places while A runs (render_queue = 2)");
    check(render_pool_reserve(p) == -1, "a third waiting job is refused");
    render_pool_submit(p, &b.rj);
    render_pool_submit(p, &c.rj);
    check(render_pool_reserve(p) == -1, "still full with B and C queued");
    check(sample(p, "gigaview_render_queue_depth") == 2 &&
          sample(p, "gigaview_render_running") == 1,
          "metrics: 2 queued, 1 running");
    check(sample(p, "gigaview_render_rejected_total") == 2,
          "metrics: 2 refusals counted");
    check(atomic_load(&started) == 1, "B and C wait behind A");

    pthread_mutex_lock(&gate_lock);
    gate_open = 1;
    pthread_cond_broadcast(&gate_cond);
    pthread_mutex_unlock(&gate_lock);
    render_pool_stop(p);
    check(atomic_load(&norder) == 3 && !memcmp(order, "ABC", 3),
          "stop ran every queued job, in order (%.3s)", order);
    check(render_pool_reserve(p) == -1, "no reservation once stopped");
    check(sample(p, "gigaview_render_queue_wait_seconds_count") == 3 &&
          sample(p, "gigaview_render_queue_wait_seconds_bucket{le=\"+Inf\"}") == 3,
          "metrics: 3 waits in the histogram");
    check(sample(p, "gigaview_render_queue_depth") == 0 &&
          sample(p, "gigaview_render_running") == 0, "metrics: idle");
    render_pool_free(p);

    /* unreserve gives the place back */
    p = render_pool_new(1, 1);
    check(render_pool_reserve(p) == 0 && render_pool_reserve(p) == -1,
          "render_queue = 1: one place");
    render_pool_unreserve(p);
    check(render_pool_reserve(p) == 0, "unreserve frees it");
    render_pool_unreserve(p);
    render_pool_free(p);
    return tap_done();
}
