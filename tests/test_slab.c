/*
 * test_slab.c - the large-buffer slab (lib/base/slab.h): size classes,
 * slots reused without a new mapping, chunks unmapped when their slots are
 * all back (one empty chunk kept), buffers that do not overlap and keep
 * what is written in them, sizes left to malloc, and four threads taking
 * and giving back buffers of three sizes at once.
 */
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/slab.h"
#include "util.h"

#define KIB ((size_t)1 << 10)
#define MIB ((size_t)1 << 20)

static struct gv_slab_stats stats(struct gv_slab *s)
{
    struct gv_slab_stats st;
    gv_slab_stats(s, &st);
    return st;
}

static void test_classes(void)
{
    /* 512 x 512 tiles of 1, 3, 4, 6 and 8 bytes a pixel fill a slot */
    static const size_t exact[] = {256 * KIB, 768 * KIB, 1 * MIB, 1536 * KIB, 2 * MIB};
    int ok = 1;
    for (size_t i = 0; i < sizeof exact / sizeof exact[0]; i++)
        ok &= gv_slab_slot_bytes(exact[i]) == exact[i];
    check(ok, "whole 512x512 tiles of 1, 3, 4, 6, 8 bytes a pixel fill their slot");
    check(gv_slab_slot_bytes(768 * KIB + 1) == 896 * KIB,
          "a byte over 768 KiB takes the next class, 896 KiB");
    check(gv_slab_slot_bytes(512 * 280 * 3) == 448 * KIB,
          "an edge tile of 512x280x3 takes 448 KiB");
    check(gv_slab_slot_bytes(7 * MIB + 1) == 8 * MIB, "just over 7 MiB takes 8 MiB");
    check(gv_slab_slot_bytes(4 * KIB) == 4 * KIB && gv_slab_slot_bytes(9 * MIB) == 9 * MIB,
          "sizes below 64 KiB and above 8 MiB are left to malloc");
    int worst = 1;
    for (size_t b = 64 * KIB; b <= 8 * MIB; b += 4093) {
        size_t z = gv_slab_slot_bytes(b);
        worst &= z >= b && (z - b) * 4 <= b;
    }
    check(worst, "no size from 64 KiB to 8 MiB takes more than a quarter over it");
}

static void test_reuse(void)
{
    struct gv_slab *s = gv_slab_new();
    size_t tile = 768 * KIB;
    uint8_t *a[5];
    for (int i = 0; i < 5; i++) {
        a[i] = gv_slab_get(s, tile);
        memset(a[i], 0x10 + i, tile);
    }
    struct gv_slab_stats st = stats(s);
    check(st.chunks == 1 && st.mapped == 4 * MIB && st.used == 5 * tile,
          "five 768 KiB buffers fill one 4 MiB chunk (chunks %llu, mapped %llu)",
          (unsigned long long)st.chunks, (unsigned long long)st.mapped);
    int apart = 1;
    for (int i = 0; i < 5; i++) {
        apart &= ((uintptr_t)a[i] & 63) == 0;
        for (size_t j = 0; j < tile; j += 4096)
            apart &= a[i][j] == 0x10 + i;
    }
    check(apart, "the buffers are aligned and hold what was written, none overlapping");
    uint8_t *b = gv_slab_get(s, tile);
    check(stats(s).chunks == 2, "a sixth maps a second chunk");
    gv_slab_put(s, a[2], tile);
    uint8_t *c = gv_slab_get(s, tile);
    check(c == a[2] && stats(s).maps == 2, "a slot given back is the next one taken, no new mapping");
    gv_slab_put(s, b, tile);
    st = stats(s);
    check(st.chunks == 2 && st.mapped == 8 * MIB,
          "the second chunk, empty, is kept for the next one");
    a[2] = c;
    for (int i = 0; i < 5; i++)
        gv_slab_put(s, a[i], tile);
    st = stats(s);
    check(st.chunks == 1 && st.used == 0,
          "when the first chunk empties too, one empty chunk stays mapped (chunks %llu)",
          (unsigned long long)st.chunks);
    size_t five = 512 * 512 * 5;   /* 1.25 MiB slots, 4 MiB chunks too */
    uint8_t *d = gv_slab_get(s, five);
    st = stats(s);
    check(d && st.maps == 2 && st.chunks == 1,
          "another class of the same chunk size reuses the empty chunk (maps %llu)",
          (unsigned long long)st.maps);
    memset(d, 1, five);
    gv_slab_put(s, d, five);
    uint8_t *small = gv_slab_get(s, 1000), *large = gv_slab_get(s, 9 * MIB);
    check(small && large && ((uintptr_t)small & 63) == 0 && ((uintptr_t)large & 63) == 0 &&
              stats(s).used == 0,
          "small and large sizes come from malloc, aligned, outside the slots");
    memset(small, 2, 1000);
    memset(large, 3, 9 * MIB);
    gv_slab_put(s, small, 1000);
    gv_slab_put(s, large, 9 * MIB);
    gv_slab_put(s, NULL, tile);
    gv_slab_free(s);
    gv_slab_free(NULL);
    check(1, "freeing the slab and NULL");
}

struct worker {
    struct gv_slab *s;
    uint64_t seed;
    int bad;
};

static void *churn(void *arg)
{
    static const size_t sizes[] = {256 * KIB, 768 * KIB, 512 * 280 * 3};
    struct worker *w = arg;
    enum { HELD = 12 };
    uint8_t *held[HELD] = {0};
    size_t held_bytes[HELD] = {0};
    uint8_t mark[HELD] = {0};
    for (int round = 0; round < 3000; round++) {
        int i = (int)(test_rand(&w->seed) % HELD);
        if (held[i]) {
            /* what this thread wrote is still there: no one else has the slot */
            w->bad |= held[i][0] != mark[i] || held[i][held_bytes[i] - 1] != mark[i];
            gv_slab_put(w->s, held[i], held_bytes[i]);
        }
        held_bytes[i] = sizes[test_rand(&w->seed) % 3];
        held[i] = gv_slab_get(w->s, held_bytes[i]);
        if (!held[i]) {
            w->bad = 1;
            break;
        }
        mark[i] = (uint8_t)test_rand(&w->seed);
        held[i][0] = held[i][held_bytes[i] - 1] = mark[i];
    }
    for (int i = 0; i < HELD; i++)
        if (held[i])
            gv_slab_put(w->s, held[i], held_bytes[i]);
    return NULL;
}

static void test_threads(void)
{
    struct gv_slab *s = gv_slab_new();
    pthread_t th[4];
    struct worker w[4];
    for (int i = 0; i < 4; i++) {
        w[i] = (struct worker){s, 0x9E3779B97F4A7C15ull + (uint64_t)i, 0};
        pthread_create(&th[i], NULL, churn, &w[i]);
    }
    int bad = 0;
    for (int i = 0; i < 4; i++) {
        pthread_join(th[i], NULL);
        bad |= w[i].bad;
    }
    struct gv_slab_stats st = stats(s);
    check(!bad, "four threads never found another's mark in their buffers");
    check(st.used == 0 && st.chunks <= 1,
          "all given back: nothing used, at most the kept chunk mapped (chunks %llu)",
          (unsigned long long)st.chunks);
    gv_slab_free(s);
}

int main(void)
{
    test_classes();
    test_reuse();
    test_threads();
    return tap_done();
}
