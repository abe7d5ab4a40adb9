/*
 * test_tile_cache.c - the shared decoded-tile cache (lib/render/tile_cache.h)
 * and decoders sharing it: single flight (threads that want a tile being
 * filled wait for that one fill; a failed fill reaches every waiter), the
 * byte budget (LRU eviction, pinned tiles kept), forgetting a store, and N
 * decoders over one cache decoding each tile exactly once.
 *
 * The waiting threads are observed through the cache's own `waiting`
 * counter, never through sleeps.
 */
#include <pthread.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "codec/tile.h"
#include "encode/stream_encoder.h"
#include "render/store_decoder.h"
#include "render/tile_cache.h"
#include "store_fixture.h"
#include "test_env.h"
#include "util.h"

#define NTHREADS 6
#define TB 1000 /* bytes of a test tile */

static char dir[128];

struct waiter {
    struct gv_tile_cache *c;
    struct gv_tile_key key;
    int rc;
    struct gv_tile_entry *e;
    uint8_t first;           /* the first pixel seen */
    struct gv_error err;
};

static void *acquire_thread(void *arg)
{
    struct waiter *w = arg;
    w->rc = gv_tile_cache_acquire(w->c, &w->key, TB, &w->e, &w->err);
    if (w->rc > 0) {
        w->first = gv_tile_entry_pixels(w->e)[0];
        gv_tile_cache_release(w->c, w->e);
    }
    return NULL;
}

static struct gv_tile_cache_stats stats(struct gv_tile_cache *c)
{
    struct gv_tile_cache_stats s;
    gv_tile_cache_stats(c, &s);
    return s;
}

/* Start NTHREADS acquiring k and return once all of them wait. */
static void start_waiters(struct gv_tile_cache *c, const struct gv_tile_key *k,
                          struct waiter *w, pthread_t *th)
{
    for (int i = 0; i < NTHREADS; i++) {
        w[i] = (struct waiter){.c = c, .key = *k, .rc = 99};
        if (pthread_create(&th[i], NULL, acquire_thread, &w[i]) != 0)
            fail("pthread_create");
    }
    while (stats(c).waiting != NTHREADS)
        sched_yield();
}

static void test_single_flight(void)
{
    struct gv_tile_cache *c = gv_tile_cache_new(100 * TB);
    struct gv_tile_key k = {1, 0, 3, 4};
    struct gv_tile_entry *e;
    struct gv_error err = {0};
    check(gv_tile_cache_acquire(c, &k, TB, &e, &err) == 0, "first acquire claims");
    struct waiter w[NTHREADS];
    pthread_t th[NTHREADS];
    start_waiters(c, &k, w, th);
    memset(gv_tile_entry_pixels(e), 0xab, TB);
    gv_tile_cache_publish(c, e);
    gv_tile_cache_release(c, e);
    int all = 1;
    for (int i = 0; i < NTHREADS; i++) {
        pthread_join(th[i], NULL);
        all = all && w[i].rc == 1 && w[i].e == e && w[i].first == 0xab;
    }
    check(all, "%d waiting threads share the one fill", NTHREADS);
    struct gv_tile_cache_stats s = stats(c);
    check(s.misses == 1 && s.waits == NTHREADS && s.hits == NTHREADS &&
          s.waiting == 0, "one fill for %d requests: misses %llu (want 1), "
          "waits %llu, hits %llu", NTHREADS + 1, (unsigned long long)s.misses,
          (unsigned long long)s.waits, (unsigned long long)s.hits);
    check(s.entries == 1 && s.bytes == TB, "one entry of %d bytes kept", TB);

    /* A failed fill reaches every waiter, and the tile can be claimed again. */
    struct gv_tile_key k2 = {1, 0, 5, 5};
    check(gv_tile_cache_acquire(c, &k2, TB, &e, &err) == 0, "claim a second tile");
    start_waiters(c, &k2, w, th);
    struct gv_error boom = {0};
    gv_fail(&boom, GV_ECORRUPT, "boom");
    gv_tile_cache_fail(c, e, &boom);
    all = 1;
    for (int i = 0; i < NTHREADS; i++) {
        pthread_join(th[i], NULL);
        all = all && w[i].rc == -1 && w[i].e == NULL &&
              w[i].err.code == GV_ECORRUPT && !strcmp(w[i].err.text, "boom");
    }
    check(all, "every waiter gets the fill's error");
    s = stats(c);
    check(s.entries == 1 && s.bytes == TB, "the failed tile left the cache");
    check(gv_tile_cache_acquire(c, &k2, TB, &e, &err) == 0,
          "a failed tile is claimed again by the next request");
    gv_tile_cache_fail(c, e, &boom);
    gv_tile_cache_free(c);
}

/* Acquire k: claim and fill it with `v` if missing.  Returns acquire's
 * 1 (hit) or 0 (filled here); the entry stays pinned in *e. */
static int get(struct gv_tile_cache *c, uint64_t store, uint32_t tx,
               uint8_t v, struct gv_tile_entry **e)
{
    struct gv_tile_key k = {store, 0, tx, 0};
    struct gv_error err = {0};
    int rc = gv_tile_cache_acquire(c, &k, TB, e, &err);
    if (rc < 0)
        fail("acquire: %s", err.text);
    if (rc == 0) {
        memset(gv_tile_entry_pixels(*e), v, TB);
        gv_tile_cache_publish(c, *e);
    }
    return rc;
}

static int touch(struct gv_tile_cache *c, uint64_t store, uint32_t tx)
{
    struct gv_tile_entry *e;
    int rc = get(c, store, tx, (uint8_t)tx, &e);
    gv_tile_cache_release(c, e);
    return rc;
}

static void test_budget(void)
{
    struct gv_tile_cache *c = gv_tile_cache_new(10 * TB);
    int within = 1;
    for (uint32_t i = 0; i < 100; i++) {
        touch(c, 1, i);
        touch(c, 1, 0); /* kept recent: never evicted */
        within = within && stats(c).bytes <= 10 * TB;
    }
    struct gv_tile_cache_stats s = stats(c);
    check(within, "never above the budget of 10 tiles");
    check(s.entries == 10 && s.bytes == 10 * TB && s.evictions == 90 &&
          s.misses == 100, "100 tiles through 10 places: %llu entries, %llu "
          "evictions, %llu misses", (unsigned long long)s.entries,
          (unsigned long long)s.evictions, (unsigned long long)s.misses);
    check(touch(c, 1, 0) == 1, "the tile used all along is still there");
    check(touch(c, 1, 99) == 1 && touch(c, 1, 91) == 1, "the 9 latest are there");
    check(touch(c, 1, 90) == 0, "the 10th latest was evicted");

    /* Pinned tiles are never evicted: the budget gives way, then comes back. */
    struct gv_tile_entry *pin[12];
    for (uint32_t i = 0; i < 12; i++)
        get(c, 2, i, 7, &pin[i]);
    s = stats(c);
    check(s.bytes == 12 * TB && s.entries == 12, "12 pinned tiles stay (%llu "
          "bytes)", (unsigned long long)s.bytes);
    for (int i = 0; i < 12; i++)
        gv_tile_cache_release(c, pin[i]);
    s = stats(c);
    check(s.bytes == 10 * TB, "released: back to the budget (%llu bytes)",
          (unsigned long long)s.bytes);

    /* Forgetting a store drops its tiles only. */
    gv_tile_cache_free(c);
    c = gv_tile_cache_new(10 * TB);
    for (uint32_t i = 0; i < 4; i++) {
        touch(c, 7, i);
        touch(c, 8, i);
    }
    gv_tile_cache_forget(c, 7);
    s = stats(c);
    check(s.entries == 4 && touch(c, 8, 0) == 1 && touch(c, 7, 0) == 0,
          "forget(7) drops store 7's 4 tiles, keeps store 8's");

    /* A budget of 0 keeps nothing once released. */
    gv_tile_cache_free(c);
    c = gv_tile_cache_new(0);
    touch(c, 1, 1);
    check(stats(c).bytes == 0 && touch(c, 1, 1) == 0, "budget 0 keeps nothing");
    gv_tile_cache_free(c);
}

struct decode_job {
    struct gv_decoder *d;
    int rc;
    const uint8_t *px;
    uint8_t *copy;
    size_t bytes;
};

static void *decode_thread(void *arg)
{
    struct decode_job *j = arg;
    struct gv_error err = {0};
    j->rc = gv_decoder_tile(j->d, 0, 1, 1, &j->px, &err);
    if (j->rc == 0) {
        j->copy = malloc(j->bytes);
        memcpy(j->copy, j->px, j->bytes);
    }
    return NULL;
}

/* Threads decoding random tiles of levels 0 and 1 through one small
 * shared cache, each compared with the reference pixels. */
struct stress_job {
    struct gv_decoder *d;
    const struct gv_geometry *g;
    uint8_t **ref;           /* [level * 64 + ty * 8 + tx] */
    size_t bytes;
    unsigned seed;
    int bad;
};

static void *stress_thread(void *arg)
{
    struct stress_job *j = arg;
    struct gv_error err = {0};
    for (int i = 0; i < 300; i++) {
        int level = rand_r(&j->seed) % 2;
        uint32_t tx = (uint32_t)rand_r(&j->seed) % j->g->level[level].tiles_x;
        uint32_t ty = (uint32_t)rand_r(&j->seed) % j->g->level[level].tiles_y;
        const uint8_t *px;
        if (gv_decoder_tile(j->d, level, tx, ty, &px, &err) < 0 ||
            memcmp(px, j->ref[level * 64 + ty * 8 + tx], j->bytes))
            j->bad++;
    }
    return NULL;
}

static void test_stress(struct gv_store *s)
{
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const size_t tb = gv_tile_bytes(g->channels);
    uint8_t *ref[128] = {0};
    struct gv_decoder *r = gv_decoder_new(s, 64u << 20);
    struct gv_error err = {0};
    for (int k = 0; k < 2; k++)
        for (uint32_t ty = 0; ty < g->level[k].tiles_y; ty++)
            for (uint32_t tx = 0; tx < g->level[k].tiles_x; tx++) {
                const uint8_t *px;
                if (gv_decoder_tile(r, k, tx, ty, &px, &err) < 0)
                    fail("reference: %s", err.text);
                ref[k * 64 + ty * 8 + tx] = malloc(tb);
                memcpy(ref[k * 64 + ty * 8 + tx], px, tb);
            }
    gv_decoder_free(r);
    struct gv_tile_cache *c = gv_tile_cache_new(3 * tb);
    struct stress_job j[4];
    pthread_t th[4];
    for (int i = 0; i < 4; i++) {
        j[i] = (struct stress_job){.d = gv_decoder_new_shared(s, c, 5), .g = g,
                                   .ref = ref, .bytes = tb, .seed = 17u + (unsigned)i};
        if (!j[i].d || pthread_create(&th[i], NULL, stress_thread, &j[i]) != 0)
            fail("stress thread");
    }
    int bad = 0;
    for (int i = 0; i < 4; i++) {
        pthread_join(th[i], NULL);
        bad += j[i].bad;
        gv_decoder_free(j[i].d);
    }
    struct gv_tile_cache_stats st = stats(c);
    check(bad == 0, "4 threads x 300 random tiles through a 3-tile cache: all "
          "exact (%d wrong; %llu decodes, %llu hits, %llu waits, %llu evictions)",
          bad, (unsigned long long)st.misses, (unsigned long long)st.hits,
          (unsigned long long)st.waits, (unsigned long long)st.evictions);
    check(st.bytes <= 3 * tb && st.waiting == 0,
          "after them: within the budget, nobody waiting");
    gv_tile_cache_free(c);
    for (int i = 0; i < 128; i++)
        free(ref[i]);
}

static void test_decoders(void)
{
    struct gv_store *s = fixture_store(dir, "rgb.gv", "synth:1500x1100", 1);
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const size_t tb = gv_tile_bytes(g->channels);
    struct gv_tile_cache *c = gv_tile_cache_new(64u << 20);
    struct decode_job j[NTHREADS];
    pthread_t th[NTHREADS];
    for (int i = 0; i < NTHREADS; i++) {
        j[i] = (struct decode_job){.d = gv_decoder_new_shared(s, c, 42),
                                   .rc = -1, .bytes = tb};
        if (!j[i].d || pthread_create(&th[i], NULL, decode_thread, &j[i]) != 0)
            fail("decoder thread");
    }
    for (int i = 0; i < NTHREADS; i++)
        pthread_join(th[i], NULL);
    /* The reference: a decoder with its own cache. */
    struct gv_decoder *ref = gv_decoder_new(s, 0);
    const uint8_t *want;
    struct gv_error err = {0};
    if (gv_decoder_tile(ref, 0, 1, 1, &want, &err) < 0)
        fail("reference decode: %s", err.text);
    int same = 1;
    for (int i = 0; i < NTHREADS; i++)
        same = same && j[i].rc == 0 && j[i].px == j[0].px &&
               !memcmp(j[i].copy, want, tb);
    check(same, "%d decoders over one cache get the reference pixels, from "
          "one buffer", NTHREADS);
    struct gv_tile_cache_stats st = stats(c);
    check(st.misses == (uint64_t)g->root + 1 && st.entries == (uint64_t)g->root + 1,
          "tile 0/1/1 and its %d ancestors decoded once each for %d threads "
          "(misses %llu)", g->root, NTHREADS, (unsigned long long)st.misses);
    check(st.hits + st.misses == (uint64_t)NTHREADS + g->root,
          "the other %d threads were served from the cache or waited (hits "
          "%llu, waits %llu)", NTHREADS - 1, (unsigned long long)st.hits,
          (unsigned long long)st.waits);
    for (int i = 0; i < NTHREADS; i++) {
        gv_decoder_free(j[i].d);
        free(j[i].copy);
    }
    gv_decoder_free(ref);

    /* A whole-level region through a cache of 3 tiles stays within it once
     * the decoder lets go, and matches a private decoder's region. */
    gv_tile_cache_free(c);
    c = gv_tile_cache_new(3 * tb);
    struct gv_decoder *d = gv_decoder_new_shared(s, c, 1);
    struct gv_decoder *big = gv_decoder_new(s, 64u << 20);
    size_t n = (size_t)g->width * g->height * g->channels;
    uint8_t *a = malloc(n), *b = malloc(n);
    check(gv_decode_region(d, 0, 0, 0, g->width, g->height, a, &err) == 0 &&
          gv_decode_region(big, 0, 0, 0, g->width, g->height, b, &err) == 0 &&
          !memcmp(a, b, n), "level 0 through a 3-tile cache is the same image");
    gv_decoder_free(d);
    st = stats(c);
    check(st.bytes <= 3 * tb && st.evictions > 0,
          "a 3-tile cache holds %llu bytes (<= %zu) after %llu evictions",
          (unsigned long long)st.bytes, 3 * tb, (unsigned long long)st.evictions);
    free(a);
    free(b);
    gv_decoder_free(big);
    gv_tile_cache_free(c);

    /* A level-0 tile a region covers whole is decoded outside the cache,
     * into a lent buffer; one covered in part goes into the cache. */
    c = gv_tile_cache_new(64u << 20);
    d = gv_decoder_new_shared(s, c, 1);
    big = gv_decoder_new(s, 64u << 20);
    uint8_t ra[GV_STEP * GV_STEP * 4], rb[GV_STEP * GV_STEP * 4];
    int same_tile = gv_decode_region(d, 0, GV_STEP, GV_STEP, GV_STEP, GV_STEP, ra, &err) == 0 &&
                    gv_decode_region(big, 0, GV_STEP, GV_STEP, GV_STEP, GV_STEP, rb, &err) == 0 &&
                    !memcmp(ra, rb, (size_t)GV_STEP * GV_STEP * g->channels);
    gv_decoder_idle(d);
    st = stats(c);
    check(same_tile && st.lent == 1 && st.misses == (uint64_t)g->root,
          "a whole level-0 tile: the same pixels, lent once, only its %d "
          "ancestors cached (misses %llu)", g->root, (unsigned long long)st.misses);
    check(gv_decode_region(d, 0, GV_STEP / 2, GV_STEP / 2, GV_STEP, GV_STEP, ra, &err) == 0 &&
              stats(c).lent == 1 && stats(c).misses > st.misses,
          "a region across level-0 tiles caches them");
    gv_decoder_free(d);
    gv_decoder_free(big);
    gv_tile_cache_free(c);

    /* A decoder pins the tile it returned last, and nothing else; idle, it
     * pins nothing. */
    c = gv_tile_cache_new(0);
    d = gv_decoder_new_shared(s, c, 1);
    const uint8_t *px;
    int rc = gv_decoder_tile(d, 0, 2, 1, &px, &err);
    st = stats(c);
    check(rc == 0 && st.bytes == tb && st.misses == (uint64_t)g->root + 1,
          "budget 0: only the returned tile is held (%llu bytes, %llu decodes)",
          (unsigned long long)st.bytes, (unsigned long long)st.misses);
    gv_decoder_idle(d);
    check(stats(c).bytes == 0 && stats(c).entries == 0, "idle: nothing held");
    gv_decoder_free(d);
    gv_tile_cache_free(c);
    test_stress(s);
    gv_store_close(s);
}

int main(void)
{
    test_tmpdir_new(dir, sizeof dir, "gv-test-tile-cache");
    test_single_flight();
    test_budget();
    test_decoders();
    test_tmpdir_free(dir);
    return tap_done();
}
