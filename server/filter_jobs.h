/*
 * filter_jobs.h - gigaviewd's pool of sandboxed filter worker processes
 * (docs/FILTERS.md section 9).
 *
 * User GLSL never runs inside gigaviewd.  The pool keeps `workers`
 * processes of gigaview-filter-worker (filters/worker_main.c), each
 * started with posix_spawn (fork and exec: a multithreaded server is
 * never forked without exec) and served by one thread of the pool that
 * owns it, its socket and its pid.  Jobs wait in one FIFO queue; a free
 * slot thread takes the next, sends it (filters/worker.h), and waits for
 * the answer up to the time limit.  Past it, or when the worker dies or
 * breaks the protocol, the thread SIGKILLs and reaps it, fails the job
 * (timeout or crash), and starts a replacement before taking another job.
 * A worker that cannot be started (no EGL, bad path) is retried with a
 * growing delay, and meanwhile jobs fail at once as unavailable.
 *
 * Admission is two-step so that a request can be refused before it
 * decodes anything: filter_jobs_reserve holds one of max_jobs places
 * (queued plus running), filter_jobs_submit queues a job under it.  The
 * job's done() callback runs once, on a pool thread, when the job has
 * finished, failed, or been cancelled by filter_jobs_stop; the HTTP side
 * uses it to resume the suspended connection, so no HTTP thread ever
 * blocks on a filter.
 *
 * The same pool runs mesh simplifications (POST /v1/meshes/simplify,
 * GV_WORKER_SIMPLIFY jobs) under their own time limit (timeout_ms).
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_FILTER_JOBS_H
#define GV_SERVER_FILTER_JOBS_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "job_queue.h"
#include "worker.h"

struct filter_jobs;
struct prom;

struct filter_jobs_config {
    const char *worker_path;   /* the gigaview-filter-worker program */
    int workers;               /* processes, >= 1 */
    int timeout_ms;            /* per job, from send to answer */
    int start_timeout_ms;      /* a new worker's hello */
    uint64_t memory_limit;     /* RLIMIT_DATA of each worker; 0 none */
    uint64_t max_pixels;       /* largest padded region a worker accepts */
    int max_jobs;              /* queued plus running */
    const char *gpu_platform;  /* the workers' --gpu-platform; NULL: auto */
};

enum filter_job_status {
    FILTER_JOB_DONE = 0,       /* res holds the worker's answer (which may
                                  be a failure it reported: res.failed) */
    FILTER_JOB_TIMEOUT,        /* past the time limit: the worker was killed */
    FILTER_JOB_CRASHED,        /* the worker died or broke the protocol */
    FILTER_JOB_UNAVAILABLE,    /* no worker could be started: err says why */
    FILTER_JOB_CANCELLED       /* the pool is stopping, or nobody waits
                                  for the answer any more (cancel) */
};

struct filter_job {
    struct gv_worker_job job;         /* in: pointers borrowed until done */
    int timeout_ms;                   /* in: this job's time limit; 0: the
                                         pool's (filter_timeout_ms) */
    const char *timeout_key;          /* in: the setting a timeout's message
                                         names; NULL: filter_timeout_ms */
    const atomic_int *cancel;         /* in: NULL, or a flag that turns 1
                                         when nobody waits for the answer
                                         any more: a job still queued then
                                         is not run (FILTER_JOB_CANCELLED) */
    void (*done)(struct filter_job *j, void *arg);
    void *arg;
    /* out, valid in done() and after */
    enum filter_job_status status;
    struct gv_worker_result res;      /* DONE: res.out is the caller's */
    struct gv_error err;              /* not DONE: what happened, as
                                         GV_ETIMEOUT, GV_ECRASH or
                                         GV_EUNAVAIL (unavailable,
                                         cancelled) */
    double worker_ms;                 /* send to answer */
    struct job_link link;             /* private */
};

/*
 * Start the pool: the slot threads start their workers right away (the
 * first jobs wait for them).  Call with the signals the daemon waits for
 * blocked, so that the threads inherit the mask.  Returns NULL with *err
 * on a resource failure; a worker that cannot start is not an error here.
 */
struct filter_jobs *filter_jobs_new(const struct filter_jobs_config *cfg,
                                    struct gv_error *err);

/*
 * Hold one admission place.  Returns 0, or -1 when max_jobs are queued or
 * running or the pool is stopping (answer 503).  Each successful call is
 * matched by one filter_jobs_submit or filter_jobs_unreserve.
 */
int filter_jobs_reserve(struct filter_jobs *p);
void filter_jobs_unreserve(struct filter_jobs *p);

/* Queue j under a reservation.  j->done(j, j->arg) will be called exactly
 * once, from another thread; j must stay valid until then. */
void filter_jobs_submit(struct filter_jobs *p, struct filter_job *j);

/*
 * Stop taking reservations, let queued and running jobs finish for up to
 * timeout_ms, then cancel what is left (done() is called for every job)
 * and stop every worker and thread.  NULL does nothing.
 */
void filter_jobs_stop(struct filter_jobs *p, unsigned timeout_ms);

/* Free a stopped pool.  NULL does nothing. */
void filter_jobs_free(struct filter_jobs *p);

/*
 * Write the pool's counters to out (docs/API.md, /metrics).  p may be
 * NULL (filters off): the counters read 0.
 */
void filter_jobs_metrics(struct filter_jobs *p, struct prom *out);

#endif
