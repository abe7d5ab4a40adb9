/*
 * render_pool.h - the threads that render IIIF images and regions, so that
 * no libmicrohttpd thread ever blocks on a long decode.
 *
 * A request that must render holds a queue place (render_pool_reserve:
 * refused when render_queue jobs already wait, which the handler answers
 * 503 with Retry-After), suspends its connection, then submits its job.
 * One of the pool's fixed threads runs job->run(job) (which renders and
 * resumes the connection); the handler is then called again and answers.
 * Jobs run in the order they were submitted.  The time each job waited
 * in the queue goes into a histogram, written to /metrics with the queue
 * depth, the jobs running and the refusals.
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_RENDER_POOL_H
#define GV_SERVER_RENDER_POOL_H

#include <stdint.h>
#include <time.h>

#include "job_queue.h"

struct render_pool;
struct prom;

struct render_job {
    void (*run)(struct render_job *j);  /* on a pool thread, once */
    /* private */
    struct timespec queued;
    struct job_link link;
};

/* Start `threads` threads (>= 1) with at most `max_queue` jobs waiting.
 * Call with the daemon's signals blocked (the threads inherit the mask).
 * NULL on a resource failure. */
struct render_pool *render_pool_new(int threads, int max_queue);

/* Hold one queue place: 0, or -1 when max_queue jobs are waiting or the
 * pool is stopping (answer 503).  Each 0 is matched by one
 * render_pool_submit or render_pool_unreserve. */
int render_pool_reserve(struct render_pool *p);
void render_pool_unreserve(struct render_pool *p);

/* Queue j under a reservation; j->run(j) is called exactly once, on a pool
 * thread (also while the pool stops: queued jobs are run, not dropped). */
void render_pool_submit(struct render_pool *p, struct render_job *j);

/* Refuse new reservations, run every queued job, join the threads.  NULL
 * does nothing. */
void render_pool_stop(struct render_pool *p);

/* Free a stopped pool.  NULL does nothing. */
void render_pool_free(struct render_pool *p);

/* The pool's gauges, counters and wait histogram (docs/API.md, /metrics).
 * p may be NULL: nothing is written. */
void render_pool_metrics(struct render_pool *p, struct prom *out);

#endif
