/*
 * log.c - log lines and the access log (see log.h).
 *
 * Lines are formatted into a stack buffer and written with a single
 * write(2): POSIX makes writes of a regular file or pipe by one call
 * atomic enough for line-sized output, so no lock is needed.
 */
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "log.h"

static enum log_level threshold = LOG_INFO;
static int access_fd = 2;           /* -1: access log off */
static int access_owned;            /* access_fd is ours to close */

static const char *const level_names[] = {"error", "warn", "info", "debug"};

int log_level_parse(const char *s)
{
    for (int i = 0; i < 4; i++)
        if (!strcmp(s, level_names[i]))
            return i;
    return -1;
}

int log_init(enum log_level level, const char *access_log)
{
    threshold = level;
    log_close();
    if (!strcmp(access_log, "off")) {
        access_fd = -1;
    } else if (!strcmp(access_log, "stderr")) {
        access_fd = 2;
    } else {
        int fd = open(access_log, O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC,
                      0640);
        if (fd < 0) {
            log_msg(LOG_ERROR, "log", "cannot open access log %s: %m",
                    access_log);
            return -1;
        }
        access_fd = fd;
        access_owned = 1;
    }
    return 0;
}

void log_close(void)
{
    if (access_owned)
        close(access_fd);
    access_owned = 0;
    access_fd = 2;
}

/* "2026-11-22T16:40:01Z" into buf (at least 21 bytes). */
static void stamp(char *buf, size_t size)
{
    time_t now = time(NULL);
    struct tm tm;
    gmtime_r(&now, &tm);
    strftime(buf, size, "%Y-%m-%dT%H:%M:%SZ", &tm);
}

static void write_line(int fd, char *line, size_t len, size_t cap)
{
    if (len >= cap - 1)
        len = cap - 2; /* truncated by vsnprintf: keep the newline */
    line[len++] = '\n';
    while (len > 0) {
        ssize_t n = write(fd, line, len);
        if (n <= 0)
            return; /* nowhere to report a failing log */
        line += n;
        len -= (size_t)n;
    }
}

void log_msg(enum log_level level, const char *module, const char *fmt, ...)
{
    if (level > threshold)
        return;
    char line[2048], ts[32];
    stamp(ts, sizeof ts);
    int n = snprintf(line, sizeof line, "%s %ld %s %s: ", ts, (long)getpid(),
                     level_names[level], module);
    if (n < 0)
        return;
    va_list ap;
    va_start(ap, fmt);
    int m = vsnprintf(line + n, sizeof line - (size_t)n, fmt, ap);
    va_end(ap);
    if (m < 0)
        return;
    write_line(2, line, (size_t)n + (size_t)m, sizeof line);
}

void log_access(const char *remote, const char *method, const char *path,
                unsigned status, unsigned long long bytes,
                unsigned long long usec)
{
    if (access_fd < 0)
        return;
    char line[2048], ts[32], epath[1024], emethod[40];
    stamp(ts, sizeof ts);
    log_escape(epath, sizeof epath, path);
    log_escape(emethod, sizeof emethod, method);
    int n = snprintf(line, sizeof line,
                     "%s %ld info access: %s \"%s %s\" %u %llu %lluus", ts,
                     (long)getpid(), remote, emethod, epath, status, bytes,
                     usec);
    if (n > 0)
        write_line(access_fd, line, (size_t)n, sizeof line);
}

char *log_escape(char *dst, size_t dstsize, const char *src)
{
    static const char hex[] = "0123456789abcdef";
    size_t o = 0;
    if (dstsize == 0)
        return dst;
    for (const unsigned char *p = (const unsigned char *)src; *p; p++) {
        int plain = *p >= 0x20 && *p < 0x7f && *p != '"' && *p != '\\';
        size_t need = plain ? 1 : 4;
        if (o + need + 4 > dstsize) { /* room for "..." and NUL */
            if (o + 4 <= dstsize) {
                memcpy(dst + o, "...", 3);
                o += 3;
            }
            break;
        }
        if (plain) {
            dst[o++] = (char)*p;
        } else {
            dst[o++] = '\\';
            dst[o++] = 'x';
            dst[o++] = hex[*p >> 4];
            dst[o++] = hex[*p & 15];
        }
    }
    dst[o] = '\0';
    return dst;
}
