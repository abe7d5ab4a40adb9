/*
 * rate_limit.c - token buckets per client (see rate_limit.h).
 */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>

#include "rate_limit.h"

#define WAYS 4           /* buckets a set */
#define SETS_A_LOCK 64

struct bucket {
    uint64_t fp;         /* the key's hash; 0: empty */
    double tokens;
    double last;         /* time of its last request */
};

struct rate_limit {
    double rate, burst;
    uint64_t seed;
    size_t nsets;        /* a power of two */
    struct bucket *b;    /* nsets * WAYS */
    size_t nlocks;
    pthread_mutex_t *lock;
};

/* FNV-1a over the seed and the key, then a finalising mix (the key's
 * bytes are the client's, the seed is not). */
static uint64_t hash(uint64_t seed, const void *key, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull ^ seed;
    const unsigned char *p = key;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h ? h : 1;
}

struct rate_limit *rate_limit_new(double rate, double burst, size_t clients,
                                  uint64_t seed)
{
    if (!(rate > 0) || !(burst >= 1))
        return NULL;
    struct rate_limit *rl = calloc(1, sizeof *rl);
    if (!rl)
        return NULL;
    rl->rate = rate;
    rl->burst = burst;
    size_t sets = 64;
    while (sets * WAYS < clients && sets < ((size_t)1 << 24))
        sets <<= 1;
    rl->nsets = sets;
    rl->nlocks = sets / SETS_A_LOCK;
    rl->b = calloc(sets * WAYS, sizeof *rl->b);
    rl->lock = calloc(rl->nlocks, sizeof *rl->lock);
    if (!rl->b || !rl->lock) {
        free(rl->b);
        free(rl->lock);
        free(rl);
        return NULL;
    }
    for (size_t i = 0; i < rl->nlocks; i++)
        pthread_mutex_init(&rl->lock[i], NULL);
    if (!seed && getrandom(&seed, sizeof seed, 0) != (ssize_t)sizeof seed)
        seed = (uint64_t)(uintptr_t)rl * 0x9e3779b97f4a7c15ull;
    rl->seed = seed;
    return rl;
}

void rate_limit_free(struct rate_limit *rl)
{
    if (!rl)
        return;
    for (size_t i = 0; i < rl->nlocks; i++)
        pthread_mutex_destroy(&rl->lock[i]);
    free(rl->lock);
    free(rl->b);
    free(rl);
}

int rate_limit_take(struct rate_limit *rl, const void *key, size_t n, double now,
                    double *retry_after)
{
    const uint64_t fp = hash(rl->seed, key, n);
    const size_t set = (size_t)(fp >> 20) & (rl->nsets - 1);
    struct bucket *s = rl->b + set * WAYS, *e = NULL;
    pthread_mutex_t *lock = &rl->lock[set / SETS_A_LOCK];
    pthread_mutex_lock(lock);
    for (int w = 0; w < WAYS && !e; w++)
        if (s[w].fp == fp)
            e = &s[w];
    if (!e) {   /* new: an empty way, else the least recent */
        e = &s[0];
        for (int w = 0; w < WAYS; w++) {
            if (!s[w].fp) {
                e = &s[w];
                break;
            }
            if (s[w].last < e->last)
                e = &s[w];
        }
        *e = (struct bucket){.fp = fp, .tokens = rl->burst, .last = now};
    }
    if (now > e->last) {
        e->tokens += (now - e->last) * rl->rate;
        if (e->tokens > rl->burst)
            e->tokens = rl->burst;
        e->last = now;
    }
    int ok = e->tokens >= 1;
    if (ok)
        e->tokens -= 1;
    else if (retry_after)
        *retry_after = (1 - e->tokens) / rl->rate;
    pthread_mutex_unlock(lock);
    return ok;
}
