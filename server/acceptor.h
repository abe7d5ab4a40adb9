/*
 * acceptor.h - gigaviewd's listen socket and the one thread that accepts
 * on it and deals the connections out to the HTTP threads.
 *
 * libmicrohttpd's own thread pool lets every pool thread poll the shared
 * listen socket; whichever wakes first accepts up to eleven connections
 * in a row, so a burst of connections lands on one or two threads (with
 * 4 threads and 64 keep-alive connections, splits like 43/11/10/2 and
 * 33/33/0/0 were measured).  Instead http.c starts one libmicrohttpd
 * daemon per thread without a listen socket, and this thread hands each
 * accepted connection (MHD_add_connection) to a daemon whose thread is
 * not inside a request handler, the one holding the fewest connections,
 * the next one in turn on a tie, so keep-alive and short connections
 * alike spread evenly.  While every thread is inside a handler (long
 * renders block their thread), it accepts nothing: the next client waits
 * in the accept queue for the first thread to come free, as it did when
 * the threads accepted for themselves, rather than behind a render.
 *
 * It also keeps connection_limit: at the limit it stops accepting, so
 * further clients wait in the kernel's accept queue (never refused) until
 * a connection closes, as libmicrohttpd did; and so that idle or slow
 * clients cannot hold every place, a waiting client evicts the one that
 * has waited longest for its next request.
 */
#ifndef GV_SERVER_ACCEPTOR_H
#define GV_SERVER_ACCEPTOR_H

#include <stdint.h>

#include <microhttpd.h>

#include "base/error.h"

struct acceptor;

/*
 * Open a TCP listen socket on `addr` (an IPv4 or IPv6 literal) and
 * `port` (0: any free one), non-blocking, close-on-exec, with
 * SO_REUSEADDR (and IPV6_V6ONLY for IPv6).  Returns the socket and sets
 * *bound to the port it got, or -1 with *err (GV_EINVAL for an address
 * that is no literal, GV_EIO for a failed bind or listen).
 */
int acceptor_listen(const char *addr, unsigned port, uint16_t *bound,
                    struct gv_error *err);

struct conn_watch;

/*
 * Start accepting on listen_fd (kept open; the caller closes it after
 * acceptor_stop) and handing the connections to the n daemons d[0..n-1],
 * at most `limit` open at once.  At the limit, a client waiting to
 * connect makes it evict, through `watch` (NULL: never), the connection
 * that has waited longest (a second at least) for a request
 * (conn_watch_evict), one at a time.  Returns NULL with *err when the
 * thread cannot start.
 */
struct acceptor *acceptor_start(int listen_fd, struct MHD_Daemon *const *d,
                                int n, unsigned limit, struct conn_watch *watch,
                                struct gv_error *err);

/* A connection handed to daemon i closed (libmicrohttpd's
 * MHD_CONNECTION_NOTIFY_CLOSED): its slot is free.  Any thread. */
void acceptor_closed(struct acceptor *a, int i);

/* Daemon i's thread enters (entering 1) or leaves (0) a request handler.
 * Called on that thread, in pairs. */
void acceptor_busy(struct acceptor *a, int i, int entering);

/* Stop accepting and join the thread; connections already handed over
 * stay with their daemons, and acceptor_closed may still be called until
 * the daemons are stopped.  NULL is a no-op. */
void acceptor_stop(struct acceptor *a);

/* Free it, after acceptor_stop and after the daemons stopped.  NULL is a
 * no-op. */
void acceptor_free(struct acceptor *a);

#endif
