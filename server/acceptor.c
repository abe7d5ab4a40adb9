/*
 * acceptor.c - the listen socket and the accepting thread (see
 * acceptor.h).
 *
 * The thread polls the listen socket and an eventfd.  The eventfd is
 * written when a connection closes while the limit is reached (room to
 * accept again), when a daemon's thread leaves its handler while every
 * one was in a handler (the acceptor waits for one), and by
 * acceptor_stop.  Counts are atomics: `open` and per_daemon[] rise here
 * when a connection is handed over and fall in acceptor_closed, busy[]
 * is kept by acceptor_busy, all on the daemons' threads; the sequentially
 * consistent order of `waiting` against busy[] means a thread leaving its
 * handler either is seen idle or sees the acceptor waiting and wakes it.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "acceptor.h"
#include "conn_watch.h"
#include "log.h"

struct acceptor {
    int listen_fd, wake_fd;
    struct MHD_Daemon *const *d;
    int n;
    int next;                 /* where the next tie is broken */
    unsigned limit;
    atomic_uint open;         /* connections handed over, not yet closed */
    atomic_int stopping;
    pthread_t thread;
    atomic_uint *per_daemon;  /* open connections by daemon */
    atomic_int *busy;         /* by daemon: its thread is in a handler */
    atomic_int waiting;       /* the thread waits for an idle daemon */
    int warned;               /* starved of descriptors, said so */
    struct conn_watch *watch; /* evicts at the limit; may be NULL */
};

int acceptor_listen(const char *addr, unsigned port, uint16_t *bound,
                    struct gv_error *err)
{
    struct sockaddr_storage ss;
    memset(&ss, 0, sizeof ss);
    struct sockaddr_in *in4 = (struct sockaddr_in *)&ss;
    struct sockaddr_in6 *in6 = (struct sockaddr_in6 *)&ss;
    socklen_t len;
    if (inet_pton(AF_INET, addr, &in4->sin_addr) == 1) {
        in4->sin_family = AF_INET;
        in4->sin_port = htons((uint16_t)port);
        len = sizeof *in4;
    } else if (inet_pton(AF_INET6, addr, &in6->sin6_addr) == 1) {
        in6->sin6_family = AF_INET6;
        in6->sin6_port = htons((uint16_t)port);
        len = sizeof *in6;
    } else {
        return gv_fail(err, GV_EINVAL, "listen: '%s' is not an IPv4 or IPv6 "
                       "address", addr);
    }
    int fd = socket(ss.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return gv_fail_errno(err, errno, "listen: socket");
    int on = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    if (ss.ss_family == AF_INET6)
        setsockopt(fd, IPPROTO_IPV6, IPV6_V6ONLY, &on, sizeof on);
    if (bind(fd, (struct sockaddr *)&ss, len) < 0 || listen(fd, SOMAXCONN) < 0) {
        int e = errno;
        close(fd);
        return gv_fail_errno(err, e, "listen: %s port %u", addr, port);
    }
    len = sizeof ss;
    if (getsockname(fd, (struct sockaddr *)&ss, &len) < 0) {
        int e = errno;
        close(fd);
        return gv_fail_errno(err, e, "listen: getsockname");
    }
    *bound = ntohs(ss.ss_family == AF_INET ? in4->sin_port : in6->sin6_port);
    return fd;
}

/* The daemon to take the next connection: of those whose thread is not
 * in a handler (all of them when none is idle, idle_only 0), the one with
 * the fewest open connections; among equals the first from a.next on,
 * which then moves past it (round robin on ties).  -1 when idle_only and
 * every thread is busy. */
static int least_loaded(struct acceptor *a, int idle_only)
{
    int best = -1;
    unsigned best_open = 0;
    for (int k = 0; k < a->n; k++) {
        int i = (a->next + k) % a->n;
        if (idle_only && atomic_load(&a->busy[i]) > 0)
            continue;
        unsigned o = atomic_load(&a->per_daemon[i]);
        if (best < 0 || o < best_open) {
            best = i;
            best_open = o;
        }
    }
    if (best >= 0)
        a->next = (best + 1) % a->n;
    return best;
}

/* 1 if some daemon's thread is not in a handler.  When none is, the
 * caller is about to wait: `waiting` is set first, so that a thread
 * leaving its handler after this look wakes it. */
static int some_idle(struct acceptor *a)
{
    atomic_store(&a->waiting, 1);
    for (int i = 0; i < a->n; i++)
        if (atomic_load(&a->busy[i]) == 0) {
            atomic_store(&a->waiting, 0);
            return 1;
        }
    return 0;
}

/* Accept one connection and hand it over.  0 when one was accepted or
 * the queue was empty, -1 when accepting failed for lack of resources
 * (descriptors, memory): the caller waits for a close. */
static int accept_one(struct acceptor *a)
{
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    int fd = accept4(a->listen_fd, (struct sockaddr *)&ss, &len,
                     SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
        if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS ||
            errno == ENOMEM) {
            if (!a->warned++) /* once until an accept succeeds */
                log_msg(LOG_WARN, "http", "accept: %s (%u connections open); "
                        "waiting for one to close", strerror(errno),
                        atomic_load(&a->open));
            return -1;
        }
        return 0; /* EAGAIN, a client gone before accept, a signal */
    }
    a->warned = 0;
    int i = least_loaded(a, 1);
    if (i < 0) /* they all turned busy since the poll: the fewest then */
        i = least_loaded(a, 0);
    atomic_fetch_add(&a->open, 1);
    atomic_fetch_add(&a->per_daemon[i], 1);
    /* MHD closes fd itself when it refuses the connection. */
    if (MHD_add_connection(a->d[i], fd, (struct sockaddr *)&ss, len) != MHD_YES) {
        atomic_fetch_sub(&a->per_daemon[i], 1);
        atomic_fetch_sub(&a->open, 1);
        log_msg(LOG_WARN, "http", "a connection could not be added: %s",
                strerror(errno));
    }
    return 0;
}

static void *accept_loop(void *arg)
{
    struct acceptor *a = arg;
    int starved = 0, evicted = 0;
    while (!atomic_load(&a->stopping)) {
        /* Accept only for a thread that is free to serve: while every
         * one is in a handler (a long render), a new client waits in the
         * accept queue rather than behind one of them. */
        int full = atomic_load(&a->open) >= a->limit;
        int room = !full && !starved && some_idle(a);
        /* At the limit, a waiting client is seen (unless an eviction is
         * already under way, or none was possible a moment ago). */
        int look = full && a->watch && !evicted && !starved;
        struct pollfd p[2] = {{a->wake_fd, POLLIN, 0}, {a->listen_fd, POLLIN, 0}};
        /* Starved of descriptors, or nobody to evict: retry within a
         * while even if no connection of ours closes. */
        int wait = starved ? 100 : evicted ? 1000 : -1;
        if (poll(p, room || look ? 2 : 1, wait) < 0 && errno != EINTR)
            break;
        atomic_store(&a->waiting, 0);
        if (p[0].revents) {
            uint64_t v;
            ssize_t r = read(a->wake_fd, &v, sizeof v);
            (void)r;
            starved = 0;
            evicted = 0;
        }
        if (!p[0].revents)
            starved = evicted = 0; /* the wait passed */
        if (look && (p[1].revents & POLLIN)) {
            conn_watch_evict(a->watch, 1000);
            evicted = 1; /* a close, or a second, before the next */
        } else if (room && (p[1].revents & POLLIN)) {
            starved = accept_one(a) < 0;
        }
    }
    return NULL;
}

/* Same shape as http_start's thread arrays in http.c: deliberately separate,
 * each allocates its own per-daemon arrays and reports in its own module. */
struct acceptor *acceptor_start(int listen_fd, struct MHD_Daemon *const *d,
                                int n, unsigned limit, struct conn_watch *watch,
                                struct gv_error *err)
{
    struct acceptor *a = calloc(1, sizeof *a);
    if (!a || !(a->per_daemon = calloc((size_t)n, sizeof *a->per_daemon)) ||
        !(a->busy = calloc((size_t)n, sizeof *a->busy))) {
        if (a)
            free(a->per_daemon);
        free(a);
        gv_fail(err, GV_ENOMEM, "acceptor: out of memory");
        return NULL;
    }
    a->listen_fd = listen_fd;
    a->d = d;
    a->n = n;
    a->limit = limit;
    a->watch = watch;
    a->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (a->wake_fd < 0) {
        gv_fail_errno(err, errno, "acceptor: eventfd");
        acceptor_free(a);
        return NULL;
    }
    int e = pthread_create(&a->thread, NULL, accept_loop, a);
    if (e) {
        gv_fail_errno(err, e, "acceptor: thread");
        close(a->wake_fd);
        free(a->per_daemon);
        free(a->busy);
        free(a);
        return NULL;
    }
    return a;
}

static void wake(struct acceptor *a)
{
    uint64_t one = 1;
    ssize_t r = write(a->wake_fd, &one, sizeof one);
    (void)r; /* a full counter already wakes the thread */
}

void acceptor_closed(struct acceptor *a, int i)
{
    atomic_fetch_sub(&a->per_daemon[i], 1);
    /* The thread waits on the eventfd alone while at the limit. */
    if (atomic_fetch_sub(&a->open, 1) >= a->limit)
        wake(a);
}

void acceptor_busy(struct acceptor *a, int i, int entering)
{
    if (entering) {
        atomic_fetch_add(&a->busy[i], 1);
        return;
    }
    atomic_fetch_sub(&a->busy[i], 1);
    if (atomic_load(&a->waiting))
        wake(a);
}

void acceptor_stop(struct acceptor *a)
{
    if (!a || atomic_exchange(&a->stopping, 1))
        return;
    wake(a);
    pthread_join(a->thread, NULL);
}

void acceptor_free(struct acceptor *a)
{
    if (!a)
        return;
    if (a->wake_fd >= 0)
        close(a->wake_fd);
    free(a->per_daemon);
    free(a->busy);
    free(a);
}
