/*
 * util.h - tiny TAP helpers shared by the C unit tests.
 *
 * Each test program prints a TAP plan and "ok N - name" lines through
 * check(); fail() prints file and line.  Exit status is 0 when every check
 * passed, 1 otherwise, so the automake TAP driver and a plain run agree.
 */
#ifndef GV_TESTS_UTIL_H
#define GV_TESTS_UTIL_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

static int tap_count, tap_failed;

static inline void tap_plan(int n)
{
    printf("1..%d\n", n);
    fflush(stdout);
}

__attribute__((format(printf, 4, 5))) static inline int
tap_check(const char *file, int line, int cond, const char *fmt, ...)
{
    va_list ap;
    tap_count++;
    printf("%sok %d - ", cond ? "" : "not ", tap_count);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf("\n");
    if (!cond) {
        printf("# failed at %s:%d\n", file, line);
        tap_failed++;
    }
    fflush(stdout);
    return cond;
}

#define check(cond, ...) tap_check(__FILE__, __LINE__, (cond) ? 1 : 0, __VA_ARGS__)

/* Abort the whole program: for set-up failures that make further checks
 * meaningless. */
#define fail(...)                                                   \
    do {                                                            \
        printf("Bail out! %s:%d: ", __FILE__, __LINE__);            \
        printf(__VA_ARGS__);                                        \
        printf("\n");                                               \
        exit(99);                                                   \
    } while (0)

static inline int tap_done(void)
{
    return tap_failed ? 1 : 0;
}

#endif
