/*
 * test_gpu_cache.c - recursive parent pulling on the GPU (lib/gpu/gpu_cache.c):
 * every tile of a few stores, asked for in an order that defeats a small
 * byte budget (finest level first, then a shuffled pass), read back from
 * the GPU and compared bit for bit with the CPU reference decoder.  The
 * budget forces evictions and re-pulls of ancestors; the cache must stay
 * within it, and a failing fetch or a truncated tile buffer must fail that
 * one request cleanly and leave the cache usable.  A range prepared in one
 * batch (gv_gpu_cache_prepare) must then be read as hits.  Skips (77 semantics:
 * "1..0 # SKIP") when no EGL context can be made.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "render/store_decoder.h"
#include "encode/stream_encoder.h"
#include "gpu/gpu.h"
#include "gpu/gpu_cache.h"
#include "gpu/gpu_decode.h"
#include "store/store_read.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

struct source {
    struct gv_store *s;
    int channels;
    int fail_level;          /* fault injection: this tile fails ... */
    uint32_t fail_tx, fail_ty;
    int truncate;            /* ... by truncation (1) or a fetch error (0) */
    uint64_t calls;
};

static int fetch(void *ctx, int level, uint32_t tx, uint32_t ty, uint8_t **buf,
                 size_t *len, struct gv_error *err)
{
    struct source *src = ctx;
    src->calls++;
    if (level == src->fail_level && tx == src->fail_tx && ty == src->fail_ty &&
        !src->truncate)
        return gv_fail(err, GV_EIO, "test: injected fetch failure");
    uint8_t *page;
    size_t plen, tlen;
    const uint8_t *t;
    if (gv_store_read_page(src->s, level, tx / 8, ty / 8, &page, &plen, err) < 0)
        return -1;
    if (gv_page_tile(page, plen, src->channels, (int)(tx % 8), (int)(ty % 8), &t,
                     &tlen, err) < 0) {
        free(page);
        return -1;
    }
    if (level == src->fail_level && tx == src->fail_tx && ty == src->fail_ty)
        tlen -= 4;
    *buf = malloc(tlen ? tlen : 1);
    if (!*buf) {
        free(page);
        return gv_fail(err, GV_ENOMEM, "test: out of memory");
    }
    memcpy(*buf, t, tlen);
    *len = tlen;
    free(page);
    return 0;
}

struct tile_id {
    int level;
    uint32_t tx, ty;
};

/* Every tile of g, finest level first, then the same list shuffled:
 * 2 * *n entries (*n: the tiles, the root included), malloc'ed. */
static struct tile_id *tile_order(const struct gv_geometry *g, size_t *count)
{
    size_t n = 1;
    for (int k = 0; k < g->root; k++)
        n += (size_t)g->level[k].tiles_x * g->level[k].tiles_y;
    struct tile_id *ids = malloc(2 * n * sizeof *ids);
    if (!ids)
        fail("out of memory");
    size_t m = 0;
    for (int k = 0; k < g->root; k++)
        for (uint32_t ty = 0; ty < g->level[k].tiles_y; ty++)
            for (uint32_t tx = 0; tx < g->level[k].tiles_x; tx++)
                ids[m++] = (struct tile_id){k, tx, ty};
    ids[m++] = (struct tile_id){g->root, 0, 0};
    uint64_t seed = 12345;
    for (size_t i = 0; i < n; i++)
        ids[n + i] = ids[i];
    for (size_t i = n - 1; i > 0; i--) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        size_t j = (size_t)(seed >> 33) % (i + 1);
        struct tile_id t = ids[n + i];
        ids[n + i] = ids[n + j];
        ids[n + j] = t;
    }
    *count = n;
    return ids;
}

/* A batch: every level-0 tile prepared at once (their ancestors with
 * them), then read as hits, equal to the CPU decoder; with a budget too
 * small for them, prepare decodes nothing but the root.  n: the store's
 * tiles, the root included. */
static void check_prepare(struct gv_gpu_decoder *gd, const struct gv_geometry *g,
                          const uint8_t *root, uint32_t rw, uint32_t rh,
                          struct source *src, struct gv_decoder *cpu, size_t n,
                          const char *name)
{
    struct gv_error err = {0};
    const size_t tb = gv_tile_bytes(g->channels);
    const struct gv_gpu_tiles tiles = gv_gpu_tiles_image(gd, g->channels);
    uint8_t *px = malloc(tb);
    const uint8_t *ref;
    struct gv_gpu_cache *gc;
    gc = gv_gpu_cache_new(&tiles, g, root, rw, rh, n * GV_GPU_TILE_BYTES, fetch, src, &err);
    if (!gc)
        fail("gpu cache: %s", err.text);
    const uint32_t lx = g->level[0].tiles_x, ly = g->level[0].tiles_y;
    int prc = gv_gpu_cache_prepare(gc, 0, 0, 0, lx, ly, &err);   /* clipped */
    struct gv_gpu_cache_stats ps;
    gv_gpu_cache_stats(gc, &ps);
    int bad = 0;
    for (uint32_t ty = 0; ty < ly; ty++)
        for (uint32_t tx = 0; tx < lx; tx++) {
            if (gv_gpu_cache_read(gc, 0, tx, ty, px, &err) < 0 ||
                gv_decoder_tile(cpu, 0, tx, ty, &ref, &err) < 0)
                fail("prepared %u/%u: %s", tx, ty, err.text);
            bad += memcmp(px, ref, tb) != 0;
        }
    struct gv_gpu_cache_stats after;
    gv_gpu_cache_stats(gc, &after);
    check(prc == 0 && ps.decodes == n && ps.fetches == n - 1 && bad == 0 &&
              after.decodes == ps.decodes && after.hits == ps.hits + (uint64_t)lx * ly,
          "%s: prepare decodes all %zu tiles in one batch (%llu decodes, %llu "
          "fetches); the %u level-0 reads then hit, equal to the CPU decoder "
          "(%d differ)", name, n, (unsigned long long)ps.decodes,
          (unsigned long long)ps.fetches, lx * ly, bad);
    gv_gpu_cache_free(gc);
    gc = gv_gpu_cache_new(&tiles, g, root, rw, rh, 2 * GV_GPU_TILE_BYTES, fetch, src, &err);
    if (!gc)
        fail("gpu cache: %s", err.text);
    prc = gv_gpu_cache_prepare(gc, 0, 0, 0, lx - 1, ly - 1, &err);
    gv_gpu_cache_stats(gc, &ps);
    check(prc == 0 && ps.decodes == 1 && ps.fetches == 0,
          "%s: with room for 2 tiles, prepare of %u leaves them to the "
          "per-tile path (%llu decodes: the root)", name, lx * ly,
          (unsigned long long)ps.decodes);

    free(px);
    gv_gpu_cache_free(gc);
}

static void check_store(struct gv_gpu *gpu, const char *input, double psnr,
                        size_t budget_tiles)
{
    char out[256];
    snprintf(out, sizeof out, "%s/c.gv", dir);
    struct gv_encode_opts o;
    gv_encode_opts_default(&o);
    o.target_psnr = psnr;
    struct gv_encode_result r;
    struct gv_error err = {0};
    const char *in[1] = {input};
    if (gv_encode(in, 1, out, &o, &r, &err) < 0)
        fail("encode %s: %s", input, err.text);
    struct gv_store *s = gv_store_open(out, &err);
    if (!s)
        fail("open: %s", err.text);
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int c = g->channels;
    struct gv_decoder *cpu = gv_decoder_new(s, 64u << 20);
    struct gv_gpu_decoder *gd = gv_gpu_decoder_new(gpu, &(struct gv_gpu_decoder_opts){.channels = c}, &err);
    if (!gd)
        fail("gpu decoder: %s", err.text);
    const struct gv_gpu_tiles tiles = gv_gpu_tiles_image(gd, c);
    uint32_t rw, rh;
    const uint8_t *root = gv_store_root(s, 0, &rw, &rh);
    struct source src = {.s = s, .channels = c, .fail_level = -1};
    const size_t budget = budget_tiles * GV_GPU_TILE_BYTES;
    struct gv_gpu_cache *gc = gv_gpu_cache_new(&tiles, g, root, rw, rh, budget,
                                               fetch, &src, &err);
    if (!gc)
        fail("gpu cache: %s", err.text);

    /* All tiles, finest level first (each pulls its whole chain), then the
     * same list shuffled. */
    size_t n;
    struct tile_id *ids = tile_order(g, &n);
    const size_t tb = gv_tile_bytes(c);
    uint8_t *px = malloc(tb);
    int mismatched = 0, over_budget = 0;
    for (size_t i = 0; i < 2 * n; i++) {
        const struct tile_id *t = &ids[i];
        const uint8_t *ref;
        if (gv_gpu_cache_read(gc, t->level, t->tx, t->ty, px, &err) < 0)
            fail("gpu cache %d/%u/%u: %s", t->level, t->tx, t->ty, err.text);
        if (gv_decoder_tile(cpu, t->level, t->tx, t->ty, &ref, &err) < 0)
            fail("cpu %d/%u/%u: %s", t->level, t->tx, t->ty, err.text);
        if (memcmp(px, ref, tb) != 0) {
            if (mismatched++ < 5)
                printf("# tile %d/%u/%u differs\n", t->level, t->tx, t->ty);
        }
        struct gv_gpu_cache_stats st;
        gv_gpu_cache_stats(gc, &st);
        over_budget += st.bytes > (budget > GV_GPU_TILE_BYTES ? budget
                                                              : GV_GPU_TILE_BYTES);
    }
    struct gv_gpu_cache_stats st;
    gv_gpu_cache_stats(gc, &st);
    const char *name = strrchr(input, '/') ? strrchr(input, '/') + 1 : input;
    check(mismatched == 0, "%s: %zu tile requests through the GPU cache equal "
          "the CPU decoder (%d differ)", name, 2 * n, mismatched);
    check(over_budget == 0 && st.evictions > 0 && st.fetches > n - 1 &&
              st.fetches == src.calls,
          "%s: budget of %zu tiles held (%d over); %llu evictions, %llu fetches "
          "for %zu tiled tiles (ancestors re-pulled), %llu hits",
          name, budget_tiles, over_budget, (unsigned long long)st.evictions,
          (unsigned long long)st.fetches, n - 1, (unsigned long long)st.hits);

    /* Faults: a fetch error, then a truncated buffer, on a level-0 tile
     * whose ancestors are fine.  Each request fails alone. */
    gv_gpu_cache_free(gc);
    gc = gv_gpu_cache_new(&tiles, g, root, rw, rh, budget, fetch, &src, &err);
    if (!gc)
        fail("gpu cache: %s", err.text);
    src.fail_level = 0;
    src.fail_tx = g->level[0].tiles_x - 1;
    src.fail_ty = g->level[0].tiles_y - 1;
    uint32_t h;
    gv_error_clear(&err);
    int rc1 = gv_gpu_cache_get(gc, 0, src.fail_tx, src.fail_ty, &h, &err);
    int msg1 = strcmp(err.text, "test: injected fetch failure") == 0;   /* as fetch gave it */
    src.truncate = 1;
    gv_error_clear(&err);
    int rc2 = gv_gpu_cache_get(gc, 0, src.fail_tx, src.fail_ty, &h, &err);
    int code2 = err.code == GV_ECORRUPT;
    src.fail_level = -1;
    const uint8_t *ref;
    int rc3 = gv_gpu_cache_read(gc, 0, src.fail_tx, src.fail_ty, px, &err);
    if (gv_decoder_tile(cpu, 0, src.fail_tx, src.fail_ty, &ref, &err) < 0)
        fail("cpu: %s", err.text);
    gv_error_clear(&err);
    int rc4 = gv_gpu_cache_get(gc, 0, g->level[0].tiles_x, 0, &h, &err);
    check(rc1 < 0 && msg1 && rc2 < 0 && code2 && rc3 == 0 &&
              memcmp(px, ref, tb) == 0 && rc4 < 0 && err.code == GV_ENOTFOUND,
          "%s: a failed fetch and a truncated buffer fail that request only; "
          "the tile decodes once the source heals; outside the grid is not found",
          name);

    gv_gpu_cache_free(gc);
    check_prepare(gd, g, root, rw, rh, &src, cpu, n, name);

    free(px);
    free(ids);
    gv_gpu_decoder_free(gd);
    gv_decoder_free(cpu);
    gv_store_close(s);
    unlink(out);
}

int main(void)
{
    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu) {
        return tap_skip_all("no EGL context: %s", err.text);
    }
    const struct gv_gpu_info *in = gv_gpu_info(gpu);
    printf("# EGL %s platform, %s: %s\n", in->platform, in->api, in->renderer);
    test_tmpdir_new(dir, sizeof dir, "gv-test-gpucache");
    check_store(gpu, "synth:2100x1500", 36.0, 3);      /* 4 levels, 27 tiles */
    check_store(gpu, "synth:1300x2600:gray", 40.0, 2); /* gray, tall */
    check_store(gpu, "synth:3000x700", 30.0, 1);       /* budget below a chain */
    test_tmpdir_free(dir);
    gv_gpu_close(gpu);
    return tap_done();
}
