/*
 * rate_limit.h - requests per client: a token bucket for each client
 * (docs/OPERATIONS.md "Rate limits"), so that one scraper or one broken
 * viewer cannot take every render thread from everyone else.
 *
 * A client is a key: its address, or the value of a header a trusted
 * reverse proxy sets (http.c chooses).  Its bucket holds up to `burst`
 * requests and refills at `rate` a second; a request takes one, and is
 * refused (429) when less than one is left.  The buckets live in a table
 * of fixed size, 4-way set associative, whatever the number of clients:
 * a client new to a full set takes the place of the one that asked least
 * recently, and starts with a full bucket.  Keys are hashed with a
 * secret drawn at creation, so that nobody can aim at another client's
 * set.  Thread-safe: one lock per 64 sets.  Times are the caller's
 * (seconds, monotonic), so that tests choose them.
 */
#ifndef GV_SERVER_RATE_LIMIT_H
#define GV_SERVER_RATE_LIMIT_H

#include <stddef.h>
#include <stdint.h>

struct rate_limit;

/* A limiter of `rate` requests a second (> 0) and bursts of `burst`
 * (>= 1) for up to `clients` clients kept at once (rounded up to a power
 * of two, at least 64), seeded with `seed` (0: drawn from getrandom).
 * NULL when out of memory. */
struct rate_limit *rate_limit_new(double rate, double burst, size_t clients,
                                  uint64_t seed);

/* NULL does nothing. */
void rate_limit_free(struct rate_limit *rl);

/* One request of the client `key` (n bytes) at time `now` (seconds): 1
 * when allowed; 0 when refused, with *retry_after (may be NULL) the
 * seconds until one would be. */
int rate_limit_take(struct rate_limit *rl, const void *key, size_t n, double now,
                    double *retry_after);

#endif
