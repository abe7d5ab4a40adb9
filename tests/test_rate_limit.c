/*
 * test_rate_limit.c - the token buckets of server/rate_limit.c, with the
 * test's own clock: a burst, then the rate; Retry-After's wait; clients
 * apart; a bucket refills to its burst and no further; a full table
 * gives a new client a full bucket in place of the least recent; many
 * threads take exactly the tokens there are.
 */
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "rate_limit.h"
#include "util.h"

static int takes(struct rate_limit *rl, const char *key, int n, double now)
{
    int ok = 0;
    for (int i = 0; i < n; i++)
        ok += rate_limit_take(rl, key, strlen(key), now, NULL);
    return ok;
}

static void test_bucket(void)
{
    struct rate_limit *rl = rate_limit_new(2, 5, 100, 42);
    if (!rl)
        fail("rate_limit_new");
    check(takes(rl, "10.0.0.1", 8, 100.0) == 5, "a burst of 5: 5 of 8 allowed");
    double wait = -1;
    int refused = !rate_limit_take(rl, "10.0.0.1", 8, 100.0, &wait);
    check(refused && wait > 0.499 && wait < 0.501,
          "the next one waits half a second at 2 a second (%g)", wait);
    check(takes(rl, "10.0.0.2", 5, 100.0) == 5, "another client has its own bucket");
    check(takes(rl, "10.0.0.1", 3, 101.0) == 2, "one second later: 2 more");
    check(takes(rl, "10.0.0.1", 10, 1000.0) == 5, "a long rest refills to the burst, no more");
    check(takes(rl, "10.0.0.1", 1, 999.0) == 0, "a clock that goes back gives nothing");
    rate_limit_free(rl);
    check(!rate_limit_new(0, 5, 10, 1) && !rate_limit_new(1, 0.5, 10, 1),
          "a rate of 0 or a burst under 1 is refused");
}

/* More clients than the table keeps: the oldest go, and a client whose
 * bucket went starts again full. */
static void test_table(void)
{
    struct rate_limit *rl = rate_limit_new(1, 2, 1, 7); /* 64 sets x 4 */
    char key[32];
    check(takes(rl, "first", 3, 0.0) == 2, "first: its burst");
    for (int i = 0; i < 4096; i++) {
        snprintf(key, sizeof key, "c%d", i);
        rate_limit_take(rl, key, strlen(key), 0.5, NULL);
    }
    check(takes(rl, "first", 1, 0.6) == 1, "evicted by newer clients, first starts full");
    rate_limit_free(rl);
}

struct worker {
    struct rate_limit *rl;
    int ok;
};

static void *hammer(void *arg)
{
    struct worker *w = arg;
    for (int i = 0; i < 1000; i++)
        w->ok += rate_limit_take(w->rl, "shared", 6, 50.0, NULL);
    return NULL;
}

static void test_threads(void)
{
    struct rate_limit *rl = rate_limit_new(1, 300, 100, 9);
    struct worker w[4];
    pthread_t t[4];
    for (int i = 0; i < 4; i++) {
        w[i] = (struct worker){rl, 0};
        pthread_create(&t[i], NULL, hammer, &w[i]);
    }
    int total = 0;
    for (int i = 0; i < 4; i++) {
        pthread_join(t[i], NULL);
        total += w[i].ok;
    }
    check(total == 300, "4 threads at one instant take the burst of 300 exactly (%d)", total);
    rate_limit_free(rl);
}

int main(void)
{
    test_bucket();
    test_table();
    test_threads();
    return tap_done();
}
