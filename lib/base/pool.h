/*
 * pool.h - a fixed pool of worker threads that runs one batch of
 * independent items at a time ("parallel for").
 *
 * The calling thread works too, so a pool of n uses n threads in all.
 * Items carry the index of the worker running them, so each worker can own
 * scratch memory without locks.
 */
#ifndef GV_POOL_H
#define GV_POOL_H

#include <stddef.h>

struct gv_pool;

typedef void (*gv_pool_fn)(void *ctx, size_t item, int worker);

/* A pool of `threads` workers (1 = run everything on the caller).  Returns
 * NULL if threads cannot be created. */
struct gv_pool *gv_pool_new(int threads);

/* Stop and join the workers.  NULL does nothing. */
void gv_pool_free(struct gv_pool *p);

/* Number of workers, the caller included. */
int gv_pool_size(const struct gv_pool *p);

/* Run fn(ctx, i, worker) for every i in [0, count) and return when all are
 * done.  Only one thread may call gv_pool_run at a time. */
void gv_pool_run(struct gv_pool *p, gv_pool_fn fn, void *ctx, size_t count);

/* Number of online CPUs (at least 1). */
int gv_cpu_count(void);

#endif
