/*
 * listen_fds.h - a listening socket passed by systemd (socket activation,
 * conf/gigaviewd.socket), read the way sd_listen_fds(3) does but without
 * libsystemd: LISTEN_PID names this process, LISTEN_FDS counts the
 * descriptors passed from 3 on.  gigaviewd takes exactly one, a listening
 * stream socket, and then binds nothing itself, so its service can run
 * with PrivateNetwork=yes.
 */
#ifndef GV_SERVER_LISTEN_FDS_H
#define GV_SERVER_LISTEN_FDS_H

#include "base/error.h"

/* The socket systemd passed, if any.  Returns its descriptor (3), made
 * close-on-exec; -1 when none was passed to this process (no LISTEN_FDS,
 * or LISTEN_PID names another one); -2 with *err when one was meant for
 * this process but cannot be used (LISTEN_FDS not a count, not exactly 1,
 * descriptor 3 not a listening stream socket).  Unsets LISTEN_PID,
 * LISTEN_FDS and LISTEN_FDNAMES whenever they were meant for this process,
 * so children do not see them.  Call once, from the main thread, before
 * any other thread starts (it changes the environment). */
int listen_fds_take(struct gv_error *err);

#endif
