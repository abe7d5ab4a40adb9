/*
 * zfield_bench.c - z-field simplification (lib/mesh/zfield.h) measured:
 *
 * 1. View-dependent refinement per frame on a 4097 x 4097 fractal height
 *    field: a camera flies a circle over it, each frame decides every
 *    vertex (screen-space error 1 px, 1080-pixel viewport, 60 degrees)
 *    and builds the mesh.  The GPU sweep (EGL) against the same rules on
 *    one CPU thread (the plain level sweep and the coarse phase), in the
 *    same run; the triangles are the same (test_zfield checks it).
 * 2. Triangle count at equal maximum error against greedy insertion
 *    (lib/mesh/tin.h): on a 1025 x 1025 crop of a DEM given as a 16-bit
 *    image (ETOPO5 in bench/zfield-speed.sh), at three vertical
 *    thresholds, the z-field mesh's measured error is handed to greedy
 *    insertion as its goal.
 *
 *   zfield_bench [--no-gpu] [--frames N] [--side N] [DEM-u16.png OFFSET]
 *
 * Prints figures and ratios; asserts nothing.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "imageio/imageio.h"
#include "mesh/tin.h"
#include "mesh/zfield.h"
#ifdef GV_ZFIELD_BENCH_EGL
#include "gpu/gpu.h"
#include "gpu/gpu_zfield.h"
#endif

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static uint64_t rng = 0x2545f4914f6cdd1dull;
static double frand(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* Diamond-square fractal, heights in metres over a 10 m grid. */
static float *fractal(uint32_t n)
{
    float *z = calloc((size_t)n * n, sizeof *z);
    if (!z)
        return NULL;
    for (uint32_t s = n - 1; s > 1; s /= 2) {
        const uint32_t h = s / 2;
        const double amp = 0.35 * 10.0 * s;
        for (uint32_t y = h; y < n; y += s)
            for (uint32_t x = h; x < n; x += s)
                z[(size_t)y * n + x] =
                    (float)((z[(size_t)(y - h) * n + x - h] + z[(size_t)(y - h) * n + x + h] +
                             z[(size_t)(y + h) * n + x - h] + z[(size_t)(y + h) * n + x + h]) / 4 +
                            amp * (frand() - 0.5));
        for (uint32_t y = 0; y < n; y += h)
            for (uint32_t x = (y / h) % 2 ? 0 : h; x < n; x += s) {
                double sum = 0;
                int k = 0;
                if (x >= h) sum += z[(size_t)y * n + x - h], k++;
                if (x + h < n) sum += z[(size_t)y * n + x + h], k++;
                if (y >= h) sum += z[(size_t)(y - h) * n + x], k++;
                if (y + h < n) sum += z[(size_t)(y + h) * n + x], k++;
                z[(size_t)y * n + x] = (float)(sum / k + amp * (frand() - 0.5));
            }
    }
    return z;
}

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

struct series {
    double t[256];
    int n;
    uint64_t tris;
};

static void report(const char *name, struct series *s, const struct series *anchor)
{
    qsort(s->t, (size_t)s->n, sizeof s->t[0], cmp_d);
    const double p50 = s->t[s->n / 2] * 1e3, worst = s->t[s->n - 1] * 1e3;
    printf("%-40s p50 %8.1f ms  max %8.1f ms  %6.2f frames/s  %9.0f triangles/frame",
           name, p50, worst, 1e3 / p50, (double)s->tris / s->n);
    if (anchor)
        printf("  x%.2f", anchor->t[anchor->n / 2] / s->t[s->n / 2]);
    printf("\n");
}

/* Part 2: triangles at equal error against greedy insertion, on a crop of
 * the 16-bit DEM at path (heights minus off). */
static int equal_error(const char *path, double off)
{
    struct gv_error err = {0};
    struct gv_image_info info;
    struct gv_image_in *in = gv_image_open(path, 1ull << 32, &info, &err);
    if (!in || info.channels != 1 || info.sample != GV_SAMPLE_U16) {
        fprintf(stderr, "zfield_bench: %s: need a 16-bit one-channel image\n", path);
        return 1;
    }
    uint16_t *img = malloc((size_t)info.width * info.height * 2);
    if (!img || gv_image_read(in, info.height, img, &err) < 0)
        return 1;
    gv_image_close(in);
    const uint32_t n = 1025;
    if (info.width < n || info.height < n)
        return 1;
    float *dem = malloc((size_t)n * n * sizeof *dem);
    uint8_t *den = malloc((size_t)n * n);
    /* A mountainous crop: the window with the largest height range among
     * a few, so that the counts are not all flat ocean. */
    uint32_t bx = 0, by = 0;
    double best = -1;
    for (uint32_t y0 = 0; y0 + n <= info.height; y0 += 256)
        for (uint32_t x0 = 0; x0 + n <= info.width; x0 += 256) {
            double lo = 1e9, hi = -1e9;
            for (uint32_t y = y0; y < y0 + n; y += 8)
                for (uint32_t x = x0; x < x0 + n; x += 8) {
                    const double v = img[(size_t)y * info.width + x];
                    lo = v < lo ? v : lo, hi = v > hi ? v : hi;
                }
            if (hi - lo > best)
                best = hi - lo, bx = x0, by = y0;
        }
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++)
            dem[(size_t)y * n + x] = (float)(img[(size_t)(by + y) * info.width + bx + x] - off);
    printf("== triangles at equal maximum error, %s crop %u,%u %ux%u (range %.0f m)\n",
           path, bx, by, n, n, best);
    const float th[] = {10.0f, 40.0f, 160.0f};
    for (int i = 0; i < 3; i++) {
        struct gv_zfield_params p = {.threshold = th[i]};
        struct gv_mesh tz, tg;
        double t0 = now();
        if (gv_zfield_enable(dem, n, &p, den, &err) < 0 ||
            gv_zfield_mesh(dem, n, den, 1, &tz, &err) < 0)
            return 1;
        const double tzt = now() - t0;
        struct gv_tin_params gp = {.max_error = tz.max_error, .border_first = 0};
        t0 = now();
        if (gv_tin_build(dem, n, n, n, &gp, &tg, &err) < 0) {
            fprintf(stderr, "tin: %s\n", err.text);
            return 1;
        }
        const double tgt = now() - t0;
        printf("threshold %5.0f m: z-field %7u triangles (max error %6.1f m, %.3f s); greedy "
               "insertion at that error %7u (%.3f s); ratio z-field / greedy %.2fx\n",
               th[i], tz.ntris, tz.max_error, tzt, tg.ntris, tgt,
               (double)tz.ntris / (tg.ntris ? tg.ntris : 1));
        gv_mesh_free(&tz);
        gv_mesh_free(&tg);
    }
    free(dem), free(den), free(img);
    return 0;
}

int main(int argc, char **argv)
{
    int want_gpu = 1, frames = 10;
    uint32_t side = 4097;
    int a = 1;
    for (; a < argc && argv[a][0] == '-'; a++) {
        if (!strcmp(argv[a], "--no-gpu"))
            want_gpu = 0;
        else if (!strcmp(argv[a], "--frames") && a + 1 < argc)
            frames = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--side") && a + 1 < argc)
            side = (uint32_t)atoi(argv[++a]);
    }
    if (frames < 1 || frames > 256 || !gv_zfield_side_ok(side)) {
        fprintf(stderr, "usage: zfield_bench [--no-gpu] [--frames 1..256] [--side 2^k+1] "
                "[DEM-u16.png OFFSET]\n");
        return 2;
    }
    struct gv_error err = {0};
    const size_t cells = (size_t)side * side;
    float *z = fractal(side);
    uint8_t *en = malloc(cells);
    if (!z || !en)
        return 1;
    const float xy = 10.0f;
    const float k = gv_zfield_k(1080, 60.0 * M_PI / 180.0);
    printf("== view-dependent refinement, %ux%u fractal (10 m grid), 1 px at 1080 px, "
           "60 deg, %d frames\n", side, side, frames);
    struct series cpu = {0}, cpu_sweep = {0}, gpu = {0}, gpu_frag = {0};
    for (int pass = 0; pass < 4; pass++) {
#ifndef GV_ZFIELD_BENCH_EGL
        if (pass >= 2)
            break;
#endif
        struct series *s = pass == 0 ? &cpu : pass == 1 ? &cpu_sweep : pass == 2 ? &gpu
                                                                                  : &gpu_frag;
#ifdef GV_ZFIELD_BENCH_EGL
        struct gv_gpu *g = NULL;
        struct gv_gpu_zfield *zf = NULL;
        if (pass >= 2) {
            if (!want_gpu)
                break;
            g = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
            if (!g || !(zf = gv_gpu_zfield_new_path(g, pass == 2 ? GV_ZFIELD_COMPUTE
                                                                 : GV_ZFIELD_FRAGMENT, &err)) ||
                gv_gpu_zfield_heights(zf, z, side, &err) < 0) {
                printf("GPU: unavailable: %s\n", err.text);
                break;
            }
            if (pass == 2)
                printf("# GPU: %s\n", gv_gpu_info(g)->renderer);
        }
#endif
        for (int f = 0; f < frames; f++) {
            const double ang = 2 * M_PI * f / frames, c = (side - 1) * xy / 2;
            struct gv_zfield_params p = {.mode = GV_ZFIELD_SCREEN, .threshold = 1.0f, .k = k,
                                         .xy_scale = xy, .no_coarse = pass == 1,
                                         .eye = {(float)(c + 0.6 * c * cos(ang)),
                                                 (float)(c + 0.6 * c * sin(ang)), 3000.0f}};
            const double t0 = now();
            int rc;
#ifdef GV_ZFIELD_BENCH_EGL
            if (pass >= 2)
                rc = gv_gpu_zfield_enable(zf, &p, en, &err);
            else
#endif
                rc = gv_zfield_enable(z, side, &p, en, &err);
            struct gv_mesh t;
            if (rc < 0 || gv_zfield_mesh(z, side, en, 0, &t, &err) < 0) {
                fprintf(stderr, "zfield: %s\n", err.text);
                return 1;
            }
            s->t[s->n++] = now() - t0;
            s->tris += t.ntris;
            gv_mesh_free(&t);
        }
#ifdef GV_ZFIELD_BENCH_EGL
        gv_gpu_zfield_free(zf);
        gv_gpu_close(g);
#endif
    }
    report("CPU, 1 thread, coarse phase + sweep", &cpu, NULL);
    report("CPU, 1 thread, plain level sweep", &cpu_sweep, NULL);
    if (gpu.n) {
        report("GPU sweep (EGL), compute + mesh", &gpu, NULL);
        if (gpu_frag.n)
            report("GPU sweep (EGL), fragment + mesh", &gpu_frag, NULL);
        printf("ratio GPU / CPU (frames per second): %.2fx against the coarse phase, "
               "%.2fx against the plain sweep\n", cpu.t[cpu.n / 2] / gpu.t[gpu.n / 2],
               cpu_sweep.t[cpu_sweep.n / 2] / gpu.t[gpu.n / 2]);
    }
    free(en);
    free(z);

    if (a + 1 >= argc)
        return 0;
    return equal_error(argv[a], atof(argv[a + 1]));
}
