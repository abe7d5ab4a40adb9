/*
 * test_gpu_height.c - the GPU height decoder (lib/gpu/gpu_height.c and
 * shaders/height_*.glsl) gives, on both shader paths, exactly the codes of
 * the CPU reference decoder for every tile of every level of height
 * stores: ETOPO5 lossless and at 2 m, and synthetic terrain at e = 1 (on
 * llvmpipe in CI).  The WebGL2 path is the browser's: its fragment shader
 * compiled as GLSL ES 3.00, q decoded on the CPU.  Sample stores
 * (docs/FORMAT.md section 13) are decoded the same way, a decoder of C
 * channels taking whole tiles (every channel's buffer into its layer,
 * against the same layer of the parent), and compared with the CPU
 * decoder's tile, every channel.  A decoder of another channel count is
 * refused.  The whole pyramid of tiles decoded in one batch
 * (gv_gpu_height_decode_batch, parents named by job) equals the CPU
 * decoder too; a batch with a damaged buffer or a parent named after its
 * job is refused.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "encode/height_encode.h"
#include "gpu/gpu.h"
#include "gpu/gpu_decode.h"
#include "gpu/gpu_height.h"
#include "render/store_decoder.h"
#include "store/store_read.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

/* A decoder of one channel fewer refuses a tile of store s (its buffers
 * do not fill it), and one of 9 channels is not made. */
static void check_refusals(struct gv_gpu *gpu, struct gv_store *s,
                           enum gv_gpu_path gp, const char *name, const char *pn)
{
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    struct gv_error err = {0};
    struct gv_gpu_height *few = gv_gpu_height_new(
        gpu, &(struct gv_gpu_height_opts){.path = gp, .channels = g->channels - 1}, &err);
    uint8_t *page = NULL;
    size_t plen, tlen;
    const uint8_t *tb;
    uint16_t *root = calloc(GV_HT_SAMPLES * (size_t)g->channels, sizeof *root);
    uint32_t up = 0, h = 0;
    if (!few || !root || gv_gpu_height_upload(few, root, &up, &err) < 0 ||
        gv_store_read_page(s, 0, 0, 0, &page, &plen, &err) < 0 ||
        gv_page_tile(page, plen, 1, 0, 0, &tb, &tlen, &err) < 0)
        fail("%s %s: refusal set-up: %s", name, pn, err.text);
    int rc = gv_gpu_height_decode(few, tb, tlen, up, 0, 0, &h, &err);
    check(rc < 0 && err.code == GV_ECORRUPT, "%s %s: a decoder of %d channels refuses "
          "a tile of %d (%s)", name, pn, g->channels - 1, g->channels, err.text);
    gv_error_clear(&err);
    struct gv_gpu_height *nine = gv_gpu_height_new(
        gpu, &(struct gv_gpu_height_opts){.path = gp, .channels = 9}, &err);
    check(!nine && err.code == GV_EINVAL, "%s %s: no decoder of 9 channels (%s)", name,
          pn, err.text);
    gv_gpu_height_free(nine);
    gv_gpu_height_release(few, up);
    gv_gpu_height_free(few);
    free(page);
    free(root);
}

/* Store `path` (*s) and a GPU decoder of its channels on path gp, or
 * NULL (the store closed) after a skip where the context has no such
 * path or a failed check. */
static struct gv_gpu_height *open_store(struct gv_gpu *gpu, const char *path,
                                        const char *name, enum gv_gpu_path gp,
                                        struct gv_store **s)
{
    const char *pn = gp == GV_GPU_PATH_COMPUTE ? "ssbo" : "webgl2";
    struct gv_error err = {0};
    if (!(*s = gv_store_open(path, &err)))
        fail("open %s: %s", path, err.text);
    const int nc = gv_store_info(*s)->geometry.channels;   /* 1: a height store */
    struct gv_gpu_height *gh = gv_gpu_height_new(
        gpu, &(struct gv_gpu_height_opts){.path = gp, .channels = nc}, &err);
    if (!gh) {
        gv_store_close(*s);
        if (err.code == GV_EFORMAT)
            tap_skip("no OpenGL ES context", "%s %s", name, pn);
        else
            check(0, "%s %s: decoder: %s", name, pn, err.text);
    }
    return gh;
}

/* Decode every tile of `path` on the GPU, all channels at once, level by
 * level from the uploaded root tile, and compare each with the CPU
 * decoder. */
static void check_tiles(struct gv_gpu *gpu, const char *path, const char *name,
                        enum gv_gpu_path gp)
{
    const char *pn = gp == GV_GPU_PATH_COMPUTE ? "ssbo" : "webgl2";
    struct gv_error err = {0};
    struct gv_store *s;
    struct gv_gpu_height *gh = open_store(gpu, path, name, gp, &s);
    if (!gh)
        return;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int nc = g->channels;   /* 1 for a height store */
    struct gv_decoder *cpu = gv_decoder_new(s, 256u << 20);
    const size_t tile_bytes = sizeof(uint16_t) * GV_HT_SAMPLES * (size_t)nc;
    uint16_t *got = malloc(tile_bytes);
    const uint8_t *px;
    uint32_t *up = calloc(1, sizeof *up), *cur = NULL;
    uint32_t up_tx = 1;
    size_t up_n = 1;
    if (gv_decoder_tile(cpu, g->root, 0, 0, &px, &err) < 0 ||
        gv_gpu_height_upload(gh, (const uint16_t *)(const void *)px, &up[0], &err) < 0)
        fail("%s: root: %s", name, err.text);
    long tiles = 0, same = 0;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        size_t n = (size_t)l->tiles_x * l->tiles_y;
        cur = calloc(n, sizeof *cur);
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                uint8_t *page;
                size_t plen, tlen;
                const uint8_t *tb;
                if (gv_store_read_page(s, k, tx / 8, ty / 8, &page, &plen, &err) < 0 ||
                    gv_page_tile(page, plen, 1, (int)(tx % 8), (int)(ty % 8), &tb,
                                 &tlen, &err) < 0)
                    fail("%s: page: %s", name, err.text);
                uint32_t *h = &cur[(size_t)ty * l->tiles_x + tx];
                if (gv_gpu_height_decode(gh, tb, tlen, up[(ty / 2) * up_tx + tx / 2],
                                         (int)(tx & 1), (int)(ty & 1), h, &err) < 0 ||
                    gv_gpu_height_read(gh, *h, got, &err) < 0)
                    fail("%s %s: GPU decode %d/%u/%u: %s", name, pn, k, tx, ty, err.text);
                free(page);
                if (gv_decoder_tile(cpu, k, tx, ty, &px, &err) < 0)
                    fail("%s: CPU decode: %s", name, err.text);
                tiles++;
                const uint16_t *want = (const uint16_t *)(const void *)px;
                if (memcmp(got, want, tile_bytes) == 0) {
                    same++;
                } else {
                    for (size_t i = 0; i < GV_HT_SAMPLES * (size_t)nc; i++)
                        if (got[i] != want[i]) {
                            printf("# %s %s tile %d/%u/%u first differs at (%zu,%zu) "
                                   "channel %zu: GPU %u, CPU %u\n", name, pn, k, tx, ty,
                                   i / nc % 513, i / nc / 513, i % nc, got[i], want[i]);
                            break;
                        }
                }
            }
        for (size_t i = 0; i < up_n; i++)
            gv_gpu_height_release(gh, up[i]);
        free(up);
        up = cur;
        up_n = n;
        up_tx = l->tiles_x;
    }
    for (size_t i = 0; i < up_n; i++)
        gv_gpu_height_release(gh, up[i]);
    free(up);
    check(tiles > 0 && same == tiles, "%s %s, %d channel%s: %ld of %ld tiles "
          "bit-exact", name, pn, nc, nc == 1 ? "" : "s", same, tiles);
    if (nc > 1)
        check_refusals(gpu, s, gp, name, pn);
    free(got);
    gv_decoder_free(cpu);
    gv_store_close(s);
    gv_gpu_height_free(gh);
}

/* Every tiled level of store `path` in one batch, each tile's parent
 * the job before it (the root uploaded), against the CPU decoder; then
 * the refusals. */
static void check_batch(struct gv_gpu *gpu, const char *path, const char *name,
                        enum gv_gpu_path gp)
{
    const char *pn = gp == GV_GPU_PATH_COMPUTE ? "ssbo" : "webgl2";
    struct gv_error err = {0};
    struct gv_store *s;
    struct gv_gpu_height *gh = open_store(gpu, path, name, gp, &s);
    if (!gh)
        return;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int nc = g->channels;
    struct gv_decoder *cpu = gv_decoder_new(s, 256u << 20);
    const uint8_t *px;
    uint32_t root;
    if (gv_decoder_tile(cpu, g->root, 0, 0, &px, &err) < 0 ||
        gv_gpu_height_upload(gh, (const uint16_t *)(const void *)px, &root, &err) < 0)
        fail("%s: root: %s", name, err.text);
    /* Jobs level by level from the top; first[k]: level k's first job. */
    size_t n = 0, first[GV_MAX_LEVELS];
    for (int k = g->root - 1; k >= 0; k--)
        n += (size_t)g->level[k].tiles_x * g->level[k].tiles_y;
    struct gv_gpu_tile_job *jobs = calloc(n, sizeof *jobs);
    uint8_t **pages = calloc(n, sizeof *pages);
    size_t at = 0;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        first[k] = at;
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++, at++) {
                size_t plen;
                if (gv_store_read_page(s, k, tx / 8, ty / 8, &pages[at], &plen, &err) < 0 ||
                    gv_page_tile(pages[at], plen, 1, (int)(tx % 8), (int)(ty % 8),
                                 &jobs[at].buf, &jobs[at].len, &err) < 0)
                    fail("%s: page: %s", name, err.text);
                const int top = k == g->root - 1;
                jobs[at].parent = top ? root : 0;
                jobs[at].parent_job = top ? -1 : (long)(first[k + 1] +
                    (size_t)(ty / 2) * g->level[k + 1].tiles_x + tx / 2);
                jobs[at].qx = (int)(tx & 1);
                jobs[at].qy = (int)(ty & 1);
            }
    }
    const size_t tile_bytes = sizeof(uint16_t) * GV_HT_SAMPLES * (size_t)nc;
    uint16_t *got = malloc(tile_bytes);
    long same = 0;
    if (gv_gpu_height_decode_batch(gh, jobs, n, &err) < 0)
        fail("%s %s: batch: %s", name, pn, err.text);
    at = 0;
    for (int k = g->root - 1; k >= 0; k--)
        for (uint32_t ty = 0; ty < g->level[k].tiles_y; ty++)
            for (uint32_t tx = 0; tx < g->level[k].tiles_x; tx++, at++) {
                if (gv_gpu_height_read(gh, jobs[at].handle, got, &err) < 0 ||
                    gv_decoder_tile(cpu, k, tx, ty, &px, &err) < 0)
                    fail("%s: read: %s", name, err.text);
                same += memcmp(got, px, tile_bytes) == 0;
                gv_gpu_height_release(gh, jobs[at].handle);
            }
    check(n > 1 && same == (long)n, "%s %s: the pyramid in one batch of %zu tiles, "
          "%ld bit-exact", name, pn, n, same);
    /* Refusals: a parent named after its job; a damaged last buffer. */
    jobs[0].parent_job = 1;
    check(gv_gpu_height_decode_batch(gh, jobs, n, &err) < 0 && err.code == GV_EINVAL,
          "%s %s: a batch naming a later job as a parent is refused: %s", name, pn,
          err.text);
    jobs[0].parent_job = -1;
    gv_error_clear(&err);
    jobs[n - 1].len = 3;
    check(gv_gpu_height_decode_batch(gh, jobs, n, &err) < 0 && err.code == GV_ECORRUPT,
          "%s %s: a batch with a damaged buffer is refused: %s", name, pn, err.text);
    for (size_t i = 0; i < n; i++)
        free(pages[i]);
    free(pages);
    free(jobs);
    free(got);
    gv_gpu_height_release(gh, root);
    gv_decoder_free(cpu);
    gv_store_close(s);
    gv_gpu_height_free(gh);
}

/* Encode `input` as a height store (samples 0) or a sample store of its
 * channels (1) within e, and check every channel on both paths. */
static void check_store(struct gv_gpu *gpu, const char *input, double e,
                        const char *name, int samples)
{
    char out[256];
    snprintf(out, sizeof out, "%s/h.gv", dir);
    struct gv_height_opts o = {.max_error = e, .samples = samples};
    struct gv_height_result r;
    struct gv_error err = {0};
    if (gv_height_encode((const char *[]){input}, 1, out, &o, &r, &err) < 0)
        fail("encode %s: %s", input, err.text);
    check_tiles(gpu, out, name, GV_GPU_PATH_COMPUTE);
    check_tiles(gpu, out, name, GV_GPU_PATH_WEBGL2);
    if (gv_gpu_info(gpu)->ssbo)
        check_batch(gpu, out, name, GV_GPU_PATH_COMPUTE);
    check_batch(gpu, out, name, GV_GPU_PATH_WEBGL2);
    unlink(out);
}

int main(int argc, char **argv)
{
    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu)
        return tap_skip_all("no EGL context: %s", err.text);
    const struct gv_gpu_info *in = gv_gpu_info(gpu);
    printf("# EGL %s platform, %s: %s / %s\n", in->platform, in->api, in->vendor,
           in->renderer);
    test_tmpdir_new(dir, sizeof dir, "gv-test-gpu-height");
    if (argc > 1) {
        /* Explicit inputs (for a machine without the test data, e.g. one
         * with a real GPU): INPUT MAX-ERROR pairs. */
        for (int i = 1; i + 1 < argc; i += 2)
            check_store(gpu, argv[i], atof(argv[i + 1]), argv[i], 0);
        test_tmpdir_free(dir);
        gv_gpu_close(gpu);
        return tap_done();
    }
    const char *data = test_data_dir();
    char dem[512];
    snprintf(dem, sizeof dem, "%s/etopo5-himalaya-1030x300-u16.png", data);
    check_store(gpu, dem, 0, "etopo lossless", 0);
    check_store(gpu, dem, 2, "etopo e=2", 0);
    check_store(gpu, "synth-height:1100x1030", 1, "synth e=1", 0);
    /* Sample stores: an 8-bit RGB picture's three channels at e = 1. */
    char rgb[512];
    snprintf(rgb, sizeof rgb, "%s/picos-1100x700.jpg", data);
    check_store(gpu, rgb, 1, "samples rgb e=1", 1);
    test_tmpdir_free(dir);
    gv_gpu_close(gpu);
    return tap_done();
}
