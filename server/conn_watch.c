/*
 * conn_watch.c - the connections' watchdog (see conn_watch.h).
 *
 * One thread waits on an epoll set that holds an eventfd (to stop it) and
 * the sockets of suspended requests (EPOLLRDHUP, one-shot), waking at
 * least every TICK_MS to check the request clocks of every connection in
 * one list.  Everything is under one mutex.  A closed connection's entry
 * is not freed at once: an epoll_wait that began before its socket left
 * the set may still return it, so it goes to a graveyard that the thread
 * empties after handling the events it already holds; entries there are
 * marked dead and ignored.
 */
#include <errno.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "conn_watch.h"
#include "log.h"

#define TICK_MS 250

struct conn_entry {
    int fd;
    int armed;            /* the request clock runs */
    int in_epoll;         /* in the epoll set (suspended) */
    int dead;             /* closed: in the graveyard */
    int64_t since_ms;     /* the clock's start */
    atomic_int *gone;     /* suspended: set on hang-up; else NULL */
    struct conn_entry *prev, *next; /* the list, or the graveyard (next) */
};

struct conn_watch {
    pthread_mutex_t lock;
    pthread_t thread;
    int epfd, wake_fd;
    int stop;
    int64_t timeout_ms;
    struct conn_entry *head;      /* open connections */
    struct conn_entry *graveyard; /* closed, freed by the thread */
    struct conn_watch_stats stats;
};

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Shut e's socket down: libmicrohttpd's next read or write on it fails
 * and it closes the connection itself. */
static void cut(struct conn_entry *e)
{
    shutdown(e->fd, SHUT_RDWR);
    e->armed = 0;
}

static void check_clocks(struct conn_watch *w, int64_t now)
{
    if (!w->timeout_ms)
        return;
    for (struct conn_entry *e = w->head; e; e = e->next)
        if (e->armed && now - e->since_ms >= w->timeout_ms) {
            cut(e);
            w->stats.timeouts++;
            log_msg(LOG_DEBUG, "http", "a request did not arrive whole "
                    "within request_timeout (%lld s): connection closed",
                    (long long)(w->timeout_ms / 1000));
        }
}

static void *watch_main(void *arg)
{
    struct conn_watch *w = arg;
    struct epoll_event ev[64];
    int64_t next_tick = now_ms() + TICK_MS;
    for (;;) {
        int64_t wait = next_tick - now_ms();
        int n = epoll_wait(w->epfd, ev, 64, wait > 0 ? (int)wait : 0);
        if (n < 0 && errno != EINTR) {
            log_msg(LOG_ERROR, "http", "connection watchdog: epoll_wait: %s",
                    strerror(errno));
            n = 0;
            struct timespec ts = {0, TICK_MS * 1000000L};
            nanosleep(&ts, NULL);
        }
        pthread_mutex_lock(&w->lock);
        if (w->stop) {
            pthread_mutex_unlock(&w->lock);
            break;
        }
        for (int i = 0; i < n; i++) {
            if (ev[i].data.ptr == w) { /* the eventfd */
                uint64_t v;
                ssize_t r = read(w->wake_fd, &v, sizeof v);
                (void)r;
                continue;
            }
            struct conn_entry *e = ev[i].data.ptr;
            if (!e->dead && e->gone) {
                atomic_store(e->gone, 1);
                e->gone = NULL; /* one-shot: no more events */
                w->stats.hangups++;
            }
        }
        while (w->graveyard) {
            struct conn_entry *e = w->graveyard;
            w->graveyard = e->next;
            free(e);
        }
        int64_t now = now_ms();
        if (now >= next_tick) {
            check_clocks(w, now);
            next_tick = now + TICK_MS;
        }
        pthread_mutex_unlock(&w->lock);
    }
    return NULL;
}

struct conn_watch *conn_watch_start(unsigned request_timeout_s,
                                    struct gv_error *err)
{
    struct conn_watch *w = calloc(1, sizeof *w);
    if (!w) {
        gv_fail(err, GV_ENOMEM, "connection watchdog: out of memory");
        return NULL;
    }
    w->timeout_ms = (int64_t)request_timeout_s * 1000;
    w->epfd = epoll_create1(EPOLL_CLOEXEC);
    w->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    struct epoll_event ev = {.events = EPOLLIN, .data.ptr = w};
    if (w->epfd < 0 || w->wake_fd < 0 ||
        epoll_ctl(w->epfd, EPOLL_CTL_ADD, w->wake_fd, &ev) < 0) {
        gv_fail_errno(err, errno, "connection watchdog: epoll");
        goto fail;
    }
    pthread_mutex_init(&w->lock, NULL);
    int rc = pthread_create(&w->thread, NULL, watch_main, w);
    if (rc) {
        gv_fail_errno(err, rc, "connection watchdog: thread");
        pthread_mutex_destroy(&w->lock);
        goto fail;
    }
    return w;
fail:
    if (w->epfd >= 0)
        close(w->epfd);
    if (w->wake_fd >= 0)
        close(w->wake_fd);
    free(w);
    return NULL;
}

void conn_watch_stop(struct conn_watch *w)
{
    if (!w)
        return;
    pthread_mutex_lock(&w->lock);
    w->stop = 1;
    pthread_mutex_unlock(&w->lock);
    uint64_t one = 1;
    ssize_t r = write(w->wake_fd, &one, sizeof one);
    (void)r;
    pthread_join(w->thread, NULL);
    struct conn_entry *lists[2] = {w->head, w->graveyard};
    for (int k = 0; k < 2; k++)
        while (lists[k]) {
            struct conn_entry *e = lists[k];
            lists[k] = e->next;
            free(e);
        }
    close(w->epfd);
    close(w->wake_fd);
    pthread_mutex_destroy(&w->lock);
    free(w);
}

struct conn_entry *conn_watch_open(struct conn_watch *w, int fd)
{
    if (!w || fd < 0)
        return NULL;
    struct conn_entry *e = calloc(1, sizeof *e);
    if (!e)
        return NULL;
    e->fd = fd;
    e->armed = 1;
    e->since_ms = now_ms();
    pthread_mutex_lock(&w->lock);
    e->next = w->head;
    if (w->head)
        w->head->prev = e;
    w->head = e;
    pthread_mutex_unlock(&w->lock);
    return e;
}

/* Take e's socket out of the epoll set (locked). */
static void leave_epoll(struct conn_watch *w, struct conn_entry *e)
{
    if (e->in_epoll)
        epoll_ctl(w->epfd, EPOLL_CTL_DEL, e->fd, NULL);
    e->in_epoll = 0;
    e->gone = NULL;
}

/* Same shape as unlink_entry in page_cache.c: deliberately separate, each
 * unlinks its own list (this one also leaves epoll). */
void conn_watch_close(struct conn_watch *w, struct conn_entry *e)
{
    if (!w || !e)
        return;
    pthread_mutex_lock(&w->lock);
    leave_epoll(w, e);
    if (e->prev)
        e->prev->next = e->next;
    else
        w->head = e->next;
    if (e->next)
        e->next->prev = e->prev;
    e->dead = 1;
    e->next = w->graveyard;
    w->graveyard = e;
    pthread_mutex_unlock(&w->lock);
}

/* Same shape as conn_watch_resumed below: deliberately separate, one arms the
 * clock for a request, the other for a resumed answer. */
void conn_watch_request_in(struct conn_watch *w, struct conn_entry *e)
{
    if (!w || !e)
        return;
    pthread_mutex_lock(&w->lock);
    e->armed = 0;
    pthread_mutex_unlock(&w->lock);
}

void conn_watch_request_done(struct conn_watch *w, struct conn_entry *e)
{
    if (!w || !e)
        return;
    pthread_mutex_lock(&w->lock);
    e->armed = 1;
    e->since_ms = now_ms();
    pthread_mutex_unlock(&w->lock);
}

void conn_watch_suspended(struct conn_watch *w, struct conn_entry *e,
                          atomic_int *gone)
{
    if (!w || !e)
        return;
    pthread_mutex_lock(&w->lock);
    struct epoll_event ev = {.events = EPOLLRDHUP | EPOLLONESHOT,
                             .data.ptr = e};
    e->gone = gone;
    if (!e->in_epoll && epoll_ctl(w->epfd, EPOLL_CTL_ADD, e->fd, &ev) == 0)
        e->in_epoll = 1;
    else if (e->in_epoll)
        epoll_ctl(w->epfd, EPOLL_CTL_MOD, e->fd, &ev);
    if (!e->in_epoll)
        e->gone = NULL;
    pthread_mutex_unlock(&w->lock);
}

/* Same shape as conn_watch_request_in above: deliberately separate, each moves
 * the entry for its own event. */
void conn_watch_resumed(struct conn_watch *w, struct conn_entry *e)
{
    if (!w || !e)
        return;
    pthread_mutex_lock(&w->lock);
    leave_epoll(w, e);
    pthread_mutex_unlock(&w->lock);
}

int conn_watch_evict(struct conn_watch *w, unsigned min_wait_ms)
{
    if (!w)
        return 0;
    pthread_mutex_lock(&w->lock);
    struct conn_entry *oldest = NULL;
    for (struct conn_entry *e = w->head; e; e = e->next)
        if (e->armed && (!oldest || e->since_ms < oldest->since_ms))
            oldest = e;
    int cut_one = oldest && now_ms() - oldest->since_ms >= (int64_t)min_wait_ms;
    if (cut_one) {
        cut(oldest);
        w->stats.evictions++;
    }
    pthread_mutex_unlock(&w->lock);
    return cut_one;
}

void conn_watch_stats(struct conn_watch *w, struct conn_watch_stats *s)
{
    memset(s, 0, sizeof *s);
    if (!w)
        return;
    pthread_mutex_lock(&w->lock);
    *s = w->stats;
    pthread_mutex_unlock(&w->lock);
}
