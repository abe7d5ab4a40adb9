/*
 * util.h - tiny TAP helpers shared by the C unit tests.
 *
 * Each test program prints "ok N - name" lines through check() and ends
 * with tap_done(), which prints the plan ("1..N", N the number of checks
 * made: TAP allows the plan after the tests) so that no count is kept by
 * hand.  A program that stops early (a crash, fail()) prints no plan, and
 * the automake TAP driver reports it as an error.  fail() prints file and
 * line.  Exit status is 0 when every check passed, 1 otherwise, so the
 * driver and a plain run agree.
 */
#ifndef GV_TESTS_UTIL_H
#define GV_TESTS_UTIL_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int tap_count, tap_failed;

/* test_rand(&state): the next number of a xorshift64 generator (Marsaglia,
 * "Xorshift RNGs", 2003: shifts 13, 7, 17), its low 32 bits; the random
 * fills of the tests, the same on every machine for a given non-zero seed. */
static inline uint32_t test_rand(uint64_t *state)
{
    uint64_t x = *state;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    *state = x;
    return (uint32_t)x;
}

/* One "ok"/"not ok" line; the checks below and check() come here. */
__attribute__((format(printf, 4, 0))) static inline int
tap_vcheck(const char *file, int line, int cond, const char *fmt, va_list ap)
{
    tap_count++;
    printf("%sok %d - ", cond ? "" : "not ", tap_count);
    vprintf(fmt, ap);
    printf("\n");
    if (!cond) {
        printf("# failed at %s:%d\n", file, line);
        tap_failed++;
    }
    fflush(stdout);
    return cond;
}

__attribute__((format(printf, 4, 5))) static inline int
tap_check(const char *file, int line, int cond, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    cond = tap_vcheck(file, line, cond, fmt, ap);
    va_end(ap);
    return cond;
}

/* The check_str() behind the macro: GOT may be NULL (never equal). */
__attribute__((format(printf, 5, 6))) static inline int
tap_check_str(const char *file, int line, const char *got, const char *want,
              const char *fmt, ...)
{
    va_list ap;
    int same = got && strcmp(got, want) == 0;
    va_start(ap, fmt);
    tap_vcheck(file, line, same, fmt, ap);
    va_end(ap);
    if (!same) {
        printf("#   got:  %s\n", got ? got : "(null)");
        printf("#   want: %s\n", want);
        fflush(stdout);
    }
    return same;
}

#define check(cond, ...) tap_check(__FILE__, __LINE__, (cond) ? 1 : 0, __VA_ARGS__)

/* check_str(GOT, WANT, FMT, ...): one check that the string GOT is exactly
 * WANT (an error message, say); a failure shows both. */
#define check_str(got, want, ...) \
    tap_check_str(__FILE__, __LINE__, (got), (want), __VA_ARGS__)

/* Abort the whole program: for set-up failures that make further checks
 * meaningless. */
#define fail(...)                                                   \
    do {                                                            \
        printf("Bail out! %s:%d: ", __FILE__, __LINE__);            \
        printf(__VA_ARGS__);                                        \
        printf("\n");                                               \
        exit(99);                                                   \
    } while (0)

/* tap_skip(REASON, FMT, ...): checks that cannot run here, reported as one
 * "ok" line with a "# SKIP REASON" directive; FMT names what was skipped. */
__attribute__((format(printf, 2, 3))) static inline void
tap_skip(const char *reason, const char *fmt, ...)
{
    va_list ap;
    printf("ok %d - ", ++tap_count);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf(" # SKIP %s\n", reason);
    fflush(stdout);
}

/* tap_skip_all(FMT, ...): the whole program cannot run here (no GPU, say).
 * Prints the empty plan with a "# SKIP" directive and the reason; returns
 * the exit status for main to return. */
__attribute__((format(printf, 1, 2))) static inline int
tap_skip_all(const char *fmt, ...)
{
    va_list ap;
    printf("1..0 # SKIP ");
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf("\n");
    fflush(stdout);
    return 0;
}

/* tap_done(): print the plan, counted from the checks made, and return the
 * exit status for main to return: 1 if any check failed, or if none was
 * made at all (a test that checks nothing must not pass), 0 otherwise. */
static inline int tap_done(void)
{
    if (tap_count == 0)
        check(0, "the program made no checks");
    printf("1..%d\n", tap_count);
    fflush(stdout);
    return tap_failed ? 1 : 0;
}

#endif
