/*
 * conn_watch.h - the watchdog of gigaviewd's connections: one thread that
 * does what libmicrohttpd cannot.
 *
 * - A whole request must arrive within request_timeout seconds.
 *   libmicrohttpd's connection_timeout is an idle timeout: it starts again
 *   with every byte, so a client sending one byte every few seconds held
 *   a connection for ever.  The clock starts when the connection opens or
 *   its previous request ends, and stops when the request has arrived
 *   whole (head and body); past it the socket is shut down, which makes
 *   libmicrohttpd close the connection.
 * - At connection_limit, a waiting client evicts the connection that has
 *   waited longest for a request (idle keep-alive, or slow), so slow
 *   clients cannot hold every place (conn_watch_evict).
 * - While a request is suspended (its job runs on the render pool or in a
 *   filter worker), libmicrohttpd does not poll its socket: the watchdog
 *   does, and sets the request's `gone` flag when the client hangs up, so
 *   the job is skipped and the request ends as 499 rather than 200.  A
 *   client that half-closes its side after sending the request counts as
 *   gone, as nginx treats it.
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_CONN_WATCH_H
#define GV_SERVER_CONN_WATCH_H

#include <stdatomic.h>

#include "base/error.h"

struct conn_watch;
struct conn_entry;

/* Start the thread: requests must arrive within request_timeout_s
 * seconds (0: no bound).  NULL with *err on a resource failure. */
struct conn_watch *conn_watch_start(unsigned request_timeout_s,
                                    struct gv_error *err);

/* Stop the thread and free everything (every connection closed before).
 * NULL does nothing. */
void conn_watch_stop(struct conn_watch *w);

/* A connection opened on socket fd: its request clock starts.  NULL when
 * out of memory (the connection is then not watched); every other
 * function takes NULL and does nothing. */
struct conn_entry *conn_watch_open(struct conn_watch *w, int fd);

/* The connection is closing (before its socket is closed): forget it. */
void conn_watch_close(struct conn_watch *w, struct conn_entry *e);

/* Its request has arrived whole: the clock stops. */
void conn_watch_request_in(struct conn_watch *w, struct conn_entry *e);

/* Its request has ended: the clock starts again for the next one. */
void conn_watch_request_done(struct conn_watch *w, struct conn_entry *e);

/* Its request is suspended: from now until conn_watch_resumed, *gone is
 * set to 1 when the client hangs up.  gone must stay valid until then. */
void conn_watch_suspended(struct conn_watch *w, struct conn_entry *e,
                          atomic_int *gone);

/* The request runs again: *gone is no longer written once this returns. */
void conn_watch_resumed(struct conn_watch *w, struct conn_entry *e);

/* A client waits at connection_limit: shut down the connection that has
 * waited longest for a request, if it has waited at least min_wait_ms.
 * Returns 1 when one was shut down (its close frees a place), else 0. */
int conn_watch_evict(struct conn_watch *w, unsigned min_wait_ms);

/* Requests cut short by request_timeout, connections evicted, and
 * suspended requests whose client hung up, since the start. */
struct conn_watch_stats {
    unsigned long long timeouts, evictions, hangups;
};
void conn_watch_stats(struct conn_watch *w, struct conn_watch_stats *s);

#endif
