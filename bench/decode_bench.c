/*
 * decode_bench.c - tile decoding speed, everything in one run on the same
 * store: the CPU reference decoder on one thread and on every core, the GPU
 * decoder (EGL: llvmpipe here, the vendor driver on a GPU machine) one call
 * per tile and in batches (one gv_gpu_decode_batch per level), and,
 * as the anchor, libjpeg-turbo decoding the same level-0 tiles saved as
 * JPEG at the quality that matches the store's PSNR.
 *
 *   decode_bench [--no-gpu] [--no-cpu] STORE [SOURCE-IMAGE]
 *
 * SOURCE-IMAGE enables the JPEG anchor; --no-gpu and --no-cpu leave out
 * those decoders (to profile one of them).
 *
 * Where layout D's rANS rows run in AVX-512 lanes (tile_dct_lanes.c), the
 * single-thread CPU run is repeated with the scalar rows, with the ratio.
 *
 * Speeds are megapixels of decoded tiles (513 x 513 each) per second of
 * wall time, best of 5 for the CPU runs (3 for the GPU); single-thread
 * runs are also given per second of process CPU time, which a loaded
 * machine's time slicing does not skew.  Prints figures only; asserts
 * nothing.
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <jpeglib.h>

#include "base/cpu.h"
#include "render/store_decoder.h"
#include "gpu/gpu.h"
#include "gpu/gpu_decode.h"
#include "imageio/imageio.h"
#include "base/pool.h"
#include "store/store_read.h"
#include "codec/tile.h"
#include "codec/predict.h"
#include "codec/tile_dct_lanes.h"

struct tile_ref {
    int level;
    uint32_t tx, ty;
    const uint8_t *buf;   /* into pages[] */
    size_t len;
    int parent;           /* index into tiles, -1 for the root tile */
};

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

/* CPU seconds of the whole process: on a loaded machine the single-thread
 * runs are also given per CPU-second, which time slicing does not skew. */
static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static double last_cpu_rate;   /* MP per CPU-second of the last timed run */

static struct tile_ref *tiles;
static int ntiles, channels;
static uint8_t **decoded;     /* CPU decode of every tile (parents for the CPU runs) */
static uint8_t *root_tile;
static int predict_only;      /* time gv_predict alone (the residual left out) */

static void cpu_decode_one(void *ctx, size_t i, int worker)
{
    (void)ctx;
    (void)worker;
    static _Thread_local uint8_t *out;
    if (!out)
        out = malloc(gv_tile_bytes(channels));
    const struct tile_ref *t = &tiles[i];
    const uint8_t *parent = t->parent < 0 ? root_tile : decoded[t->parent];
    struct gv_error err = {0};
    if (predict_only) {
        gv_predict(parent, channels, (int)(t->tx & 1), (int)(t->ty & 1), out);
        return;
    }
    if (gv_tile_decode(t->buf, t->len, channels, parent, (int)(t->tx & 1),
                       (int)(t->ty & 1), out, &err) < 0) {
        fprintf(stderr, "decode: %s\n", err.text);
        exit(1);
    }
}

static double cpu_run(int threads)
{
    struct gv_pool *p = gv_pool_new(threads);
    double best = 1e9, best_cpu = 1e9;
    for (int rep = 0; rep < 5; rep++) {
        double t0 = now(), c0 = cpu_now();
        gv_pool_run(p, cpu_decode_one, NULL, (size_t)ntiles);
        double t = now() - t0, c = cpu_now() - c0;
        if (t < best)
            best = t;
        if (c < best_cpu)
            best_cpu = c;
    }
    gv_pool_free(p);
    last_cpu_rate = (double)ntiles * 513 * 513 / best_cpu / 1e6;
    return (double)ntiles * 513 * 513 / best / 1e6;
}

/* JPEG anchor: level-0 tiles of the source as JPEG files in memory. */
struct jpeg_tile {
    unsigned char *data;
    unsigned long len;
};

static struct jpeg_tile *jpeg_encode_tiles(const uint8_t *img, uint32_t w, uint32_t h,
                                           int c, int quality, int *count,
                                           double *psnr)
{
    int tx = (int)((w + 511) / 512), ty = (int)((h + 511) / 512);
    struct jpeg_tile *jt = calloc((size_t)tx * ty, sizeof *jt);
    double sse = 0, n = 0;
    uint8_t *tile = malloc(513 * 513 * 3);
    for (int y = 0; y < ty; y++)
        for (int x = 0; x < tx; x++) {
            for (int v = 0; v < 513; v++)
                for (int u = 0; u < 513; u++) {
                    uint32_t sx = (uint32_t)(x * 512 + u), sy = (uint32_t)(y * 512 + v);
                    if (sx >= w) sx = w - 1;
                    if (sy >= h) sy = h - 1;
                    for (int k = 0; k < 3; k++)
                        tile[(v * 513 + u) * 3 + k] = img[((size_t)sy * w + sx) * c + (c == 3 ? k : 0)];
                }
            struct jpeg_compress_struct ci;
            struct jpeg_error_mgr je;
            ci.err = jpeg_std_error(&je);
            jpeg_create_compress(&ci);
            struct jpeg_tile *o = &jt[y * tx + x];
            jpeg_mem_dest(&ci, &o->data, &o->len);
            ci.image_width = 513;
            ci.image_height = 513;
            ci.input_components = 3;
            ci.in_color_space = JCS_RGB;
            jpeg_set_defaults(&ci);
            jpeg_set_quality(&ci, quality, TRUE);
            ci.optimize_coding = TRUE;
            jpeg_start_compress(&ci, TRUE);
            while (ci.next_scanline < 513) {
                JSAMPROW row = tile + ci.next_scanline * 513 * 3;
                jpeg_write_scanlines(&ci, &row, 1);
            }
            jpeg_finish_compress(&ci);
            jpeg_destroy_compress(&ci);
            /* quality of this tile, for the PSNR match */
            struct jpeg_decompress_struct di;
            di.err = jpeg_std_error(&je);
            jpeg_create_decompress(&di);
            jpeg_mem_src(&di, o->data, o->len);
            jpeg_read_header(&di, TRUE);
            jpeg_start_decompress(&di);
            uint8_t *row = malloc(513 * 3);
            for (int v = 0; v < 513; v++) {
                jpeg_read_scanlines(&di, &row, 1);
                for (int u = 0; u < 513 * 3; u++) {
                    double d = (double)row[u] - tile[v * 513 * 3 + u];
                    sse += d * d;
                }
                n += 513 * 3;
            }
            free(row);
            jpeg_finish_decompress(&di);
            jpeg_destroy_decompress(&di);
        }
    free(tile);
    *count = tx * ty;
    *psnr = 10 * log10(65025.0 * n / sse);
    return jt;
}

/* libjpeg-turbo decoding every tile: into one reused row (the anchor of
 * the ratios: the JPEG decoder at its fastest), or, whole_tile, each row
 * into its place in a 513x513 tile buffer, as gv_tile_decode writes it. */
static double jpeg_run(struct jpeg_tile *jt, int count, int whole_tile)
{
    uint8_t *tile = malloc((size_t)513 * 513 * 3), *row = tile;
    double best = 1e9, best_cpu = 1e9;
    for (int rep = 0; rep < 5; rep++) {
        double t0 = now(), c0 = cpu_now();
        for (int i = 0; i < count; i++) {
            struct jpeg_decompress_struct di;
            struct jpeg_error_mgr je;
            di.err = jpeg_std_error(&je);
            jpeg_create_decompress(&di);
            jpeg_mem_src(&di, jt[i].data, jt[i].len);
            jpeg_read_header(&di, TRUE);
            jpeg_start_decompress(&di);
            while (di.output_scanline < di.output_height) {
                if (whole_tile)
                    row = tile + (size_t)di.output_scanline * 513 * 3;
                jpeg_read_scanlines(&di, &row, 1);
            }
            jpeg_finish_decompress(&di);
            jpeg_destroy_decompress(&di);
        }
        double t = now() - t0, c = cpu_now() - c0;
        if (t < best)
            best = t;
        if (c < best_cpu)
            best_cpu = c;
    }
    free(tile);
    last_cpu_rate = (double)count * 513 * 513 / best_cpu / 1e6;
    return (double)count * 513 * 513 / best / 1e6;
}

/* Every tile of store s (at path), parents before children, into tiles[],
 * their CPU decode into decoded[], the root tile into root_tile; prints the
 * store's line.  Returns the level-0 PSNR, or -1 when a page cannot be
 * read. */
static double load_tiles(struct gv_store *s, const char *path)
{
    struct gv_error err = {0};
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    channels = g->channels;
    /* Every tile, parents before children. */
    int cap = 0;
    for (int k = 0; k < g->root; k++)
        cap += (int)(g->level[k].tiles_x * g->level[k].tiles_y);
    tiles = calloc((size_t)cap, sizeof *tiles);
    decoded = calloc((size_t)cap, sizeof *decoded);
    int *first = calloc((size_t)g->root + 1, sizeof *first);
    uint64_t coded_bytes = 0;
    int entropy = 0, dct = 0;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        first[k] = ntiles;
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                uint8_t *page;
                size_t plen;
                if (gv_store_read_page(s, k, tx / 8, ty / 8, &page, &plen, &err) < 0) {
                    fprintf(stderr, "%s\n", err.text);
                    return -1;
                }
                struct tile_ref *t = &tiles[ntiles];
                const uint8_t *b;
                gv_page_tile(page, plen, channels, (int)(tx % 8), (int)(ty % 8), &b, &t->len, &err);
                uint8_t *copy = malloc(t->len);
                memcpy(copy, b, t->len);
                free(page);
                t->buf = copy;
                t->level = k;
                t->tx = tx;
                t->ty = ty;
                t->parent = k + 1 == g->root ? -1 :
                    first[k + 1] + (int)((ty / 2) * g->level[k + 1].tiles_x + tx / 2);
                coded_bytes += t->len;
                entropy += (copy[0] & 0x80) != 0;
                dct += gv_tile_is_dct(copy[0]);
                ntiles++;
            }
    }
    struct gv_decoder *d = gv_decoder_new(s, 8u << 20);
    const uint8_t *px;
    gv_decoder_tile(d, g->root, 0, 0, &px, &err);
    root_tile = malloc(gv_tile_bytes(channels));
    memcpy(root_tile, px, gv_tile_bytes(channels));
    for (int i = 0; i < ntiles; i++) {
        gv_decoder_tile(d, tiles[i].level, tiles[i].tx, tiles[i].ty, &px, &err);
        decoded[i] = malloc(gv_tile_bytes(channels));
        memcpy(decoded[i], px, gv_tile_bytes(channels));
    }
    double psnr0 = gv_store_info(s)->header.psnr0_mdb / 1000.0;
    printf("store %s: %ux%u, %d tiles (%d VQ entropy-coded, %d layout D or D2), %.3f bits per decoded tile pixel, level-0 PSNR %.2f dB\n",
           path, g->width, g->height, ntiles, entropy, dct,
           8.0 * coded_bytes / ((double)ntiles * 513 * 513), psnr0);
    return psnr0;
}

/* The CPU reference decoder's rates, printed: *out1 on 1 thread (*out1_c
 * per CPU-second), *outn on every core. */
static void cpu_rates(double *out1, double *outn, double *out1_c)
{
    double cpu1, cpun, cpu1_c;
    cpu1 = cpu_run(1);
    cpu1_c = last_cpu_rate;
    printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second)\n", "CPU reference, 1 thread",
           cpu1, cpu1_c);
    cpun = cpu_run(gv_cpu_count());
    printf("%-34s %9.1f MP/s  (%d threads)\n", "CPU reference, all cores", cpun, gv_cpu_count());
    predict_only = 1;
    double pr = cpu_run(1), pr_c = last_cpu_rate;
    printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second; the residual and rANS left out)\n",
           "CPU prediction only, 1 thread", pr, pr_c);
    predict_only = 0;
    /* Where the prediction runs at level 3 (AVX-512 VBMI and VNNI),
     * the same decoder with the level-2 prediction (AVX-512BW without
     * them, as on Skylake-SP and Cascade Lake), in this run. */
    const unsigned l3 = GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI;
    const unsigned flags = gv_cpu_flags();
    if ((flags & l3) == l3) {
        gv_cpu_set_mask(flags & ~(unsigned)GV_CPU_AVX512VNNI);
        double old1 = cpu_run(1), old1_c = last_cpu_rate;
        predict_only = 1;
        double oldp = cpu_run(1), oldp_c = last_cpu_rate;
        predict_only = 0;
        gv_cpu_set_mask(flags);
        printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second)\n",
               "CPU reference, level-2 prediction", old1, old1_c);
        printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second)\n",
               "CPU prediction only, level 2", oldp, oldp_c);
        printf("ratio prediction level 3 / level 2: decoder %.2fx (per CPU-second %.2fx), "
               "prediction alone %.2fx (%.2fx)\n", cpu1 / old1, cpu1_c / old1_c,
               pr / oldp, pr_c / oldp_c);
    }
    /* Where layout D's rANS rows run in AVX-512 lanes, the same
     * decoder with the scalar rows (two in lockstep), in this run. */
    if (gv_dct_lanes_usable()) {
        /* Of the kernels only the lanes need POPCNT: without it the
         * rest stays as it was. */
        gv_cpu_set_mask(flags & ~(unsigned)GV_CPU_POPCNT);
        double sc1 = cpu_run(1), sc1_c = last_cpu_rate;
        gv_cpu_set_mask(flags);
        printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second)\n",
               "CPU reference, scalar rANS rows", sc1, sc1_c);
        printf("ratio rANS rows in lanes / scalar: decoder %.2fx (per CPU-second %.2fx)\n",
               cpu1 / sc1, cpu1_c / sc1_c);
    }
    *out1 = cpu1;
    *outn = cpun;
    *out1_c = cpu1_c;
}

/* The GPU decoder's rates, printed (without a context: why).  Returns the
 * faster rate in MP/s (0 without a GPU), or -1 when a batch fails. */
static double gpu_rates(int want_gpu)
{
    struct gv_error err = {0};
    double gpu = 0;
    struct gv_gpu *gpuctx = want_gpu ? gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err) : NULL;
    if (want_gpu && !gpuctx) {
        printf("%-34s unavailable: %s\n", "GPU (EGL)", err.text);
    } else if (gpuctx) {
        const struct gv_gpu_info *in = gv_gpu_info(gpuctx);
        struct gv_gpu_decoder *gd = gv_gpu_decoder_new(
            gpuctx, &(struct gv_gpu_decoder_opts){.channels = channels}, &err);
        uint32_t *h = calloc((size_t)ntiles, sizeof *h), root;
        gv_gpu_upload_tile(gd, root_tile, &root, &err);
        double best = 1e9, best_c = 1e9;
        uint8_t *one = malloc((size_t)257 * 257 * channels);
        for (int rep = 0; rep < 3; rep++) {
            double t0 = now(), c0 = cpu_now();
            for (int i = 0; i < ntiles; i++)
                gv_gpu_decode_tile(gd, tiles[i].buf, tiles[i].len,
                                   tiles[i].parent < 0 ? root : h[tiles[i].parent],
                                   (int)(tiles[i].tx & 1), (int)(tiles[i].ty & 1), &h[i], &err);
            /* Reading back the smallest level of the last tile waits for all. */
            gv_gpu_read_tile(gd, h[ntiles - 1], 1, one, &err);
            double t = now() - t0, c = cpu_now() - c0;
            if (c < best_c)
                best_c = c;
            if (t < best)
                best = t;
            for (int i = 0; i < ntiles; i++)
                gv_gpu_release(gd, h[i]);
        }
        gpu = (double)ntiles * 513 * 513 / best / 1e6;
        const double gpu_c = (double)ntiles * 513 * 513 / best_c / 1e6;
        printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second; %s, %s)\n", "GPU decode, per tile (EGL)",
               gpu, gpu_c, in->renderer, in->version);
        /* Batched: one gv_gpu_decode_batch per level, parents from the
         * level above (tiles[] runs level by level, top first); then again
         * with a texture reserved for every tile (gv_gpu_reserve). */
        struct gv_gpu_tile_job *jobs = calloc((size_t)ntiles, sizeof *jobs);
        double gpub = 0;
        for (int reserved = 0; reserved < 2; reserved++) {
            if (reserved && gv_gpu_reserve(gd, (size_t)ntiles, &err) < 0) {
                fprintf(stderr, "reserve: %s\n", err.text);
                return -1;
            }
            double bbest = 1e9, bbest_c = 1e9;
            for (int rep = 0; rep < 3; rep++) {
                double t0 = now(), c0 = cpu_now();
                for (int a = 0; a < ntiles;) {
                    int b = a;
                    while (b < ntiles && tiles[b].level == tiles[a].level)
                        b++;
                    for (int i = a; i < b; i++)
                        jobs[i] = (struct gv_gpu_tile_job){
                            .buf = tiles[i].buf, .len = tiles[i].len, .parent_job = -1,
                            .parent = tiles[i].parent < 0 ? root : jobs[tiles[i].parent].handle,
                            .qx = (int)(tiles[i].tx & 1), .qy = (int)(tiles[i].ty & 1)};
                    if (gv_gpu_decode_batch(gd, jobs + a, (size_t)(b - a), &err) < 0) {
                        fprintf(stderr, "batch: %s\n", err.text);
                        return -1;
                    }
                    a = b;
                }
                gv_gpu_read_tile(gd, jobs[ntiles - 1].handle, 1, one, &err);
                double t = now() - t0, c = cpu_now() - c0;
                if (c < bbest_c)
                    bbest_c = c;
                if (t < bbest)
                    bbest = t;
                for (int i = 0; i < ntiles; i++)
                    gv_gpu_release(gd, jobs[i].handle);
            }
            const double rate = (double)ntiles * 513 * 513 / bbest / 1e6;
            const double rate_c = (double)ntiles * 513 * 513 / bbest_c / 1e6;
            printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second; one call per level)\n",
                   reserved ? "GPU decode, batched, reserved" : "GPU decode, batched (EGL)",
                   rate, rate_c);
            printf("ratio GPU batched%s / GPU per tile: %.2fx  (per CPU-second %.2fx: the "
                   "measure for a software renderer)\n", reserved ? ", reserved" : "",
                   rate / gpu, rate_c / gpu_c);
            if (rate > gpub)
                gpub = rate;
        }
        free(jobs);
        gpu = gpub > gpu ? gpub : gpu;
        free(one);
        free(h);
        gv_gpu_release(gd, root);
        gv_gpu_decoder_free(gd);
        gv_gpu_close(gpuctx);
    }

    return gpu;
}

/* libjpeg-turbo on the source image at path, at the quality nearest the
 * store's level-0 PSNR, as the anchor of the rates measured before. */
static int jpeg_anchor(const char *path, double psnr0, double cpu1, double cpu1_c,
                       double cpun, double gpu)
{
    struct gv_error err = {0};
    struct gv_image_info info;
    struct gv_image_in *in = gv_image_open(path, 1ull << 34, &info, &err);
    if (!in || info.sample != GV_SAMPLE_U8) {
        printf("JPEG anchor: cannot read %s as 8-bit\n", path);
        return 0;
    }
    uint8_t *img = malloc((size_t)info.width * info.height * info.channels);
    gv_image_read(in, info.height, img, &err);
    gv_image_close(in);
    /* The quality whose tiles' PSNR is closest to the store's level 0. */
    int bestq = 0, count = 0;
    double bestd = 1e9, p;
    struct jpeg_tile *jt = NULL;
    /* Every fourth quality, then the three on either side of the
     * best: the nearest PSNR at a step of 1. */
    int qs[23 + 6], nq = 0;
    for (int q = 10; q <= 98; q += 4)
        qs[nq++] = q;
    for (int iq = 0; iq < nq; iq++) {
        const int q = qs[iq];
        int n;
        struct jpeg_tile *t = jpeg_encode_tiles(img, info.width, info.height,
                                                info.channels, q, &n, &p);
        if (fabs(p - psnr0) < bestd) {
            if (jt)
                for (int i = 0; i < count; i++)
                    free(jt[i].data);
            free(jt);
            jt = t;
            count = n;
            bestd = fabs(p - psnr0);
            bestq = q;
        } else {
            for (int i = 0; i < n; i++)
                free(t[i].data);
            free(t);
        }
        if (iq == 22)
            for (int dq = -3; dq <= 3; dq++)
                if (dq && bestq + dq >= 1 && bestq + dq <= 100)
                    qs[nq++] = bestq + dq;
    }
    double jp = jpeg_run(jt, count, 0), jp_c = last_cpu_rate;
    printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second; level-0 tiles, Q%d, PSNR within %.2f dB of the store)\n",
           "libjpeg-turbo, 1 thread (anchor)", jp, jp_c, bestq, bestd);
    double jw = jpeg_run(jt, count, 1), jw_c = last_cpu_rate;
    printf("%-34s %9.1f MP/s  (%.1f MP per CPU-second; rows kept, as a tile decoder writes them)\n",
           "libjpeg-turbo into a tile buffer", jw, jw_c);
    if (cpu1 > 0) {
        printf("ratio CPU reference 1 thread / libjpeg-turbo 1 thread: %.2fx  (per CPU-second %.2fx; goal >= 1.5x)\n",
               cpu1 / jp, cpu1_c / jp_c);
        printf("ratio CPU reference all cores / libjpeg-turbo 1 thread: %.2fx\n", cpun / jp);
        printf("ratio CPU reference 1 thread / libjpeg-turbo into a tile buffer: %.2fx  (per CPU-second %.2fx)\n",
               cpu1 / jw, cpu1_c / jw_c);
    }
    if (gpu > 0)
        printf("ratio GPU decode (the faster way) / libjpeg-turbo 1 thread: %.2fx\n", gpu / jp);
    return 0;
}

int main(int argc, char **argv)
{
    int want_gpu = 1, want_cpu = 1;
    while (argc > 1 && argv[1][0] == '-') {
        if (!strcmp(argv[1], "--no-gpu"))
            want_gpu = 0;
        else if (!strcmp(argv[1], "--no-cpu"))
            want_cpu = 0;
        else
            break;
        argv++;
        argc--;
    }
    if (argc < 2) {
        fprintf(stderr, "usage: decode_bench [--no-gpu] [--no-cpu] STORE [SOURCE-IMAGE]\n");
        return 2;
    }
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(argv[1], &err);
    if (!s) {
        fprintf(stderr, "%s\n", err.text);
        return 1;
    }
    const double psnr0 = load_tiles(s, argv[1]);
    if (psnr0 < 0)
        return 1;

    double cpu1 = 0, cpun = 0, cpu1_c = 0;
    if (want_cpu)
        cpu_rates(&cpu1, &cpun, &cpu1_c);

    const double gpu = gpu_rates(want_gpu);
    if (gpu < 0)
        return 1;

    return argc > 2 ? jpeg_anchor(argv[2], psnr0, cpu1, cpu1_c, cpun, gpu) : 0;
}
