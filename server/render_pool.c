/*
 * render_pool.c - a fixed set of threads over one FIFO of render jobs
 * (see render_pool.h).  One mutex guards the queue and the counters; the
 * wait histogram uses the request histogram's bounds (metrics.h).
 */
#include <pthread.h>
#include <stdlib.h>

#include "job_queue.h"
#include "metrics.h"
#include "render_pool.h"

struct render_pool {
    pthread_mutex_t lock;
    pthread_cond_t work;
    struct job_queue queue;
    int max_queue;
    int reserved;          /* places held: reserved or queued, not running */
    int running;
    int stopping;
    int nthreads;
    pthread_t *threads;
    uint64_t rejected;
    struct metrics_hist wait;  /* seconds each job waited in the queue */
};

static double since(const struct timespec *t0)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)(t.tv_sec - t0->tv_sec) + (double)(t.tv_nsec - t0->tv_nsec) / 1e9;
}

/* The next job, or NULL once stopping with an empty queue. */
static struct render_job *take(struct render_pool *p)
{
    pthread_mutex_lock(&p->lock);
    while (!p->queue.head && !p->stopping)
        pthread_cond_wait(&p->work, &p->lock);
    struct job_link *l = job_queue_pop(&p->queue);
    struct render_job *j = l ? job_queue_entry(l, struct render_job, link) : NULL;
    if (j) {
        p->reserved--;
        p->running++;
        metrics_hist_add(&p->wait, metrics_bucket_le, METRICS_BUCKETS,
                         since(&j->queued));
    }
    pthread_mutex_unlock(&p->lock);
    return j;
}

static void *worker(void *arg)
{
    struct render_pool *p = arg;
    struct render_job *j;
    while ((j = take(p)) != NULL) {
        j->run(j);
        pthread_mutex_lock(&p->lock);
        p->running--;
        pthread_mutex_unlock(&p->lock);
    }
    return NULL;
}

struct render_pool *render_pool_new(int threads, int max_queue)
{
    struct render_pool *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->threads = calloc((size_t)threads, sizeof *p->threads);
    if (!p->threads) {
        free(p);
        return NULL;
    }
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->work, NULL);
    p->max_queue = max_queue;
    for (int i = 0; i < threads; i++) {
        if (pthread_create(&p->threads[i], NULL, worker, p) != 0)
            break;
        p->nthreads++;
    }
    if (p->nthreads == 0) {
        render_pool_free(p);
        return NULL;
    }
    return p;
}

int render_pool_reserve(struct render_pool *p)
{
    pthread_mutex_lock(&p->lock);
    int ok = !p->stopping && p->reserved < p->max_queue;
    if (ok)
        p->reserved++;
    else
        p->rejected++;
    pthread_mutex_unlock(&p->lock);
    return ok ? 0 : -1;
}

void render_pool_unreserve(struct render_pool *p)
{
    pthread_mutex_lock(&p->lock);
    p->reserved--;
    pthread_mutex_unlock(&p->lock);
}

void render_pool_submit(struct render_pool *p, struct render_job *j)
{
    clock_gettime(CLOCK_MONOTONIC, &j->queued);
    pthread_mutex_lock(&p->lock);
    job_queue_push(&p->queue, &j->link);
    pthread_cond_signal(&p->work);
    pthread_mutex_unlock(&p->lock);
}

void render_pool_stop(struct render_pool *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->stopping = 1;
    pthread_cond_broadcast(&p->work);
    pthread_mutex_unlock(&p->lock);
    for (int i = 0; i < p->nthreads; i++)
        pthread_join(p->threads[i], NULL);
    p->nthreads = 0;
}

void render_pool_free(struct render_pool *p)
{
    if (!p)
        return;
    render_pool_stop(p);
    pthread_mutex_destroy(&p->lock);
    pthread_cond_destroy(&p->work);
    free(p->threads);
    free(p);
}

void render_pool_metrics(struct render_pool *p, struct prom *out)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    int queued = p->queue.count, running = p->running;
    uint64_t rejected = p->rejected;
    pthread_mutex_unlock(&p->lock);
    prom_metric(out, "gigaview_render_queue_depth", "gauge",
                "IIIF and region renders waiting for a render thread.", "%d",
                queued);
    prom_metric(out, "gigaview_render_running", "gauge",
                "IIIF and region renders running.", "%d", running);
    prom_metric(out, "gigaview_render_rejected_total", "counter",
                "Renders refused with 503 because render_queue were waiting.",
                "%llu", (unsigned long long)rejected);
    const char *name = "gigaview_render_queue_wait_seconds";
    prom_family(out, name, "histogram",
                "Time a render waited in the queue before a thread took it.");
    metrics_hist_write(out, name, NULL, NULL, metrics_bucket_le,
                       METRICS_BUCKETS, &p->wait);
}
