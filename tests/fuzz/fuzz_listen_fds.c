/*
 * fuzz_listen_fds.c - libFuzzer target for the socket-activation
 * environment (server/listen_fds.c: LISTEN_PID, LISTEN_FDS,
 * LISTEN_FDNAMES).
 *
 * Byte 0 says which variables are set (bit 0 LISTEN_PID, bit 1
 * LISTEN_FDS, bit 2 LISTEN_FDNAMES); the rest is their three values
 * separated by newlines (each at most 4 KiB, cut at a NUL as the
 * environment would).  In LISTEN_PID every '@' becomes this process's
 * pid, so an input can name this process whatever its pid ("@", "00@",
 * "@0", "-@").  listen_fds_take must then agree with a reference written
 * here from sd_listen_fds(3): the variables are for this process exactly
 * when LISTEN_FDS is set and LISTEN_PID is decimal digits whose value is
 * the pid; if not, -1 and the environment untouched; if so, all three
 * unset, and LISTEN_FDS other than the decimal 1 is refused (-2, a
 * "listen: LISTEN_FDS=" message).  A 1 gives descriptor 3, now
 * close-on-exec, or -2 with a "listen: " message (descriptor 3 is
 * whatever the driver has there; this target never makes one).  Anything
 * else aborts.
 */
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz.h"
#include "listen_fds.h"

#define MAX_VALUE 4096

/* s without its leading zeros equals want, s all decimal digits. */
static int decimal_is(const char *s, const char *want)
{
    if (!*s)
        return 0;
    for (const char *p = s; *p; p++)
        if (*p < '0' || *p > '9')
            return 0;
    while (*s == '0')
        s++;
    return strcmp(s, want) == 0;
}

/* Whether the variable is set to exactly v (v NULL: unset). */
static int env_is(const char *name, const char *v)
{
    const char *e = getenv(name);
    return v ? e && strcmp(e, v) == 0 : e == NULL;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char val[3][MAX_VALUE * 12 + 1]; /* '@' may grow to 11 digits */
    static const char *const name[3] = {"LISTEN_PID", "LISTEN_FDS", "LISTEN_FDNAMES"};
    if (size == 0)
        return 0;
    const unsigned set = data[0];
    char pid[24];
    snprintf(pid, sizeof pid, "%ld", (long)getpid());
    size_t at = 1;
    for (int i = 0; i < 3; i++) {
        size_t n = 0, end = at;
        while (end < size && (i == 2 || data[end] != '\n'))
            end++;
        for (size_t k = at; k < end && k - at < MAX_VALUE && data[k]; k++) {
            if (i == 0 && data[k] == '@') {
                memcpy(val[i] + n, pid, strlen(pid));
                n += strlen(pid);
            } else {
                val[i][n++] = (char)data[k];
            }
        }
        val[i][n] = '\0';
        at = end < size ? end + 1 : size;
    }
    const char *want[3];
    for (int i = 0; i < 3; i++) {
        want[i] = (set >> i) & 1 ? val[i] : NULL;
        if (want[i] ? setenv(name[i], want[i], 1) : unsetenv(name[i]))
            abort();
    }

    struct gv_error err = {0};
    gv_error_clear(&err);
    int rc = listen_fds_take(&err);

    const int for_us = want[1] && want[0] && decimal_is(want[0], pid);
    if (!for_us) {
        if (rc != -1)
            abort();
        for (int i = 0; i < 3; i++)
            if (!env_is(name[i], want[i]))
                abort();
    } else {
        for (int i = 0; i < 3; i++)
            if (!env_is(name[i], NULL))
                abort();
        if (!decimal_is(want[1], "1")) {
            if (rc != -2 || strncmp(err.text, "listen: LISTEN_FDS=", 19) != 0 ||
                err.code != GV_EINVAL)
                abort();
        } else if (rc == 3) {
            int fl = fcntl(3, F_GETFD);
            if (fl < 0 || !(fl & FD_CLOEXEC))
                abort();
        } else if (rc != -2 || strncmp(err.text, "listen: ", 8) != 0 ||
                   err.code == GV_OK) {
            abort();
        }
    }
    for (int i = 0; i < 3; i++)
        unsetenv(name[i]);
    return 0;
}
