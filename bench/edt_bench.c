/*
 * edt_bench.c - distance transform speed and accuracy (bench/edt-speed.sh
 * drives it; the anchors OpenCV and SciPy run from bench/edt_anchor.py
 * on the same .npy input).
 *
 *   edt_bench gen SIZE DENSITY SEED OUT.npy
 *       a SIZE x SIZE uint8 mask, 0 at the sites (each pixel a site with
 *       probability DENSITY), 1 elsewhere: the convention of OpenCV's
 *       distanceTransform and SciPy's distance_transform_edt.
 *   edt_bench run MASK.npy [-t THREADS] [-r REPS] [-m METHOD,...]
 *                [-e] [-c NAME=DIST.npy ...]
 *       times each method (best of REPS, wall clock, output buffer
 *       allocated per call as the Python anchors do) and prints
 *         method NAME WxH MS MPX_S CPU_MS
 *       (CPU_MS: the best CPU time of the process over a call, every
 *       thread counted: a figure that other load on the machine barely
 *       moves)
 *       -e: also compares every method's distances, and each -c float32
 *       distance file, with the exact EDT (tests/edt_exact.c) and prints
 *         error NAME MAX_ABS_ERR ERRING_PIXELS PIXELS
 *       (a pixel errs when |d - exact| > 1e-3 px).
 *
 * Methods are rows of `methods[]`; built with -DGV_EDT_BENCH_EGL against
 * a build's libraries, egl-frag and egl-compute run the stock distance
 * transform graph on the EGL context.  Prints figures only; asserts
 * nothing.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "edt_cpu.h"
#include "edt_exact.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* CPU seconds of the whole process (every thread). */
static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

static _Noreturn void die(const char *msg)
{
    fprintf(stderr, "edt_bench: %s\n", msg);
    exit(1);
}

/* ---------------------------------------------------------------- npy */

static void npy_write(const char *path, const char *descr, const void *data,
                      size_t elem, uint32_t w, uint32_t h)
{
    char dict[128];
    int len = snprintf(dict, sizeof dict,
                       "{'descr': '%s', 'fortran_order': False, "
                       "'shape': (%u, %u), }", descr, h, w);
    /* magic(6) + version(2) + length(2) + dict, padded with spaces and a
     * newline to a multiple of 64 */
    int hl = (len + 1 + 10 + 63) / 64 * 64 - 10;
    FILE *f = fopen(path, "wb");
    if (!f)
        die("cannot write the .npy file");
    fwrite("\x93NUMPY\x01\x00", 1, 8, f);
    fputc(hl & 0xff, f);
    fputc(hl >> 8, f);
    fwrite(dict, 1, (size_t)len, f);
    for (int i = len; i < hl - 1; i++)
        fputc(' ', f);
    fputc('\n', f);
    if (fwrite(data, elem, (size_t)w * h, f) != (size_t)w * h || fclose(f))
        die("short write");
}

/* Reads a 2-D C-order array of `descr` ("|u1" or "<f4"). */
static void *npy_read(const char *path, const char *descr, size_t elem,
                      uint32_t *w, uint32_t *h)
{
    unsigned char pre[10];
    char dict[4096];
    FILE *f = fopen(path, "rb");
    if (!f || fread(pre, 1, 10, f) != 10 || memcmp(pre, "\x93NUMPY", 6))
        die("not a .npy file");
    size_t hl = pre[8] | (size_t)pre[9] << 8;
    if (pre[6] != 1 || hl >= sizeof dict || fread(dict, 1, hl, f) != hl)
        die("unsupported .npy header");
    dict[hl] = 0;
    char want[32];
    snprintf(want, sizeof want, "'descr': '%s'", descr);
    const char *shape = strstr(dict, "'shape': (");
    unsigned hh, ww;
    if (!strstr(dict, want) || !strstr(dict, "'fortran_order': False") ||
        !shape || sscanf(shape + 10, "%u, %u", &hh, &ww) != 2)
        die("expected a 2-D C-order array of the right type");
    *w = ww;
    *h = hh;
    void *data = malloc((size_t)ww * hh * elem);
    if (!data || fread(data, elem, (size_t)ww * hh, f) != (size_t)ww * hh)
        die("short .npy file");
    fclose(f);
    return data;
}

/* ---------------------------------------------------------------- methods */

static int nthreads;

static int run_cpu(const uint32_t *ids, uint32_t w, uint32_t h, int threads,
                   int sites, float *dist)
{
    struct gv_error err = {0};
    struct gv_edt_out o = {NULL, NULL, NULL, dist};
    size_t n = (size_t)w * h;
    if (sites) {
        o.site_x = malloc(n * sizeof *o.site_x);
        o.site_y = malloc(n * sizeof *o.site_y);
        o.site_id = malloc(n * sizeof *o.site_id);
        if (!o.site_x || !o.site_y || !o.site_id)
            die("out of memory");
    }
    int rc = gv_edt_cpu(ids, w, h, threads, &o, &err);
    if (rc)
        fprintf(stderr, "edt_bench: %s\n", err.text);
    free(o.site_x);
    free(o.site_y);
    free(o.site_id);
    return rc;
}

static int m_cpu1(const uint32_t *ids, uint32_t w, uint32_t h, float *dist)
{
    return run_cpu(ids, w, h, 1, 0, dist);
}

static int m_cpu(const uint32_t *ids, uint32_t w, uint32_t h, float *dist)
{
    return run_cpu(ids, w, h, nthreads, 0, dist);
}

static int m_cpu_sites(const uint32_t *ids, uint32_t w, uint32_t h,
                       float *dist)
{
    return run_cpu(ids, w, h, nthreads, 1, dist);
}

#ifdef GV_EDT_BENCH_EGL
/*
 * The EGL path: the stock graph filters/library/distance-transform.json
 * (feature = red channel >= 0.5) run by gv_filter_run on the whole image,
 * fragment or compute propagation.  Timed as a service would see it: the
 * RGBA upload, the four sweeps, the distance pass and the read-back of
 * the float result.  The context and the parsed graph are made once.
 */
#include "filter.h"
#include "gpu/gpu.h"

static struct gv_gpu *egl;
static struct gv_filter_graph *egl_graph;
static double egl_params[16];

static int egl_setup(void)
{
    if (egl)
        return 0;
    struct gv_error err = {0};
    const char *path = getenv("GV_EDT_GRAPH");
    FILE *f = path ? fopen(path, "rb") : NULL;
    if (!f)
        return fprintf(stderr, "edt_bench: set GV_EDT_GRAPH to distance-transform.json\n"), -1;
    char *doc = malloc(1 << 20);
    size_t n = doc ? fread(doc, 1, (1 << 20) - 1, f) : 0;
    fclose(f);
    if (!doc)
        return -1;
    egl_graph = gv_filter_graph_parse(doc, n, NULL, &err);
    free(doc);
    json_t *given = json_pack("{s:{s:f, s:f}}", "features", "channel", 0.0, "threshold", 0.5);
    if (!egl_graph || gv_filter_params(egl_graph, given, egl_params, &err) < 0 ||
        !(egl = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err))) {
        json_decref(given);
        return fprintf(stderr, "edt_bench: %s\n", err.text), -1;
    }
    json_decref(given);
    fprintf(stderr, "# egl: %s\n", gv_gpu_info(egl)->renderer);
    return 0;
}

static int run_egl(const uint32_t *ids, uint32_t w, uint32_t h, float *dist,
                   enum gv_filter_path path)
{
    if (egl_setup() < 0)
        return -1;
    size_t n = (size_t)w * h;
    uint8_t *rgba = malloc(n * 4);
    if (!rgba)
        die("out of memory");
    for (size_t i = 0; i < n; i++) {
        rgba[i * 4] = ids[i] ? 255 : 0;
        rgba[i * 4 + 1] = rgba[i * 4 + 2] = 0;
        rgba[i * 4 + 3] = 255;
    }
    struct gv_filter_input in = {.w = w, .h = h, .rgba = rgba, .roi_w = w, .roi_h = h,
                                 .params = egl_params, .path = path};
    float *out = NULL;
    struct gv_error err = {0};
    int rc = gv_filter_run(egl, egl_graph, &in, &out, NULL, &err);
    if (rc)
        fprintf(stderr, "edt_bench: %s\n", err.text);
    for (size_t i = 0; rc == 0 && i < n; i++)
        dist[i] = out[i * 4];
    free(out);
    free(rgba);
    return rc;
}

static int m_egl_frag(const uint32_t *ids, uint32_t w, uint32_t h, float *dist)
{
    return run_egl(ids, w, h, dist, GV_FILTER_PATH_FRAGMENT);
}

static int m_egl_compute(const uint32_t *ids, uint32_t w, uint32_t h, float *dist)
{
    return run_egl(ids, w, h, dist, GV_FILTER_PATH_COMPUTE);
}
#endif

struct method {
    const char *name;
    const char *what;
    int (*run)(const uint32_t *ids, uint32_t w, uint32_t h, float *dist);
};

static const struct method methods[] = {
    {"cpu1", "gv_edt_cpu, 1 thread, distances only", m_cpu1},
    {"cpu", "gv_edt_cpu, every core, distances only", m_cpu},
    {"cpu+sites", "gv_edt_cpu, every core, distances, sites and ids",
     m_cpu_sites},
#ifdef GV_EDT_BENCH_EGL
    {"egl-frag", "stock graph on EGL, fragment sweeps (one draw per line)", m_egl_frag},
    {"egl-compute", "stock graph on EGL, compute sweeps (32 lines per dispatch)",
     m_egl_compute},
#endif
};

static const struct method *find_method(const char *name)
{
    for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++)
        if (strcmp(methods[i].name, name) == 0)
            return &methods[i];
    return NULL;
}

/* ---------------------------------------------------------------- errors */

static void report_error(const char *name, const float *dist,
                         const uint64_t *exact, size_t n)
{
    double max = 0;
    size_t bad = 0;
    for (size_t p = 0; p < n; p++) {
        double e = fabs((double)dist[p] - sqrt((double)exact[p]));
        if (e > 1e-3)
            bad++;
        if (e > max)
            max = e;
    }
    printf("error %s %.6f %zu %zu\n", name, max, bad, n);
    fflush(stdout);
}

/* ---------------------------------------------------------------- main */

static int cmd_gen(int argc, char **argv)
{
    if (argc != 6)
        die("usage: edt_bench gen SIZE DENSITY SEED OUT.npy");
    uint32_t s = (uint32_t)strtoul(argv[2], NULL, 10);
    double dens = strtod(argv[3], NULL);
    uint64_t x = strtoull(argv[4], NULL, 10) * 0x9e3779b97f4a7c15ull + 1;
    size_t n = (size_t)s * s;
    uint8_t *m = malloc(n ? n : 1);
    if (!s || !m)
        die("bad size");
    uint64_t thr = (uint64_t)(dens * 18446744073709551616.0);
    for (size_t p = 0; p < n; p++) {
        x ^= x << 13;   /* xorshift64 */
        x ^= x >> 7;
        x ^= x << 17;
        m[p] = x < thr ? 0 : 1;
    }
    npy_write(argv[5], "|u1", m, 1, s, s);
    free(m);
    return 0;
}

static int cmd_run(int argc, char **argv)
{
    int reps = 3, exact = 0;
    const char *list = "cpu1,cpu,cpu+sites";
    char *cmp[8];
    int ncmp = 0;
    nthreads = (int)sysconf(_SC_NPROCESSORS_ONLN);
    if (argc < 3)
        die("usage: edt_bench run MASK.npy [-t N] [-r REPS] [-m M,...] [-e] "
            "[-c NAME=FILE.npy]");
    for (int i = 3; i < argc; i++) {
        if (!strcmp(argv[i], "-t") && i + 1 < argc)
            nthreads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "-r") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "-m") && i + 1 < argc)
            list = argv[++i];
        else if (!strcmp(argv[i], "-e"))
            exact = 1;
        else if (!strcmp(argv[i], "-c") && i + 1 < argc && ncmp < 8)
            cmp[ncmp++] = argv[++i];
        else
            die("bad argument");
    }
    uint32_t w, h;
    uint8_t *mask = npy_read(argv[2], "|u1", 1, &w, &h);
    size_t n = (size_t)w * h;
    uint32_t *ids = malloc(n * sizeof *ids), next = 1, sites = 0;
    if (!ids)
        die("out of memory");
    for (size_t p = 0; p < n; p++)
        ids[p] = mask[p] ? 0 : (sites++, next++);
    free(mask);
    printf("# %ux%u, %u sites, %d threads, kernels %s, best of %d\n", w, h,
           sites, nthreads, gv_edt_cpu_isa(), reps);

    uint64_t *ex = NULL;
    if (exact || ncmp) {
        double t0 = now();
        ex = malloc(n * sizeof *ex);
        if (!ex || edt_exact_d2(ids, w, h, ex) != 0)
            die("exact EDT failed");
        printf("# exact EDT (Felzenszwalb-Huttenlocher, 1 thread): %.0f ms\n",
               (now() - t0) * 1e3);
    }
    char *names = strdup(list);
    for (char *save = NULL, *name = strtok_r(names, ",", &save); name;
         name = strtok_r(NULL, ",", &save)) {
        const struct method *m = find_method(name);
        if (!m) {
            printf("# unknown method %s\n", name);
            continue;
        }
        double best = 1e30, best_cpu = 1e30;
        float *keep = NULL;
        for (int r = 0; r < reps; r++) {
            double t0 = now(), c0 = cpu_now();
            float *dist = malloc(n * sizeof *dist);
            if (!dist || m->run(ids, w, h, dist) != 0)
                die("method failed");
            double t = now() - t0, c = cpu_now() - c0;
            if (t < best)
                best = t;
            if (c < best_cpu)
                best_cpu = c;
            if (ex && !keep)
                keep = dist;
            else
                free(dist);
        }
        printf("method %s %ux%u %.2f %.1f %.2f\n", m->name, w, h,
               best * 1e3, (double)n / best / 1e6, best_cpu * 1e3);
        fflush(stdout);
        if (keep)
            report_error(m->name, keep, ex, n);
        free(keep);
    }
    free(names);
    for (int i = 0; i < ncmp; i++) {
        char *eq = strchr(cmp[i], '=');
        uint32_t cw, ch;
        if (!eq)
            die("-c NAME=FILE.npy");
        *eq = 0;
        float *d = npy_read(eq + 1, "<f4", 4, &cw, &ch);
        if (cw != w || ch != h)
            die("-c: size differs from the mask");
        report_error(cmp[i], d, ex, n);
        free(d);
    }
    free(ex);
    free(ids);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "gen"))
        return cmd_gen(argc, argv);
    if (argc >= 2 && !strcmp(argv[1], "run"))
        return cmd_run(argc, argv);
    die("usage: edt_bench gen|run ...");
}
