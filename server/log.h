/*
 * log.h - gigaviewd's log lines and access log.
 *
 * Every line is "TIME PID LEVEL MODULE: MESSAGE", TIME in UTC as
 * 2026-11-22T16:40:01Z, written with one write(2) so that lines from
 * different threads never interleave.  Anything that came from a client
 * must go through log_escape first: control characters, quotes, backslash
 * and non-ASCII bytes become \xNN, so a request cannot forge log lines.
 * Access lines (one per request, from the completion callback) go to their
 * own destination: a file, "stderr", or "off".
 * All functions may be called from any thread after log_init.
 */
#ifndef GV_SERVER_LOG_H
#define GV_SERVER_LOG_H

#include <stddef.h>

enum log_level { LOG_ERROR = 0, LOG_WARN, LOG_INFO, LOG_DEBUG };

/* Set the threshold and open the access log ("stderr", "off" or a path,
 * opened for append).  Returns 0, or -1 (message on stderr). */
int log_init(enum log_level level, const char *access_log);

/* Close the access log file, if any. */
void log_close(void);

/* Parse "error", "warn", "info" or "debug".  Returns the level or -1. */
int log_level_parse(const char *s);

/* One line at `level` from `module` (e.g. "http", "catalog"). */
void log_msg(enum log_level level, const char *module, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* One access line: remote, method, path (escaped here), status, body
 * bytes, duration in microseconds. */
void log_access(const char *remote, const char *method, const char *path,
                unsigned status, unsigned long long bytes,
                unsigned long long usec);

/* Copy src to dst (size dstsize, always NUL-terminated), escaping bytes
 * outside printable ASCII, '"' and '\\' as \xNN; long input is cut with
 * "...".  Returns dst. */
char *log_escape(char *dst, size_t dstsize, const char *src);

#endif
