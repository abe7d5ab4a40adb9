/*
 * test_slab.c - the large-buffer slab (lib/base/slab.h): slot sizes and
 * the table of classes,
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
    /* decoded tiles are 513 x 513 pixels of 1 to 4 bytes, or codes of 2 C */
    int ok = 1;
    for (size_t c = 1; c <= 16; c++) {
        size_t tile = 513 * 513 * c, slot = gv_slab_slot_bytes(tile);
        ok &= slot >= tile && slot - tile < 4096 && slot % 4096 == 0;
    }
    check(ok, "a 513x513 tile of 1 to 16 bytes a pixel takes its size to the next 4 KiB");
    check(gv_slab_slot_bytes(768 * KIB) == 768 * KIB, "768 KiB takes 768 KiB");
    check(gv_slab_slot_bytes(4 * KIB) == 4 * KIB && gv_slab_slot_bytes(17 * MIB) == 17 * MIB,
          "sizes below 64 KiB and above 16 MiB are left to malloc");

    struct gv_slab *s = gv_slab_new();
    void *p[40];
    for (int i = 0; i < 40; i++)
        p[i] = gv_slab_get(s, (size_t)(100 + i) * 4096);
    struct gv_slab_stats st;
    gv_slab_stats(s, &st);
    size_t in_slots = 0;
    for (int i = 0; i < 32; i++)
        in_slots += (size_t)(100 + i) * 4096;
    check(st.used == in_slots, "32 sizes take slots, the 33rd and later come from malloc");
    for (int i = 0; i < 40; i++) {
        memset(p[i], i, (size_t)(100 + i) * 4096);
        gv_slab_put(s, p[i], (size_t)(100 + i) * 4096);
    }
    gv_slab_stats(s, &st);
    check(st.used == 0 && st.chunks == 1, "all given back: one empty chunk left");
    gv_slab_free(s);
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
    uint8_t *small = gv_slab_get(s, 1000), *large = gv_slab_get(s, 17 * MIB);
    check(small && large && ((uintptr_t)small & 63) == 0 && ((uintptr_t)large & 63) == 0 &&
              stats(s).used == 0,
          "small and large sizes come from malloc, aligned, outside the slots");
    memset(small, 2, 1000);
    memset(large, 3, 17 * MIB);
    gv_slab_put(s, small, 1000);
    gv_slab_put(s, large, 17 * MIB);
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
    static const size_t sizes[] = {513 * 513, 513 * 513 * 3, 768 * KIB};
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
