/*
 * test_gpu_decode.c - the GPU decoder (EGL; llvmpipe in CI) against the CPU
 * reference decoder, bit for bit, on every tile of several stores: RGB and
 * gray, a real photograph and procedural images, rates from 0 to 12, every
 * tile layout (fixed, E, the context-coded EX, the transform-coded D of
 * stores encoded with --layouts all, and synthetic D buffers with negative
 * controls), and a store of format version 1.  Tiles
 * are decoded top-down entirely on the GPU (each from its GPU-decoded
 * parent), so an error anywhere would propagate and be seen: one call per
 * tile, and the whole pyramid as one batch (gv_gpu_decode_batch, each tile
 * naming its parent's job).  Skips (77) when no EGL context can be made.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "render/store_decoder.h"
#include "encode/stream_encoder.h"
#include "gpu/gpu.h"
#include "gpu/gpu_decode.h"
#include "store/store_read.h"
#include "store_fixture.h"
#include "dct_fixture.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

static int check_path(struct gv_gpu *gpu, const char *input, const char *out,
                      enum gv_gpu_path path);
static void check_batch(struct gv_gpu *gpu, const char *input, const char *out,
                        enum gv_gpu_path path, int copies);

/* Encode `input` and check it on both shader paths: storage buffers with
 * the compute pass, and WebGL2's GLSL ES 3.00 with textures.  With `dct`
 * the encoder may write layout D (FORMAT.md 4.3), and the store must hold
 * some D tiles. */
static void check_store(struct gv_gpu *gpu, const char *input, double psnr,
                        int max_rate, int dct)
{
    char out[256];
    snprintf(out, sizeof out, "%s/g.gv", dir);
    struct gv_encode_opts o;
    gv_encode_opts_default(&o);
    o.target_psnr = psnr;
    o.max_rate = max_rate;
    o.dct = dct ? GV_LAYOUTS_ALL : GV_LAYOUTS_VQ;
    fixture_encode(out, input, &o);
    const int d = check_path(gpu, input, out, GV_GPU_PATH_COMPUTE);
    check_path(gpu, input, out, GV_GPU_PATH_WEBGL2);
    if (dct) {
        const char *name = strrchr(input, '/') ? strrchr(input, '/') + 1 : input;
        check(d > 0, "%s at %.0f dB with --layouts all: the store holds %d layout-D tiles",
              name, psnr, d);
    }
    /* The gray synthetic store five times over (65 tiles): a batch longer
     * than a group, parents in earlier groups. */
    const int copies = strcmp(input, "synth:1100x1500:gray") == 0 ? 5 : 1;
    check_batch(gpu, input, out, GV_GPU_PATH_COMPUTE, copies);
    check_batch(gpu, input, out, GV_GPU_PATH_WEBGL2, 1);
    unlink(out);
}

/* The store `out`, open, with its CPU decoder (*cpu) and a GPU decoder on
 * `path` (returned). */
static struct gv_gpu_decoder *open_decoders(struct gv_gpu *gpu, const char *out,
                                            enum gv_gpu_path path, struct gv_store **s,
                                            struct gv_decoder **cpu)
{
    struct gv_error err = {0};
    *s = fixture_open(out);
    *cpu = gv_decoder_new(*s, 64u << 20);
    struct gv_gpu_decoder *gd =
        gv_gpu_decoder_new(gpu, &(struct gv_gpu_decoder_opts){
            .channels = gv_store_info(*s)->geometry.channels, .path = path}, &err);
    if (!*cpu || !gd)
        fail("decoders: %s", *cpu ? err.text : "no CPU decoder");
    return gd;
}

/* Decode every tile of the store `out` top-down on `path`, each from its
 * GPU-decoded parent, against the CPU.  Returns the number of layout-D
 * tiles. */
static int check_path(struct gv_gpu *gpu, const char *input, const char *out,
                      enum gv_gpu_path path)
{
    struct gv_error err = {0};
    struct gv_store *s;
    struct gv_decoder *cpu;
    struct gv_gpu_decoder *gd = open_decoders(gpu, out, path, &s, &cpu);
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int c = g->channels;
    const size_t tb = gv_tile_bytes(c);
    uint8_t *px = malloc(tb), *quarter = malloc((size_t)257 * 257 * c);
    /* Handles of the level above, row-major. */
    uint32_t *above = NULL, *cur = NULL;
    uint32_t above_w = 1;
    const uint8_t *root;
    if (gv_decoder_tile(cpu, g->root, 0, 0, &root, &err) < 0)
        fail("root: %s", err.text);
    above = malloc(sizeof *above);
    if (gv_gpu_upload_tile(gd, root, &above[0], &err) < 0)
        fail("upload: %s", err.text);
    int tiles = 0, mismatched = 0, quarter_bad = 0, rates[16] = {0}, coded = 0, ctx = 0;
    int dct = 0;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        cur = malloc(sizeof *cur * l->tiles_x * l->tiles_y);
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                uint8_t *page;
                size_t tlen;
                const uint8_t *buf;
                fixture_tile(s, k, tx, ty, &page, &buf, &tlen);
                dct += gv_tile_is_dct(buf[0]);
                rates[gv_tile_is_dct(buf[0]) ? 0 : buf[0] & 0x0f] += !gv_tile_is_dct(buf[0]);
                coded += (buf[0] & 0x80) != 0;
                ctx += (buf[0] & 0x40) != 0;
                uint32_t h;
                if (gv_gpu_decode_tile(gd, buf, tlen, above[(ty / 2) * above_w + tx / 2],
                                       (int)(tx & 1), (int)(ty & 1), &h, &err) < 0)
                    fail("gpu decode %d/%u/%u: %s", k, tx, ty, err.text);
                free(page);
                cur[ty * l->tiles_x + tx] = h;
                const uint8_t *ref;
                if (gv_decoder_tile(cpu, k, tx, ty, &ref, &err) < 0 ||
                    gv_gpu_read_tile(gd, h, 0, px, &err) < 0)
                    fail("read %d/%u/%u: %s", k, tx, ty, err.text);
                tiles++;
                if (memcmp(px, ref, tb) != 0) {
                    mismatched++;
                    size_t i = 0;
                    while (px[i] == ref[i])
                        i++;
                    printf("# tile %d/%u/%u differs first at pixel %zu,%zu: gpu %u cpu %u\n",
                           k, tx, ty, (i / c) % 513, (i / c) / 513, px[i], ref[i]);
                }
                /* Mip 1 is the parent quarter: compare with the CPU parent. */
                const uint8_t *par;
                if (gv_gpu_read_tile(gd, h, 1, quarter, &err) < 0 ||
                    gv_decoder_tile(cpu, k + 1, tx / 2, ty / 2, &par, &err) < 0)
                    fail("mip 1: %s", err.text);
                for (int v = 0; v < 257; v++)
                    quarter_bad += memcmp(quarter + (size_t)v * 257 * c,
                                          par + ((size_t)(256 * (ty & 1) + v) * 513 +
                                                 256 * (tx & 1)) * c,
                                          (size_t)257 * c) != 0;
            }
        for (uint32_t i = 0; i < above_w * (k + 1 == g->root ? 1 : g->level[k + 1].tiles_y); i++)
            gv_gpu_release(gd, above[i]);
        free(above);
        above = cur;
        above_w = l->tiles_x;
    }
    for (uint32_t i = 0; i < g->level[0].tiles_x * g->level[0].tiles_y && g->root > 0; i++)
        gv_gpu_release(gd, above[i]);
    free(above);
    char rs[128] = "";
    for (int q = 0; q < 16; q++)
        if (rates[q])
            snprintf(rs + strlen(rs), sizeof rs - strlen(rs), " r%d:%d", q, rates[q]);
    if (dct)
        snprintf(rs + strlen(rs), sizeof rs - strlen(rs), " D:%d", dct);
    const char *name = strrchr(input, '/') ? strrchr(input, '/') + 1 : input;
    check(mismatched == 0 && quarter_bad == 0 && tiles > 0,
          "%s, %s: %d tiles (%s; %d entropy-coded, %d of them context-coded) decode "
          "identically on the GPU (%d differ, %d mip-1 rows differ)", name,
          path == GV_GPU_PATH_COMPUTE ? "GLSL ES 3.10 + compute" : "GLSL ES 3.00 (WebGL2)",
          tiles, rs + 1, coded, ctx, mismatched, quarter_bad);
    free(px);
    free(quarter);
    gv_gpu_decoder_free(gd);
    gv_decoder_free(cpu);
    gv_store_close(s);
    return dct;
}

static const char *path_name(enum gv_gpu_path path)
{
    return path == GV_GPU_PATH_COMPUTE ? "GLSL ES 3.10 + compute" : "GLSL ES 3.00 (WebGL2)";
}

struct tile_where {
    int level;
    uint32_t tx, ty;
};

/* Tiles of jobs[0..n) read back from the GPU that differ from the CPU
 * decoder's, each listed. */
static int count_mismatches(struct gv_decoder *cpu, struct gv_gpu_decoder *gd,
                            const struct gv_gpu_tile_job *jobs,
                            const struct tile_where *where, size_t n, int c)
{
    struct gv_error err = {0};
    const size_t tb = gv_tile_bytes(c);
    uint8_t *px = malloc(tb);
    int mismatched = 0;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *ref;
        if (gv_decoder_tile(cpu, where[i].level, where[i].tx, where[i].ty, &ref, &err) < 0 ||
            gv_gpu_read_tile(gd, jobs[i].handle, 0, px, &err) < 0)
            fail("read %d/%u/%u: %s", where[i].level, where[i].tx, where[i].ty, err.text);
        if (memcmp(px, ref, tb) != 0) {
            mismatched++;
            printf("# batch: job %zu, tile %d/%u/%u (byte 0 0x%02x) differs\n", i,
                   where[i].level, where[i].tx, where[i].ty, jobs[i].buf[0]);
        }
    }
    free(px);
    return mismatched;
}

/* Every tile of the store in one gv_gpu_decode_batch, top level first,
 * each naming its parent's job (the root tile uploaded), then read back
 * and compared with the CPU decoder; `copies` times over in the batch. */
static void check_batch(struct gv_gpu *gpu, const char *input, const char *out,
                        enum gv_gpu_path path, int copies)
{
    struct gv_error err = {0};
    struct gv_store *s;
    struct gv_decoder *cpu;
    struct gv_gpu_decoder *gd = open_decoders(gpu, out, path, &s, &cpu);
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int c = g->channels;
    size_t one = 0;
    for (int k = 0; k < g->root; k++)
        one += (size_t)g->level[k].tiles_x * g->level[k].tiles_y;
    const size_t n = one * (size_t)copies;
    struct gv_gpu_tile_job *jobs = calloc(n ? n : 1, sizeof *jobs);
    uint8_t **pages = calloc(n ? n : 1, sizeof *pages);
    struct tile_where *where = calloc(n ? n : 1, sizeof *where);
    const uint8_t *root;
    uint32_t root_h;
    if (gv_decoder_tile(cpu, g->root, 0, 0, &root, &err) < 0 ||
        gv_gpu_upload_tile(gd, root, &root_h, &err) < 0)
        fail("root: %s", err.text);
    size_t at = 0;
    for (int copy = 0; copy < copies; copy++) {
    size_t level_start = at, above_start = at;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        const uint32_t above_w = k + 1 == g->root ? 1 : g->level[k + 1].tiles_x;
        level_start = at;
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++, at++) {
                fixture_tile(s, k, tx, ty, &pages[at], &jobs[at].buf, &jobs[at].len);
                jobs[at].qx = (int)(tx & 1);
                jobs[at].qy = (int)(ty & 1);
                if (k + 1 == g->root) {
                    jobs[at].parent = root_h;
                    jobs[at].parent_job = -1;
                } else {
                    jobs[at].parent_job = (long)(above_start + (ty / 2) * above_w + tx / 2);
                }
                where[at].level = k;
                where[at].tx = tx;
                where[at].ty = ty;
            }
        above_start = level_start;
    }
    }
    /* A parent that is not an earlier job is refused, and nothing made. */
    if (n > 0) {
        struct gv_gpu_tile_job bad = jobs[0];
        bad.parent_job = 0;
        int rc = gv_gpu_decode_batch(gd, &bad, 1, &err);
        check(rc < 0 && err.code == GV_EINVAL, "%s: a job naming itself as parent "
              "is refused (%s)", path_name(path), rc < 0 ? err.text : "accepted");
    }
    if (gv_gpu_decode_batch(gd, jobs, n, &err) < 0)
        fail("batch of %zu tiles: %s", n, err.text);
    const char *name = strrchr(input, '/') ? strrchr(input, '/') + 1 : input;
    int distinct = 1;
    for (size_t i = 0; i < n; i++)
        distinct &= jobs[i].handle != 0 && jobs[i].handle != root_h &&
                    (i == 0 || jobs[i].handle != jobs[i - 1].handle);
    int mismatched = count_mismatches(cpu, gd, jobs, where, n, c);
    check(mismatched == 0 && distinct && n > 0, "%s, %s: all %zu tiles in one batch "
          "(the store %d time(s)) decode identically on the GPU (%d differ)", name,
          path_name(path), n, copies, mismatched);
    /* Again one batch per level, parents given as handles (so the grouped
     * passes run: every quarter pass, then every decode pass), into
     * textures reserved up front and the ones just released. */
    for (size_t i = 0; i < n; i++)
        gv_gpu_release(gd, jobs[i].handle);
    if (gv_gpu_reserve(gd, n, &err) < 0)
        fail("reserve: %s", err.text);
    for (size_t a = 0, b; a < n; a = b) {
        for (b = a; b < n && where[b].level == where[a].level; b++)
            if (jobs[b].parent_job >= 0) {
                jobs[b].parent = jobs[jobs[b].parent_job].handle;
                jobs[b].parent_job = -1;
            }
        if (gv_gpu_decode_batch(gd, jobs + a, b - a, &err) < 0)
            fail("level batch: %s", err.text);
    }
    mismatched = count_mismatches(cpu, gd, jobs, where, n, c);
    check(mismatched == 0 && n > 0, "%s, %s: one batch per level into reserved "
          "textures decodes identically (%d differ)", name, path_name(path), mismatched);
    for (size_t i = 0; i < n; i++) {
        gv_gpu_release(gd, jobs[i].handle);
        free(pages[i]);
    }
    gv_gpu_release(gd, root_h);
    free(jobs);
    free(pages);
    free(where);
    gv_gpu_decoder_free(gd);
    gv_decoder_free(cpu);
    gv_store_close(s);
}

/*
 * Layout D (FORMAT.md 4.3) on buffers written by dct_fixture.h rather than
 * the encoder: typical sparse blocks with escapes over their whole range,
 * steps of 4095 whose products clamp to 16 bits and pixels that clamp,
 * every coefficient of every block coded (the longest streams), and no
 * coefficient at all.  Each decoded on both paths, one call per tile and
 * all in one batch (one compute dispatch for all on the SSBO path), against
 * gv_tile_decode.  Then the negative controls: the decode shader with a
 * wrong rounding offset in either pass of the inverse transform, and a
 * buffer whose quantizer step was changed after the CPU decoded it, must
 * each be caught.
 */

static uint64_t rng_state = 0x9e3779b97f4a7c15u;

static uint32_t rng(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 16);
}

struct dct_tile {
    uint8_t *buf;
    size_t len;
    int qx, qy;
    uint8_t *ref;        /* gv_tile_decode's tile */
};

/* Tiles of t[0..n) decoded by `gd` from the parent `ph` (one call each, or
 * one batch) that differ from their CPU decoding. */
static int dct_mismatches(struct gv_gpu_decoder *gd, uint32_t ph, struct dct_tile *t,
                          int n, int batch, int channels)
{
    struct gv_error err = {0};
    struct gv_gpu_tile_job jobs[DCT_FIXTURE_CASES];
    for (int i = 0; i < n; i++)
        jobs[i] = (struct gv_gpu_tile_job){.buf = t[i].buf, .len = t[i].len, .parent = ph,
                                           .parent_job = -1, .qx = t[i].qx, .qy = t[i].qy};
    if (batch) {
        if (gv_gpu_decode_batch(gd, jobs, (size_t)n, &err) < 0)
            fail("dct batch: %s", err.text);
    } else {
        for (int i = 0; i < n; i++)
            if (gv_gpu_decode_tile(gd, t[i].buf, t[i].len, ph, t[i].qx, t[i].qy,
                                   &jobs[i].handle, &err) < 0)
                fail("dct tile %d: %s", i, err.text);
    }
    uint8_t *px = malloc(gv_tile_bytes(channels));
    int bad = 0;
    for (int i = 0; i < n; i++) {
        if (gv_gpu_read_tile(gd, jobs[i].handle, 0, px, &err) < 0)
            fail("dct read: %s", err.text);
        bad += memcmp(px, t[i].ref, gv_tile_bytes(channels)) != 0;
        gv_gpu_release(gd, jobs[i].handle);
    }
    free(px);
    return bad;
}

static void check_dct_synthetic(struct gv_gpu *gpu, int channels)
{
    struct gv_error err = {0};
    const size_t tb = gv_tile_bytes(channels);
    uint8_t *parent = malloc(tb);
    for (size_t i = 0; i < tb; i++) {
        const size_t p = i / (size_t)channels;
        parent[i] = (uint8_t)(p % 513 / 3 + p / 513 / 4 + rng() % 8 + 40 * (i % 3));
    }
    int *q = malloc(sizeof *q * 3 * 520 * 520);
    struct dct_tile t[DCT_FIXTURE_CASES];
    int clamped = 0;
    for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
        int S[3];
        dct_fixture_case(k, channels, &rng_state, q, S);
        t[k].buf = malloc(2u << 20);
        t[k].len = dct_fixture_write(q, S, channels, t[k].buf);
        t[k].qx = k & 1;
        t[k].qy = k >> 1 & 1;
        t[k].ref = malloc(tb);
        if (gv_tile_decode(t[k].buf, t[k].len, channels, parent, t[k].qx, t[k].qy,
                           t[k].ref, &err) < 0)
            fail("CPU decode of synthetic D buffer %d (%zu bytes): %s", k, t[k].len,
                 err.text);
        for (size_t i = 0; i < tb; i++)
            clamped += t[k].ref[i] == 0 || t[k].ref[i] == 255;
    }
    for (int path = GV_GPU_PATH_COMPUTE; path <= GV_GPU_PATH_WEBGL2; path++) {
        struct gv_gpu_decoder *gd = gv_gpu_decoder_new(
            gpu, &(struct gv_gpu_decoder_opts){.channels = channels, .path = path}, &err);
        if (!gd)
            fail("decoder: %s", err.text);
        uint32_t ph;
        if (gv_gpu_upload_tile(gd, parent, &ph, &err) < 0)
            fail("upload: %s", err.text);
        const int one = dct_mismatches(gd, ph, t, DCT_FIXTURE_CASES, 0, channels);
        const int all = dct_mismatches(gd, ph, t, DCT_FIXTURE_CASES, 1, channels);
        check(one == 0 && all == 0 && clamped > 0,
              "C=%d, %s: %d synthetic D buffers (%zu to %zu bytes; escapes, clamped "
              "products, all 64 coefficients, none; %d clamped samples) decode "
              "identically, one call each (%d differ) and in one batch (%d differ)",
              channels, path_name(path), DCT_FIXTURE_CASES, t[3].len, t[2].len, clamped,
              one, all);
        gv_gpu_release(gd, ph);
        gv_gpu_decoder_free(gd);
        /* Negative controls: a wrong rounding offset in the row pass (63
         * for 64) or the column pass (1023 for 1024) of the inverse
         * transform. */
        static const char *const wrong[2] = {"#define GV_DCT_ROUND_ROWS 63\n",
                                             "#define GV_DCT_ROUND_COLS 1023\n"};
        for (int w = 0; w < 2; w++) {
            gd = gv_gpu_decoder_new(gpu, &(struct gv_gpu_decoder_opts){
                .channels = channels, .path = path, .defines = wrong[w]}, &err);
            if (!gd || gv_gpu_upload_tile(gd, parent, &ph, &err) < 0)
                fail("control decoder: %s", err.text);
            const int bad = dct_mismatches(gd, ph, t, 1, 0, channels);
            check(bad == 1, "C=%d, %s: negative control, %s rounding of the %s pass: "
                  "the first synthetic D tile differs", channels, path_name(path),
                  w ? "1023/2048" : "63/128", w ? "column" : "row");
            gv_gpu_release(gd, ph);
            gv_gpu_decoder_free(gd);
        }
    }
    /* Negative control: the first buffer with another quantizer step for
     * channel 0 than the one its CPU decoding saw. */
    t[0].buf[2] ^= 1;
    for (int path = GV_GPU_PATH_COMPUTE; path <= GV_GPU_PATH_WEBGL2; path++) {
        struct gv_gpu_decoder *gd = gv_gpu_decoder_new(
            gpu, &(struct gv_gpu_decoder_opts){.channels = channels, .path = path}, &err);
        uint32_t ph;
        if (!gd || gv_gpu_upload_tile(gd, parent, &ph, &err) < 0)
            fail("decoder: %s", err.text);
        const int bad = dct_mismatches(gd, ph, t, 1, 0, channels);
        check(bad == 1, "C=%d, %s: negative control, a D buffer whose step S[0] "
              "changed after the CPU decoded it differs", channels, path_name(path));
        gv_gpu_release(gd, ph);
        gv_gpu_decoder_free(gd);
    }
    for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
        free(t[k].buf);
        free(t[k].ref);
    }
    free(q);
    free(parent);
}

int main(int argc, char **argv)
{
    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu) {
        return tap_skip_all("no EGL context: %s", err.text);
    }
    const struct gv_gpu_info *in = gv_gpu_info(gpu);
    printf("# EGL %s platform, %s: %s / %s / %s\n", in->platform, in->api, in->vendor,
           in->renderer, in->version);
    test_tmpdir_new(dir, sizeof dir, "gv-test-gpu");
    const char *data = test_data_dir();
    char picos[512];
    snprintf(picos, sizeof picos, "%s/picos-1100x700.jpg", data);
    if (argc > 1) {
        /* Explicit inputs (used to check a machine without the test data,
         * e.g. one with a real GPU): INPUT PSNR MAXRATE triples. */
        for (int i = 1; i + 2 < argc; i += 3)
            check_store(gpu, argv[i], atof(argv[i + 1]), atoi(argv[i + 2]),
                        getenv("GV_TEST_DCT") != NULL);
        test_tmpdir_free(dir);
        gv_gpu_close(gpu);
        return tap_done();
    }
    check_dct_synthetic(gpu, 3);
    check_dct_synthetic(gpu, 1);
    check_store(gpu, picos, 36.0, 10, 0);
    check_store(gpu, picos, 41.0, 10, 0);               /* rates 8 to 10 */
    /* Rates up to the cap: 11 and 12 (measured: r11:1 r12:4), in full and
     * edge tiles of two tiled levels; 1100x512 has what 1500x1100 had in
     * 5 tiles instead of 13 (whose encode took 35 s of this test's 65 under
     * ASan). */
    check_store(gpu, "synth:1100x512", 60.0, 12, 0);
    check_store(gpu, "synth:1100x1500:gray", 33.0, 10, 0);
    check_store(gpu, "synth:2100x900", 20.0, 3, 0);    /* low rates, r = 0 */
    check_store(gpu, "synth:600x600:gray", 99.0, 12, 0);
    /* Layout D (FORMAT.md 4.3) where the encoder finds it cheaper. */
    check_store(gpu, picos, 40.0, 10, 1);
    check_store(gpu, "synth:700x700:gray", 40.0, 10, 1);
    check_store(gpu, "synth:900x700", 40.0, 10, 1);    /* D and EX in a group */
    /* A store of format version 1 (E layout and rate 0 only). */
    char v1[512];
    snprintf(v1, sizeof v1, "%s/v1-picos-530x516.gv", data);
    check_path(gpu, v1, v1, GV_GPU_PATH_COMPUTE);
    check_path(gpu, v1, v1, GV_GPU_PATH_WEBGL2);
    /* A store of format version 4: its 8 tiles in layout D (the encoder
     * now writes D2). */
    char v4[512];
    snprintf(v4, sizeof v4, "%s/v4-picos-1100x700.gv", data);
    check(check_path(gpu, v4, v4, GV_GPU_PATH_COMPUTE) == 8,
          "the version-4 store's 8 tiles are layout D");
    check_path(gpu, v4, v4, GV_GPU_PATH_WEBGL2);
    test_tmpdir_free(dir);
    gv_gpu_close(gpu);
    return tap_done();
}
