/*
 * filter_jobs.c - the pool of filter worker processes (filter_jobs.h).
 *
 * One thread per slot owns that slot's worker: its pid and its end of
 * the socket pair.  The thread is the only one that starts, talks to,
 * kills and reaps its worker, so pids are never signalled after they
 * have been reaped (no pid reuse races).  The pool lock guards the queue,
 * the counts and the published pid/fd of each slot; filter_jobs_stop
 * reads the latter to shutdown() a socket, which wakes a slot thread
 * blocked on its worker without closing the descriptor under it.
 *
 * Workers are started with posix_spawn: glibc's clone(CLONE_VM |
 * CLONE_VFORK) then exec, which is safe in a threaded process and does
 * not copy the page tables of a server holding a large page cache.  The
 * child gets the socket as descriptor 3, /dev/null as stdin, the daemon's
 * stderr as stdout and stderr, no other descriptor, an empty signal mask
 * and default dispositions.
 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "filter_jobs.h"
#include "log.h"
#include "metrics.h"

extern char **environ;

/* Delay before retrying a worker that failed to start: doubled each
 * failure, so a machine with no EGL costs one spawn a minute at most. */
#define BACKOFF_MIN_MS 1000
#define BACKOFF_MAX_MS 60000
#define CHILD_FD 3

struct slot {
    struct filter_jobs *pool;
    int index;
    pthread_t thread;
    int thread_ok;
    pid_t pid;                  /* 0: no worker (published under lock) */
    int fd;                     /* -1: none (published under lock) */
    int ready;                  /* the worker said hello (under lock) */
    int started;                /* a worker has run in this slot before */
    int64_t retry_at;           /* no start attempt before this */
    int backoff_ms;
    struct gv_error start_err;  /* why the last start failed */
};

struct filter_jobs {
    struct filter_jobs_config cfg;
    char *path;
    pthread_mutex_t lock;
    pthread_cond_t wake;        /* slots: a job was queued, or stop */
    pthread_cond_t idle;        /* stop: queued + running reached 0 */
    struct job_queue queue;
    int running, reserved;
    int ready;                  /* slots whose worker said hello */
    int draining, stop;
    int nslots;
    struct slot *slot;
    atomic_uint_fast64_t n_ok, n_error, n_timeout, n_crash, n_unavailable,
        n_cancelled, n_rejected, n_starts, n_restarts, n_start_failures,
        worker_usec;
    atomic_uint_fast64_t n_kind[3];  /* jobs sent to a worker: compile, run,
                                        simplify */
};

/* The index of a job kind in n_kind. */
static int kind_index(int op)
{
    return op == GV_WORKER_SIMPLIFY ? 2 : op == GV_WORKER_RUN ? 1 : 0;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

/* "exited with status N" / "killed by signal N (SIGNAME)". */
static void describe_status(int st, char *buf, size_t size)
{
    if (WIFEXITED(st)) {
        snprintf(buf, size, "exited with status %d", WEXITSTATUS(st));
    } else if (WIFSIGNALED(st)) {
        const char *name = sigabbrev_np(WTERMSIG(st));
        snprintf(buf, size, "killed by signal %d (SIG%s)", WTERMSIG(st),
                 name ? name : "?");
    } else {
        snprintf(buf, size, "status 0x%x", (unsigned)st);
    }
}

/* SIGKILL and reap the slot's worker (if any); what became of it in
 * why.  Slot thread only. */
static void stop_worker(struct slot *s, char *why, size_t size)
{
    struct filter_jobs *p = s->pool;
    if (why && size)
        snprintf(why, size, "no worker");
    if (s->pid <= 0)
        return;
    pid_t pid = s->pid;
    int fd = s->fd;
    kill(pid, SIGKILL); /* a worker that already died is a zombie: no-op */
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR)
        ;
    if (why && size)
        describe_status(st, why, size);
    pthread_mutex_lock(&p->lock);
    s->pid = 0;
    s->fd = -1;
    if (s->ready)
        p->ready--;
    s->ready = 0;
    pthread_mutex_unlock(&p->lock);
    if (fd >= 0)
        close(fd);
}

static int start_failed(struct slot *s, const struct gv_error *err)
{
    s->start_err = *err;
    s->backoff_ms = s->backoff_ms ? s->backoff_ms * 2 : BACKOFF_MIN_MS;
    if (s->backoff_ms > BACKOFF_MAX_MS)
        s->backoff_ms = BACKOFF_MAX_MS;
    s->retry_at = gv_worker_now_ms() + s->backoff_ms;
    atomic_fetch_add(&s->pool->n_start_failures, 1);
    log_msg(LOG_ERROR, "filter", "slot %d: %s (next attempt in %d s)", s->index,
            err->text, s->backoff_ms / 1000);
    return -1;
}

/* Spawn p's worker program on one end of a new socket pair (descriptor 3
 * in the child).  0 with *pid and *fd (our end, non-blocking), or -1 with
 * *err. */
static int spawn_worker(struct filter_jobs *p, pid_t *pid, int *fd,
                        struct gv_error *err)
{
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) < 0)
        return gv_fail_errno(err, errno, "filter: socketpair");
    if (sv[1] == CHILD_FD) { /* dup2(3, 3) would keep FD_CLOEXEC */
        int d = fcntl(sv[1], F_DUPFD_CLOEXEC, CHILD_FD + 1);
        close(sv[1]);
        sv[1] = d;
        if (d < 0) {
            gv_fail_errno(err, errno, "filter: fcntl");
            close(sv[0]);
            return -1;
        }
    }
    char a_parent[24], a_mem[24], a_px[24];
    snprintf(a_parent, sizeof a_parent, "%ld", (long)getpid());
    snprintf(a_mem, sizeof a_mem, "%llu", (unsigned long long)p->cfg.memory_limit);
    snprintf(a_px, sizeof a_px, "%llu", (unsigned long long)p->cfg.max_pixels);
    char *argv[] = {p->path, "--fd", "3", "--parent", a_parent,
                    "--memory-limit", a_mem, "--max-pixels", a_px,
                    "--gpu-platform",
                    (char *)(p->cfg.gpu_platform ? p->cfg.gpu_platform : "auto"),
                    NULL};
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    sigset_t none, all;
    sigemptyset(&none);
    sigfillset(&all);
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&at);
    int rc = posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    if (!rc)
        rc = posix_spawn_file_actions_adddup2(&fa, 2, 1);
    if (!rc)
        rc = posix_spawn_file_actions_adddup2(&fa, sv[1], CHILD_FD);
    if (!rc)
        rc = posix_spawn_file_actions_addclosefrom_np(&fa, CHILD_FD + 1);
    if (!rc)
        rc = posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK |
                                               POSIX_SPAWN_SETSIGDEF);
    if (!rc)
        rc = posix_spawnattr_setsigmask(&at, &none);
    if (!rc)
        rc = posix_spawnattr_setsigdefault(&at, &all);
    *pid = 0;
    if (!rc)
        rc = posix_spawn(pid, p->path, &fa, &at, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    close(sv[1]);
    if (rc) {
        close(sv[0]);
        return gv_fail(err, GV_EIO, "filter: cannot start %s: %s", p->path,
                       strerror(rc));
    }
    fcntl(sv[0], F_SETFL, fcntl(sv[0], F_GETFL) | O_NONBLOCK);
    *fd = sv[0];
    return 0;
}

/* The slot's new worker gave no good hello (io: what reading it returned;
 * text: what it said): kill it and fail the start, unless the pool is
 * stopping under it.  Returns -1.  Slot thread. */
static int hello_failed(struct slot *s, pid_t pid, int io, const char *text,
                        struct gv_error *err)
{
    struct filter_jobs *p = s->pool;
    char why[96];
    stop_worker(s, why, sizeof why);
    pthread_mutex_lock(&p->lock);
    int stopping = p->stop;
    pthread_mutex_unlock(&p->lock);
    if (stopping) { /* shut down under it: not a failure to report */
        gv_error_clear(&s->start_err);   /* it may hold an earlier start's */
        gv_fail(&s->start_err, GV_EUNAVAIL, "filter: the server is stopping");
        return -1;
    }
    if (io == GV_WORKER_TIMEOUT)
        gv_fail(err, GV_EIO, "filter: worker %ld said nothing within %d s; "
                "killed", (long)pid, p->cfg.start_timeout_ms / 1000);
    else if (io == GV_WORKER_EOF)
        gv_fail(err, GV_EIO, "filter: worker %s %s before it was ready",
                p->path, why);
    else if (io == 0)
        gv_fail(err, GV_EUNAVAIL, "filter: worker has no GPU context: %s", text);
    return start_failed(s, err);
}

/* Spawn the slot's worker and wait for its hello.  0 or -1 (s->start_err
 * says why, and the next attempt waits for the back-off).  Slot thread. */
static int start_worker(struct slot *s)
{
    struct filter_jobs *p = s->pool;
    struct gv_error err = {0};
    gv_error_clear(&err);
    double t0 = now_s();
    pid_t pid = 0;
    int fd = -1;
    if (spawn_worker(p, &pid, &fd, &err) < 0)
        return start_failed(s, &err);
    pthread_mutex_lock(&p->lock);
    s->pid = pid;
    s->fd = fd;
    int stopping = p->stop;
    pthread_mutex_unlock(&p->lock);
    char text[GV_WORKER_MSG_MAX + 1] = "";
    int ok = 0;
    const int64_t until = gv_worker_now_ms() + s->pool->cfg.start_timeout_ms;
    int io = stopping ? GV_WORKER_EOF
                      : gv_worker_recv_hello(fd, until, &ok, text, sizeof text, &err);
    if (io || !ok)
        return hello_failed(s, pid, io, text, &err);
    s->backoff_ms = 0;
    s->retry_at = 0;
    pthread_mutex_lock(&p->lock);
    s->ready = 1;
    p->ready++;
    pthread_cond_broadcast(&p->wake); /* jobs may wait for a worker */
    pthread_mutex_unlock(&p->lock);
    atomic_fetch_add(&p->n_starts, 1);
    if (s->started)
        atomic_fetch_add(&p->n_restarts, 1);
    s->started = 1;
    log_msg(LOG_INFO, "filter", "slot %d: worker %ld ready in %.0f ms (%s)",
            s->index, (long)pid, (now_s() - t0) * 1e3, text);
    return 0;
}

/* An idle worker never writes: readable or hung up means it died (or
 * misbehaved).  Replace it before giving it a job. */
static void check_idle(struct slot *s)
{
    if (s->pid <= 0)
        return;
    struct pollfd pf = {s->fd, POLLIN, 0};
    if (poll(&pf, 1, 0) == 0)
        return;
    char why[96];
    stop_worker(s, why, sizeof why);
    log_msg(LOG_WARN, "filter", "slot %d: idle worker %s; starting another",
            s->index, why);
    start_worker(s);
}

/* Run j on the slot's worker.  Returns 1 if the worker was killed and
 * must be replaced, else 0.  Slot thread. */
static int run_job(struct slot *s, struct filter_job *j)
{
    struct filter_jobs *p = s->pool;
    if (s->pid <= 0 &&
        (gv_worker_now_ms() < s->retry_at || start_worker(s) < 0)) {
        j->status = FILTER_JOB_UNAVAILABLE;
        gv_fail(&j->err, GV_EUNAVAIL, "filters unavailable: %s", s->start_err.text);
        atomic_fetch_add(&p->n_unavailable, 1);
        return 0;
    }
    pid_t pid = s->pid;
    struct gv_error err = {0};
    gv_error_clear(&err);
    double t0 = now_s();
    int timeout_ms = j->timeout_ms > 0 ? j->timeout_ms : p->cfg.timeout_ms;
    int64_t deadline = gv_worker_now_ms() + timeout_ms;
    atomic_fetch_add(&p->n_kind[kind_index(j->job.op)], 1);
    int rc = gv_worker_send_job(s->fd, &j->job, deadline, &err);
    if (!rc)
        rc = gv_worker_recv_result(s->fd, &j->job, deadline, &j->res, &err);
    j->worker_ms = (now_s() - t0) * 1e3;
    atomic_fetch_add(&p->worker_usec, (uint_fast64_t)(j->worker_ms * 1e3));
    if (!rc) {
        j->status = FILTER_JOB_DONE;
        if (!j->res.failed) {
            atomic_fetch_add(&p->n_ok, 1);
            return 0;
        }
        atomic_fetch_add(&p->n_error, 1);
        /* Out of memory or a GPU failure may leave the driver in a bad
         * state: a fresh process costs a tenth of a second. */
        if (j->res.err.code != GV_ENOMEM && j->res.err.code != GV_EIO)
            return 0;
        char why[96];
        stop_worker(s, why, sizeof why);
        log_msg(LOG_WARN, "filter", "slot %d: worker %ld replaced after: %s",
                s->index, (long)pid, j->res.err.text);
        return 1;
    }
    char why[96];
    stop_worker(s, why, sizeof why);
    pthread_mutex_lock(&p->lock);
    int stopping = p->stop;
    pthread_mutex_unlock(&p->lock);
    if (stopping) {
        j->status = FILTER_JOB_CANCELLED;
        gv_fail(&j->err, GV_EUNAVAIL, "filter: cancelled: the server is stopping");
        atomic_fetch_add(&p->n_cancelled, 1);
        return 0;
    }
    const char *what = j->job.op == GV_WORKER_SIMPLIFY ? "simplify" : "filter";
    if (rc == GV_WORKER_TIMEOUT) {
        j->status = FILTER_JOB_TIMEOUT;
        gv_fail(&j->err, GV_ETIMEOUT, "%s: the job ran past the time limit of "
                "%d ms (%s); its worker was killed", what, timeout_ms,
                j->timeout_key ? j->timeout_key : "filter_timeout_ms");
        atomic_fetch_add(&p->n_timeout, 1);
    } else {
        j->status = FILTER_JOB_CRASHED;
        if (rc == GV_WORKER_EOF)
            gv_fail(&j->err, GV_ECRASH, "%s: the worker process died during "
                    "the job (%s)", what, why);
        else
            gv_fail(&j->err, GV_ECRASH, "%s: the worker broke the protocol "
                    "(%s) and was killed", what, err.text);
        atomic_fetch_add(&p->n_crash, 1);
    }
    log_msg(LOG_WARN, "filter", "slot %d: worker %ld %s after %.0f ms: %s",
            s->index, (long)pid, why, j->worker_ms, j->err.text);
    return 1;
}

/* An absolute CLOCK_MONOTONIC time for pthread_cond_timedwait. */
static struct timespec at_ms(int64_t ms)
{
    struct timespec ts = {(time_t)(ms / 1000), (long)(ms % 1000) * 1000000L};
    return ts;
}

/*
 * A slot takes the next job when it has a worker, or when no slot has
 * one (the job then fails at once as unavailable, rather than waiting).
 * A slot whose worker failed to start waits out its back-off and tries
 * again, leaving jobs to the others meanwhile.
 */
static void *slot_main(void *arg)
{
    struct slot *s = arg;
    struct filter_jobs *p = s->pool;
    start_worker(s);
    pthread_mutex_lock(&p->lock);
    for (;;) {
        if (p->stop && !p->queue.head)
            break;
        if (s->pid <= 0 && !p->stop && gv_worker_now_ms() >= s->retry_at) {
            pthread_mutex_unlock(&p->lock);
            start_worker(s);
            pthread_mutex_lock(&p->lock);
            continue;
        }
        if (!p->queue.head || (s->pid <= 0 && p->ready > 0 && !p->stop)) {
            if (s->pid <= 0 && !p->stop) {
                struct timespec ts = at_ms(s->retry_at);
                pthread_cond_timedwait(&p->wake, &p->lock, &ts);
            } else {
                pthread_cond_wait(&p->wake, &p->lock);
            }
            continue;
        }
        struct filter_job *j =
            job_queue_entry(job_queue_pop(&p->queue), struct filter_job, link);
        p->running++;
        pthread_mutex_unlock(&p->lock);

        int replace = 0;
        if (j->cancel && atomic_load(j->cancel)) { /* its client left */
            j->status = FILTER_JOB_CANCELLED;
            gv_fail(&j->err, GV_EUNAVAIL, "filter: cancelled: the client "
                    "went away");
            atomic_fetch_add(&p->n_cancelled, 1);
        } else {
            check_idle(s);
            replace = run_job(s, j);
        }

        pthread_mutex_lock(&p->lock);
        p->running--;
        p->reserved--;
        if (p->queue.count == 0 && p->running == 0)
            pthread_cond_broadcast(&p->idle);
        int stopping = p->stop;
        pthread_mutex_unlock(&p->lock);
        j->done(j, j->arg); /* answer first, then replace the worker */
        if (replace && !stopping)
            start_worker(s);
        pthread_mutex_lock(&p->lock);
    }
    pthread_mutex_unlock(&p->lock);
    stop_worker(s, NULL, 0);
    return NULL;
}

struct filter_jobs *filter_jobs_new(const struct filter_jobs_config *cfg,
                                    struct gv_error *err)
{
    struct filter_jobs *p = calloc(1, sizeof *p);
    if (!p) {
        gv_fail(err, GV_ENOMEM, "filter: out of memory");
        return NULL;
    }
    p->cfg = *cfg;
    p->path = strdup(cfg->worker_path);
    p->nslots = cfg->workers;
    p->slot = calloc((size_t)(cfg->workers > 0 ? cfg->workers : 1), sizeof *p->slot);
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->wake, &ca);
    pthread_cond_init(&p->idle, &ca);
    pthread_condattr_destroy(&ca);
    if (!p->path || !p->slot) {
        gv_fail(err, GV_ENOMEM, "filter: out of memory");
        filter_jobs_free(p);
        return NULL;
    }
    for (int i = 0; i < p->nslots; i++) {
        struct slot *s = &p->slot[i];
        s->pool = p;
        s->index = i;
        s->fd = -1;
        int rc = pthread_create(&s->thread, NULL, slot_main, s);
        if (rc) {
            gv_fail(err, GV_ENOMEM, "filter: cannot start a thread: %s", strerror(rc));
            filter_jobs_stop(p, 0);
            filter_jobs_free(p);
            return NULL;
        }
        s->thread_ok = 1;
    }
    return p;
}

int filter_jobs_reserve(struct filter_jobs *p)
{
    int rc = -1;
    pthread_mutex_lock(&p->lock);
    if (!p->draining && !p->stop && p->reserved < p->cfg.max_jobs) {
        p->reserved++;
        rc = 0;
    } else if (!p->draining && !p->stop) {
        atomic_fetch_add(&p->n_rejected, 1);
    }
    pthread_mutex_unlock(&p->lock);
    return rc;
}

void filter_jobs_unreserve(struct filter_jobs *p)
{
    pthread_mutex_lock(&p->lock);
    p->reserved--;
    pthread_mutex_unlock(&p->lock);
}

void filter_jobs_submit(struct filter_jobs *p, struct filter_job *j)
{
    memset(&j->res, 0, sizeof j->res);
    gv_error_clear(&j->err);
    pthread_mutex_lock(&p->lock);
    job_queue_push(&p->queue, &j->link);
    pthread_cond_broadcast(&p->wake); /* slots waiting out a back-off
                                         pass jobs on */
    pthread_mutex_unlock(&p->lock);
}

void filter_jobs_stop(struct filter_jobs *p, unsigned timeout_ms)
{
    if (!p)
        return;
    struct timespec until;
    clock_gettime(CLOCK_MONOTONIC, &until);
    until.tv_sec += timeout_ms / 1000;
    until.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (until.tv_nsec >= 1000000000L) {
        until.tv_sec++;
        until.tv_nsec -= 1000000000L;
    }
    pthread_mutex_lock(&p->lock);
    p->draining = 1;
    if (p->queue.count || p->running)
        log_msg(LOG_INFO, "filter", "waiting for %d filter jobs", p->queue.count + p->running);
    while ((p->queue.count || p->running) &&
           pthread_cond_timedwait(&p->idle, &p->lock, &until) == 0)
        ;
    p->stop = 1;
    p->reserved -= p->queue.count;
    struct job_link *cancelled = job_queue_take_all(&p->queue);
    for (int i = 0; i < p->nslots; i++)
        if (p->slot[i].fd >= 0)
            shutdown(p->slot[i].fd, SHUT_RDWR);
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    while (cancelled) {
        struct filter_job *j = job_queue_entry(cancelled, struct filter_job, link);
        cancelled = cancelled->next;
        j->status = FILTER_JOB_CANCELLED;
        gv_fail(&j->err, GV_EUNAVAIL, "filter: cancelled: the server is stopping");
        atomic_fetch_add(&p->n_cancelled, 1);
        j->done(j, j->arg);
    }
    for (int i = 0; i < p->nslots; i++)
        if (p->slot[i].thread_ok) {
            pthread_join(p->slot[i].thread, NULL);
            p->slot[i].thread_ok = 0;
        }
}

void filter_jobs_free(struct filter_jobs *p)
{
    if (!p)
        return;
    filter_jobs_stop(p, 0); /* a no-op when stopped already */
    pthread_mutex_destroy(&p->lock);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->idle);
    free(p->slot);
    free(p->path);
    free(p);
}

void filter_jobs_metrics(struct filter_jobs *p, struct prom *out)
{
    static const char *const results[] = {"ok", "error", "timeout", "crash",
                                          "unavailable", "cancelled"};
    uint64_t v[11] = {0};
    int ready = 0, queued = 0, running = 0;
    if (p) {
        atomic_uint_fast64_t *c[11] = {
            &p->n_ok, &p->n_error, &p->n_timeout, &p->n_crash, &p->n_unavailable,
            &p->n_cancelled, &p->n_rejected, &p->n_starts, &p->n_restarts,
            &p->n_start_failures, &p->worker_usec};
        for (int i = 0; i < 11; i++)
            v[i] = atomic_load(c[i]);
        pthread_mutex_lock(&p->lock);
        ready = p->ready;
        queued = p->queue.count;
        running = p->running;
        pthread_mutex_unlock(&p->lock);
    }
    prom_family(out, "gigaview_filter_jobs_total", "counter",
                "Filter jobs by result: ok, error (the graph failed in the "
                "worker: GLSL, limits), timeout (worker killed at "
                "filter_timeout_ms), crash (worker died), unavailable (no worker "
                "could start), cancelled (shutdown, or the client went away).");
    for (int i = 0; i < 6; i++)
        prom_printf(out, "gigaview_filter_jobs_total{result=\"%s\"} %llu\n",
                    results[i], (unsigned long long)v[i]);
    static const char *const kinds[] = {"compile", "run", "simplify"};
    prom_family(out, "gigaview_worker_jobs_total", "counter",
                "Jobs sent to a filter worker process, by kind: compile (POST "
                "/v1/filters), run (a filter graph over a region), simplify "
                "(POST /v1/meshes/simplify).");
    for (int i = 0; i < 3; i++)
        prom_printf(out, "gigaview_worker_jobs_total{kind=\"%s\"} %llu\n", kinds[i],
                    p ? (unsigned long long)atomic_load(&p->n_kind[i]) : 0ull);
    prom_metric(out, "gigaview_filter_jobs_rejected_total", "counter",
                "Filter requests refused with 503 because filter_max_jobs were "
                "queued or running.", "%llu", (unsigned long long)v[6]);
    prom_metric(out, "gigaview_filter_worker_starts_total", "counter",
                "Worker processes started.", "%llu", (unsigned long long)v[7]);
    prom_metric(out, "gigaview_filter_worker_restarts_total", "counter",
                "Workers started to replace one that was killed or died.", "%llu",
                (unsigned long long)v[8]);
    prom_metric(out, "gigaview_filter_worker_start_failures_total", "counter",
                "Workers that could not start (no EGL context, missing "
                "program).", "%llu", (unsigned long long)v[9]);
    prom_metric(out, "gigaview_filter_worker_seconds_total", "counter",
                "Time jobs spent in workers, from sending to the answer.", "%.6f",
                (double)v[10] / 1e6);
    prom_metric(out, "gigaview_filter_workers", "gauge",
                "Worker processes ready for jobs.", "%d", ready);
    prom_metric(out, "gigaview_filter_jobs_queued", "gauge",
                "Filter jobs waiting for a worker.", "%d", queued);
    prom_metric(out, "gigaview_filter_jobs_running", "gauge",
                "Filter jobs in workers.", "%d", running);
}
