/*
 * listen_fds.c - the socket-activation protocol (listen_fds.h).
 *
 * systemd passes the sockets of gigaviewd.socket as descriptors 3, 4, ...
 * and says so in the environment: LISTEN_PID (the process they are for:
 * a variable inherited by some other program means nothing) and
 * LISTEN_FDS (how many).  Parsed strictly: decimal digits only.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "listen_fds.h"

#define FIRST_FD 3 /* SD_LISTEN_FDS_START */

/* s as a decimal number below 2^31, or -1. */
static long parse_count(const char *s)
{
    long v = 0;
    if (!s || !*s)
        return -1;
    for (; *s; s++) {
        if (*s < '0' || *s > '9' || v > 0x7fffffffL / 10)
            return -1;
        v = v * 10 + (*s - '0');
    }
    return v;
}

static void unset_all(void)
{
    unsetenv("LISTEN_PID");
    unsetenv("LISTEN_FDS");
    unsetenv("LISTEN_FDNAMES");
}

/* Is fd a listening stream socket?  0, or -2 with *err. */
static int check_socket(int fd, struct gv_error *err)
{
    struct stat st;
    int type = 0, listening = 0;
    socklen_t len = sizeof type;
    if (fstat(fd, &st) < 0 || !S_ISSOCK(st.st_mode)) {
        gv_fail(err, GV_EINVAL, "listen: LISTEN_FDS=1 but descriptor %d is not a "
                "socket", fd);
        return -2;
    }
    if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &len) < 0 ||
        type != SOCK_STREAM) {
        gv_fail(err, GV_EINVAL, "listen: descriptor %d is not a stream socket", fd);
        return -2;
    }
    len = sizeof listening;
    if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &len) < 0 ||
        !listening) {
        gv_fail(err, GV_EINVAL, "listen: socket %d is not listening", fd);
        return -2;
    }
    return 0;
}

int listen_fds_take(struct gv_error *err)
{
    const char *pid = getenv("LISTEN_PID"), *fds = getenv("LISTEN_FDS");
    if (!fds)
        return -1;
    long p = parse_count(pid);
    if (p != (long)getpid())
        return -1; /* not for us: leave it alone */
    long n = parse_count(fds);
    char given[24];
    snprintf(given, sizeof given, "%s", fds); /* unsetenv frees it */
    unset_all();
    if (n != 1) {
        gv_fail(err, GV_EINVAL, "listen: LISTEN_FDS=%s: gigaviewd takes exactly "
                "one listening socket", given);
        return -2;
    }
    if (check_socket(FIRST_FD, err) < 0)
        return -2;
    int fl = fcntl(FIRST_FD, F_GETFD);
    if (fl < 0 || fcntl(FIRST_FD, F_SETFD, fl | FD_CLOEXEC) < 0) {
        gv_fail(err, GV_EIO, "listen: descriptor %d: %s", FIRST_FD, strerror(errno));
        return -2;
    }
    return FIRST_FD;
}
