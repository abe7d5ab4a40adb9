/*
 * test_filter_elevation.c - the elevation graphs (filters/library/
 * {hillshade,slope,aspect,contours}.json, docs/FILTERS.md section 8.5) on
 * the GPU (EGL; llvmpipe in CI) against their CPU references
 * (tests/filter_ref_elevation.c), against known answers, and against GDAL.
 *
 * 1. A real DEM: tests/data/etopo-600x400-u16.png brought to 8 bits as
 *    `gigaview encode --range 1360:11560` would (40 m per gray level, gray
 *    0 at -9640 m, pixels taken as 8000 m).  Each graph runs on three ROIs
 *    of 160 x 120 (two corners, where the padding is cut by the image's
 *    edges, and one in the middle) with the default parameters and two
 *    other sets, padded as the server pads them, against its reference on
 *    the whole image.  Tolerance: 1 LSB after the PNG conversion (the
 *    library's), and for aspect and contours the same decision on every
 *    pixel (flat or not; on a line or not), except pixels whose decision
 *    hangs on float rounding (ref_elevation_ambiguous), which are counted.
 *    Then every parameter at its minimum, its maximum and alternately:
 *    finite results that still agree with the reference.
 * 2. Known answers on synthetic DEMs: planes of known slope and aspect,
 *    a cone whose aspects point outward, a flat field, a ramp whose
 *    contours fall on known columns.
 * 3. GDAL: where `gdaldem` is installed (gdal-bin), hillshade, slope
 *    (degrees and percent) and aspect of the whole DEM against gdaldem's
 *    on every pixel not on the image's edge (gdaldem leaves the edge as
 *    nodata).  Tolerances: hillshade 1 LSB of gdaldem's byte; slope
 *    0.001 degree / 0.001 percent; aspect 0.01 degree, flat exactly where
 *    gdaldem has nodata.  Contours are lines in gdal_contour (vectors), so
 *    they are not compared.
 *
 * GV_ELEV_DEM=FILE GV_ELEV_RANGE=LO:HI GV_ELEV_M=M GV_ELEV_PIXEL=P [GV_ELEV_LABEL] (used
 * by bench/elevation-filters.sh) run only part 3 on another DEM, with
 * timings.  Without an EGL context the graphs are parsed and the rest is
 * skipped.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <jansson.h>

#include "encode/source.h"
#include "filter.h"
#include "filter_ref.h"
#include "gpu/gpu.h"
#include "test_env.h"
#include "util.h"

#define ROI_W 160
#define ROI_H 120
#define PI 3.14159265358979323846

/* An 8-bit gray DEM as RGBA8 and as floats / 255. */
struct dem {
    int w, h;
    uint8_t *rgba;
    float *f;
};

enum { HILLSHADE, SLOPE, ASPECT, CONTOURS, NGRAPH };

static const struct graph {
    const char *file;
    ref_fn ref;
    const char *params[5];     /* the reference's p[i], in module `file` */
    const char *given[2];      /* two more parameter sets for the DEM */
} graphs[NGRAPH] = {
    {"hillshade", ref_hillshade,
     {"azimuth", "altitude", "z_factor", "metres_per_level", "pixel_size"},
     {"{\"hillshade\": {\"metres_per_level\": 40, \"pixel_size\": 8000, \"z_factor\": 20}}",
      "{\"hillshade\": {\"azimuth\": 120, \"altitude\": 30, \"z_factor\": 50, "
      "\"metres_per_level\": 40, \"pixel_size\": 8000}}"}},
    {"slope", ref_slope, {"percent", "full_scale", "metres_per_level", "pixel_size"},
     {"{\"slope\": {\"full_scale\": 2, \"metres_per_level\": 40, \"pixel_size\": 8000}}",
      "{\"slope\": {\"percent\": 1, \"full_scale\": 3.5, \"metres_per_level\": 40, "
      "\"pixel_size\": 8000}}"}},
    {"aspect", ref_aspect, {"flat_slope", "metres_per_level", "pixel_size"},
     {"{\"aspect\": {\"metres_per_level\": 40, \"pixel_size\": 8000}}",
      "{\"aspect\": {\"flat_slope\": 0.3, \"metres_per_level\": 40, \"pixel_size\": 8000}}"}},
    {"contours", ref_contours, {"interval", "offset", "base", "metres_per_level", "show_dem"},
     {"{\"contours\": {\"interval\": 500, \"base\": -9640, \"metres_per_level\": 40}}",
      "{\"contours\": {\"interval\": 1000, \"offset\": 250, \"base\": -9640, "
      "\"metres_per_level\": 40, \"show_dem\": 0}}"}},
};

static struct gv_filter_graph *parsed[NGRAPH];

static int png8(float v)
{
    if (isnan(v))
        return -1000;
    return (int)floor((v < 0 ? 0 : v > 1 ? 1 : v) * 255.0 + 0.5);
}

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

static void dem_alloc(struct dem *d, int w, int h)
{
    d->w = w, d->h = h;
    d->rgba = malloc((size_t)w * h * 4);
    d->f = malloc(sizeof *d->f * (size_t)w * h * 4);
    if (!d->rgba || !d->f)
        fail("out of memory");
}

static void dem_set(struct dem *d, int x, int y, int u)
{
    uint8_t *q = d->rgba + ((size_t)y * d->w + x) * 4;
    q[0] = q[1] = q[2] = (uint8_t)u;
    q[3] = 255;
    for (int k = 0; k < 4; k++)
        d->f[((size_t)y * d->w + x) * 4 + k] = q[k] / 255.0f;
}

static int dem_get(const struct dem *d, int x, int y)
{
    return d->rgba[((size_t)y * d->w + x) * 4];
}

static void dem_free(struct dem *d)
{
    free(d->rgba);
    free(d->f);
}

/* A gray DEM brought to 8 bits by --range lo:hi, as the encoder does. */
static void load_dem(struct dem *d, const char *path, double lo, double hi)
{
    const char *in[1] = {path};
    struct gv_source_opts o = {0};
    o.range_lo = lo, o.range_hi = hi;
    struct gv_source_info info;
    struct gv_error err = {0};
    struct gv_source *s = gv_source_open(in, 1, &o, &info, &err);
    if (!s)
        fail("open %s: %s", path, err.text);
    const int c = info.channels;
    uint8_t *all = malloc((size_t)info.width * info.height * (size_t)c);
    if (!all || gv_source_read(s, info.height, all, &err) < 0)
        fail("read %s: %s", path, all ? err.text : "out of memory");
    gv_source_free(s);
    dem_alloc(d, (int)info.width, (int)info.height);
    for (int y = 0; y < d->h; y++)
        for (int x = 0; x < d->w; x++)
            dem_set(d, x, y, all[((size_t)y * d->w + x) * (size_t)c]);
    free(all);
}

static char *read_text(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    if (fseek(f, 0, SEEK_END) < 0) {
        fclose(f);
        return NULL;
    }
    const long n = ftell(f);
    rewind(f);
    char *buf = n >= 0 ? malloc((size_t)n + 1) : NULL;
    *len = buf ? fread(buf, 1, (size_t)n, f) : 0;
    fclose(f);
    if (buf)
        buf[*len] = 0;
    return buf;
}

/* Parameter values of graph gi: defaults overridden by `given` (JSON or
 * NULL); p gets the reference's order. */
static double *params_of(int gi, const char *given, double *p)
{
    const struct gv_filter_graph *g = parsed[gi];
    double *values = calloc((size_t)g->nparams + 1, sizeof *values);
    if (!values)
        fail("out of memory");
    json_t *gj = NULL;
    if (given) {
        json_error_t je;
        gj = json_loads(given, 0, &je);
        if (!gj)
            fail("%s: bad test parameters: %s", graphs[gi].file, je.text);
    }
    struct gv_error err = {0};
    if (gv_filter_params(g, gj, values, &err) < 0)
        fail("%s: params: %s", graphs[gi].file, err.text);
    json_decref(gj);
    const int m = gv_filter_graph_find(g, graphs[gi].file);
    if (m < 0)
        fail("%s: no module %s", graphs[gi].file, graphs[gi].file);
    for (int i = 0; i < 5 && graphs[gi].params[i]; i++) {
        int k = -1;
        for (int q = 0; q < g->module[m].nparams; q++)
            if (!strcmp(g->module[m].param[q].name, graphs[gi].params[i]))
                k = q;
        if (k < 0)
            fail("%s: no parameter %s", graphs[gi].file, graphs[gi].params[i]);
        p[i] = values[g->module[m].param_base + k];
    }
    return values;
}

/* Run graph gi over the ROI (rx, ry, rw, rh) of d, padded as the server
 * pads it.  Returns the ROI's RGBA floats (NULL with a failed check). */
static float *run_gpu(struct gv_gpu *gpu, int gi, const struct dem *d, int rx, int ry,
                      int rw, int rh, const double *values, double *ms)
{
    const struct gv_filter_graph *g = parsed[gi];
    int x0 = rx - g->pad_left, y0 = ry - g->pad_top;
    int x1 = rx + rw + g->pad_right, y1 = ry + rh + g->pad_bottom;
    x0 = x0 < 0 ? 0 : x0 / g->align * g->align;
    y0 = y0 < 0 ? 0 : y0 / g->align * g->align;
    x1 = x1 > d->w ? d->w : x1;
    y1 = y1 > d->h ? d->h : y1;
    const int w = x1 - x0, h = y1 - y0;
    uint8_t *buf = malloc((size_t)w * h * 4);
    if (!buf)
        fail("out of memory");
    for (int y = 0; y < h; y++)
        memcpy(buf + (size_t)y * w * 4, d->rgba + ((size_t)(y0 + y) * d->w + x0) * 4,
               (size_t)w * 4);
    struct gv_filter_input in = {
        .w = (uint32_t)w, .h = (uint32_t)h, .rgba = buf,
        .roi_x = (uint32_t)(rx - x0), .roi_y = (uint32_t)(ry - y0),
        .roi_w = (uint32_t)rw, .roi_h = (uint32_t)rh, .abs_x = x0, .abs_y = y0,
        .params = values};
    float *out = NULL;
    struct gv_error err = {0};
    const double t0 = now_ms();
    if (gv_filter_run(gpu, g, &in, &out, NULL, &err) < 0) {
        check(0, "%s: gv_filter_run: %s", graphs[gi].file, err.text);
        out = NULL;
    }
    if (ms)
        *ms = now_ms() - t0;
    free(buf);
    return out;
}

static struct ref_region whole(const struct dem *d, int rx, int ry, int rw, int rh)
{
    struct ref_region rr = {{d->w, d->h, d->f}, rx, ry, rw, rh, 0, 0};
    return rr;
}

/* ------------------------------------------------ 1. GPU against CPU */

static struct worst {
    int lsb, runs;
    long decided, ambiguous;   /* decisions (flat, line) differing; set aside */
} worst[NGRAPH];

static void gpu_vs_ref(struct gv_gpu *gpu, int gi, const struct dem *d, int rx, int ry,
                       const char *given, int set, const char *where)
{
    const struct graph *gr = &graphs[gi];
    double p[5] = {0};
    double *values = params_of(gi, given, p);
    float *out = run_gpu(gpu, gi, d, rx, ry, ROI_W, ROI_H, values, NULL);
    float *ref = malloc(sizeof *ref * ROI_W * ROI_H * 4);
    const struct ref_region rr = whole(d, rx, ry, ROI_W, ROI_H);
    if (!ref || gr->ref(&rr, p, ref, NULL) < 0)
        fail("out of memory");
    if (out) {
        int lsb = 0;
        long bad = 0, amb = 0, first = -1;
        for (int j = 0; j < ROI_H; j++)
            for (int i = 0; i < ROI_W; i++) {
                const size_t k = ((size_t)j * ROI_W + i) * 4;
                const int a = png8(out[k]), b = png8(ref[k]);
                int differs = abs(a - b) > 1;
                if (gi == ASPECT)
                    differs |= (out[k] == 0.0f) != (ref[k] == 0.0f);
                if (gi == CONTOURS)
                    differs = a != b;
                if (differs && gi != HILLSHADE && gi != SLOPE &&
                    ref_elevation_ambiguous(gr->ref, &rr, p, i, j)) {
                    amb++;
                    continue;
                }
                if (abs(a - b) > lsb && !(gi == CONTOURS && !differs))
                    lsb = abs(a - b);
                if (differs) {
                    bad++;
                    if (first < 0) {
                        first = (long)(k / 4);
                        printf("# %s: first difference at ROI (%d, %d): gpu %g ref %g\n",
                               gr->file, i, j, out[k], ref[k]);
                    }
                }
            }
        struct worst *wo = &worst[gi];
        wo->runs++;
        wo->lsb = lsb > wo->lsb ? lsb : wo->lsb;
        wo->decided += bad;
        wo->ambiguous += amb;
        check(bad == 0, "%s, %s ROI %dx%d at (%d,%d), %s%.0d: max %d LSB, %ld pixels "
              "differ, %ld set aside as ambiguous", gr->file, where, ROI_W, ROI_H, rx, ry,
              set ? "parameter set " : "default parameters", set, lsb, bad, amb);
    }
    free(ref);
    free(out);
    free(values);
}

/* Every parameter at its minimum, then at its maximum, then alternating:
 * the result stays finite (no division by zero, no NaN) and agrees with
 * the reference within 1 LSB. */
static void extremes(struct gv_gpu *gpu, int gi, const struct dem *d)
{
    const struct gv_filter_graph *g = parsed[gi];
    const int m = gv_filter_graph_find(g, graphs[gi].file);
    for (int mode = 0; mode < 3; mode++) {
        char given[1024];
        size_t n = (size_t)snprintf(given, sizeof given, "{\"%s\": {", graphs[gi].file);
        for (int q = 0; q < g->module[m].nparams; q++) {
            const struct gv_filter_param *pa = &g->module[m].param[q];
            const int hi = mode == 2 ? q % 2 : mode;
            n += (size_t)snprintf(given + n, sizeof given - n, "%s\"%s\": %.17g", q ? ", " : "",
                                  pa->name, hi ? pa->max : pa->min);
        }
        snprintf(given + n, sizeof given - n, "}}");
        double p[5] = {0};
        double *values = params_of(gi, given, p);
        float *out = run_gpu(gpu, gi, d, 100, 100, ROI_W, ROI_H, values, NULL);
        free(values);
        if (!out)
            continue;
        float *ref = malloc(sizeof *ref * ROI_W * ROI_H * 4);
        const struct ref_region rr = whole(d, 100, 100, ROI_W, ROI_H);
        if (!ref || graphs[gi].ref(&rr, p, ref, NULL) < 0)
            fail("out of memory");
        long nonfinite = 0, bad = 0;
        for (size_t k = 0; k < (size_t)ROI_W * ROI_H * 4; k += 4) {
            nonfinite += !isfinite(out[k]);
            if (abs(png8(out[k]) - png8(ref[k])) > 1 &&
                !ref_elevation_ambiguous(graphs[gi].ref, &rr, p, (int)(k / 4 % ROI_W),
                                         (int)(k / 4 / ROI_W)))
                bad++;
        }
        check(nonfinite == 0 && bad == 0, "%s with every parameter at its %s: finite (%ld "
              "not), the reference within 1 LSB (%ld differ)", graphs[gi].file,
              mode == 0 ? "minimum" : mode == 1 ? "maximum" : "minimum or maximum, alternating",
              nonfinite, bad);
        free(out);
        free(ref);
    }
}

/* ------------------------------------------------ 2. known answers */

/* Run graph gi with `given` over the whole synthetic DEM d; the CPU
 * reference must give the same within 1 LSB (and so be right too). */
static float *run_whole(struct gv_gpu *gpu, int gi, const struct dem *d, const char *given,
                        double *p)
{
    double *values = params_of(gi, given, p);
    float *out = run_gpu(gpu, gi, d, 0, 0, d->w, d->h, values, NULL);
    free(values);
    if (!out)
        fail("%s: no result", graphs[gi].file);
    return out;
}

static float *ref_whole(int gi, const struct dem *d, const double *p)
{
    float *ref = malloc(sizeof *ref * (size_t)d->w * d->h * 4);
    const struct ref_region rr = whole(d, 0, 0, d->w, d->h);
    if (!ref || graphs[gi].ref(&rr, p, ref, NULL) < 0)
        fail("out of memory");
    return ref;
}

/* The largest |value(v) - want| over the interior (1 px from the edges)
 * of GPU and reference results, value() decoding the output. */
static double worst_interior(const struct dem *d, const float *gpu, const float *ref,
                             double (*value)(float), double want)
{
    double e = 0;
    for (int y = 1; y < d->h - 1; y++)
        for (int x = 1; x < d->w - 1; x++) {
            const size_t k = ((size_t)y * d->w + x) * 4;
            const double a = fabs(value(gpu[k]) - want), b = fabs(value(ref[k]) - want);
            e = a > e || isnan(a) ? a : e;
            e = b > e || isnan(b) ? b : e;
        }
    return e;
}

static double as_is(float v) { return v; }
static double as_aspect(float v) { return v == 0 ? -1 : (255.0 * v - 1) * 360.0 / 254.0; }
static double as_byte(float v) { return 255.0 * v; }

static double plane_slope(struct gv_gpu *gpu, const struct dem *d, const char *given,
                          double want)
{
    double p[5];
    float *out = run_whole(gpu, SLOPE, d, given, p);
    float *ref = ref_whole(SLOPE, d, p);
    const double e = worst_interior(d, out, ref, as_is, want);
    free(out);
    free(ref);
    return e;
}

static double plane_value(struct gv_gpu *gpu, int gi, const struct dem *d, const char *given,
                          double (*value)(float), double want)
{
    double p[5];
    float *out = run_whole(gpu, gi, d, given, p);
    float *ref = ref_whole(gi, d, p);
    const double e = worst_interior(d, out, ref, value, want);
    free(out);
    free(ref);
    return e;
}

static void known_answers(struct gv_gpu *gpu)
{
    struct dem d;
    dem_alloc(&d, 64, 48);

    /* A plane rising 2 gray levels per pixel towards the east: with 1 m
     * per level and 2 m pixels, a grade of 1 (45 degrees, 100 %), facing
     * west (270). */
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, 2 * x);
    double e = plane_slope(gpu, &d, "{\"slope\": {\"pixel_size\": 2, \"full_scale\": 90}}",
                           0.5);
    check(e <= 1e-4, "slope of a 45-degree plane: 45 degrees (max error %.2g of full scale)",
          e);
    e = plane_slope(gpu, &d,
                    "{\"slope\": {\"pixel_size\": 2, \"percent\": 1, \"full_scale\": 200}}", 0.5);
    check(e <= 1e-4, "slope of a 45-degree plane: 100 %% (max error %.2g of full scale)", e);
    e = plane_slope(gpu, &d,
                    "{\"slope\": {\"pixel_size\": 8, \"metres_per_level\": 0.5, "
                    "\"full_scale\": 1}}", atan(0.125) * 180 / PI);
    check(e <= 1e-3, "slope with 0.5 m per level and 8 m pixels: atan(1/8) = 7.125 degrees "
          "(max error %.2g degree)", e);
    e = plane_value(gpu, ASPECT, &d, NULL, as_aspect, 270);
    check(e <= 0.01, "aspect of a plane rising east: 270 (west), max error %.2g degree", e);
    e = plane_value(gpu, HILLSHADE, &d,
                    "{\"hillshade\": {\"pixel_size\": 2, \"azimuth\": 270}}", as_byte, 255);
    check(e <= 0.01, "hillshade of a 45-degree slope facing a sun at 270/45: 255 (max error "
          "%.2g)", e);
    e = plane_value(gpu, HILLSHADE, &d,
                    "{\"hillshade\": {\"pixel_size\": 2, \"azimuth\": 90}}", as_byte, 1);
    check(e <= 0.01, "hillshade of a 45-degree slope facing away from a sun at 90/45: 1 "
          "(max error %.2g)", e);
    e = plane_value(gpu, HILLSHADE, &d, "{\"hillshade\": {\"pixel_size\": 2}}", as_byte,
                    1 + 254 * (0.5 + sqrt(0.5)) / sqrt(2));
    check(e <= 0.01, "hillshade of that slope, sun at 315/45: 1 + 254 cos i = 217.81 (max "
          "error %.2g)", e);

    /* Planes rising south and north: facing north (0) and south (180). */
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, 3 * y);
    e = plane_value(gpu, ASPECT, &d, NULL, as_aspect, 0);
    check(e <= 0.01, "aspect of a plane rising south: 0 (north), max error %.2g degree", e);
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, 3 * (d.h - 1 - y) + x);
    e = plane_value(gpu, ASPECT, &d, NULL, as_aspect,
                    180 + atan2(1, 3) * 180 / PI);
    check(e <= 0.01, "aspect of a plane rising north and east: 180 + atan(1/3) = 198.43, "
          "max error %.2g degree", e);

    /* Flat: aspect 0 (flat), slope 0, hillshade 1 + 254 sin 45. */
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, 77);
    e = plane_value(gpu, ASPECT, &d, NULL, as_is, 0);
    check(e == 0, "aspect of a flat field: 0 everywhere (flat)");
    e = plane_value(gpu, SLOPE, &d, NULL, as_is, 0);
    check(e == 0, "slope of a flat field: 0");
    e = plane_value(gpu, HILLSHADE, &d, NULL, as_byte, 1 + 254 * sqrt(0.5));
    check(e <= 0.01, "hillshade of a flat field: 1 + 254 sin 45 = 180.61 (max error %.2g)", e);

    /* A cone, peak at (32, 24): aspects point away from the peak. */
    const int cx = 32, cy = 24;
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, (int)floor(250 - 4 * hypot(x - cx, y - cy) + 0.5));
    double p[5];
    float *out = run_whole(gpu, ASPECT, &d, NULL, p);
    float *ref = ref_whole(ASPECT, &d, p);
    double worst_a = 0, sum = 0;
    long n = 0, lsb_bad = 0;
    for (int y = 1; y < d.h - 1; y++)
        for (int x = 1; x < d.w - 1; x++) {
            const size_t k = ((size_t)y * d.w + x) * 4;
            lsb_bad += abs(png8(out[k]) - png8(ref[k])) > 1;
            if (hypot(x - cx, y - cy) < 2)
                continue;
            const double want = atan2(x - cx, cy - y) * 180 / PI;
            double a = fabs(remainder(as_aspect(out[k]) - want, 360.0));
            if (out[k] == 0)
                a = 180;
            sum += a, n++;
            worst_a = a > worst_a ? a : worst_a;
        }
    check(worst_a <= 8 && sum / n <= 1.5 && lsb_bad == 0,
          "aspect of a cone points away from the peak: max %.2f degrees off, mean %.3f over "
          "%ld pixels 2 px or more from the peak (bounds 8 and 1.5: gray levels are "
          "rounded); the reference agrees within 1 LSB (%ld differ)", worst_a, sum / n, n,
          lsb_bad);
    free(out);
    free(ref);
    dem_free(&d);

    /* Contours of a ramp, one gray level per column, on white: black lines
     * on exactly the expected columns, one pixel wide. */
    dem_alloc(&d, 100, 12);
    for (int y = 0; y < d.h; y++)
        for (int x = 0; x < d.w; x++)
            dem_set(&d, x, y, x);
    static const struct {
        const char *given;
        int period, phase;
        const char *what;
    } ramp[] = {
        {"{\"contours\": {\"interval\": 10, \"offset\": 4.5, \"show_dem\": 0}}", 10, 5,
         "interval 10, offset 4.5: columns 5, 15, 25 ..."},
        {"{\"contours\": {\"interval\": 10, \"offset\": 104.5, \"base\": 100, \"show_dem\": 0}}", 10, 5,
         "base 100, offset 104.5: the same columns"},
        {"{\"contours\": {\"interval\": 7.5, \"offset\": 1, \"metres_per_level\": 1.5, \"show_dem\": 0}}", 5, 1,
         "1.5 m per level, interval 7.5, offset 1: columns 1, 6, 11 ..."},
    };
    for (size_t c = 0; c < sizeof ramp / sizeof ramp[0]; c++) {
        out = run_whole(gpu, CONTOURS, &d, ramp[c].given, p);
        ref = ref_whole(CONTOURS, &d, p);
        long wrong = 0, lines = 0;
        for (int y = 0; y < d.h; y++)
            for (int x = 0; x < d.w; x++) {
                const size_t k = ((size_t)y * d.w + x) * 4;
                const int want = x % ramp[c].period == ramp[c].phase;
                lines += out[k] == 0;
                wrong += (out[k] == 0) != want || (ref[k] == 0) != want;
                if (!want)
                    wrong += out[k] != 1 || ref[k] != 1;
            }
        check(wrong == 0, "contours of a ramp, %s (%ld line pixels, %ld wrong)",
              ramp[c].what, lines, wrong);
        free(out);
        free(ref);
    }
    dem_free(&d);
}

/* ------------------------------------------------------- 3. GDAL */

/* Read an AAIGrid written by gdaldem into w*h doubles (nodata as NAN). */
static double *read_asc(const char *path, int w, int h)
{
    size_t len;
    char *t = read_text(path, &len);
    if (!t)
        return NULL;
    double *v = malloc(sizeof *v * (size_t)w * h), nodata = NAN;
    char *s = t, *end;
    int got = 0;
    for (int line = 0; line < 6 && v; line++) {
        char key[32];
        double val;
        if (sscanf(s, "%31s %lf", key, &val) == 2 && !strcmp(key, "NODATA_value"))
            nodata = val;
        if (line < 5 || !strcmp(key, "NODATA_value"))
            s = strchr(s, '\n') ? strchr(s, '\n') + 1 : s + strlen(s);
    }
    for (; v && got < w * h; got++) {
        const double x = strtod(s, &end);
        if (end == s)
            break;
        v[got] = x == nodata ? NAN : x;
        s = end;
    }
    free(t);
    if (got != w * h) {
        free(v);
        return NULL;
    }
    return v;
}

static int run_cmd(const char *cmd, double *ms)
{
    const double t0 = now_ms();
    const int rc = system(cmd);
    *ms = now_ms() - t0;
    return rc;
}

static void gdal_compare(struct gv_gpu *gpu, const struct dem *d, double mpl, double px,
                         const char *label, int reps)
{
    if (system("command -v gdaldem >/dev/null 2>&1") != 0) {
        tap_skip("gdaldem not installed (Debian gdal-bin)", "comparison with GDAL");
        return;
    }
    char dir[256], path[512], cmd[1536];
    test_tmpdir_new(dir, sizeof dir, "gv-elev");
    snprintf(path, sizeof path, "%s/dem.asc", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        fail("cannot write %s", path);
    fprintf(f, "ncols %d\nnrows %d\nxllcorner 0\nyllcorner 0\ncellsize %.17g\n", d->w, d->h,
            px);
    for (int y = 0; y < d->h; y++)
        for (int x = 0; x < d->w; x++)
            fprintf(f, "%.17g%c", dem_get(d, x, y) * mpl, x == d->w - 1 ? '\n' : ' ');
    fclose(f);

    static const struct {
        int gi;
        const char *args, *given, *what;
        double tol;
    } cases[] = {
        {HILLSHADE, "hillshade -z 20", "\"z_factor\": 20", "hillshade -z 20", 1},
        {HILLSHADE, "hillshade -z 50 -az 120 -alt 30",
         "\"z_factor\": 50, \"azimuth\": 120, \"altitude\": 30",
         "hillshade -z 50 -az 120 -alt 30", 1},
        {SLOPE, "slope", "\"full_scale\": 1", "slope (degrees)", 1e-3},
        {SLOPE, "slope -p", "\"full_scale\": 1, \"percent\": 1", "slope -p (percent)", 1e-3},
        {ASPECT, "aspect", "\"flat_slope\": 0", "aspect", 1e-2},
    };
    /* gdaldem reads and writes float GeoTIFF (only its run is timed); the
     * ASCII grids are for this program. */
    double ms;
    snprintf(cmd, sizeof cmd, "gdal_translate -q -ot Float32 %s/dem.asc %s/dem.tif", dir, dir);
    if (run_cmd(cmd, &ms) != 0)
        fail("%s failed", cmd);
    printf("# GDAL comparison (%s, %dx%d, %g m per level, %g m pixels): what, "
           "max difference, pixels, our GPU ms (best of %d, gv_filter_run: upload, run, "
           "read back), gdaldem ms (GeoTIFF to GeoTIFF, process included), gdaldem / ours\n",
           label, d->w, d->h, mpl, px, reps);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const int gi = cases[c].gi;
        char given[512];
        snprintf(given, sizeof given,
                 "{\"%s\": {%s, \"metres_per_level\": %.17g, \"pixel_size\": %.17g}}",
                 graphs[gi].file, cases[c].given, mpl, px);
        double p[5], gpu_ms = INFINITY, gdal_ms;
        double *values = params_of(gi, given, p);
        float *out = NULL;
        for (int r = 0; r < reps; r++) {
            free(out);
            out = run_gpu(gpu, gi, d, 0, 0, d->w, d->h, values, &ms);
            gpu_ms = ms < gpu_ms ? ms : gpu_ms;
        }
        free(values);
        snprintf(cmd, sizeof cmd, "gdaldem %s -q %s/dem.tif %s/out.tif", cases[c].args, dir,
                 dir);
        int rc = run_cmd(cmd, &gdal_ms);
        snprintf(cmd, sizeof cmd,
                 "gdal_translate -q -of AAIGrid -co SIGNIFICANT_DIGITS=10 %s/out.tif %s/out.asc",
                 dir, dir);
        rc = rc ? rc : run_cmd(cmd, &ms);
        snprintf(path, sizeof path, "%s/out.asc", dir);
        double *g = rc == 0 ? read_asc(path, d->w, d->h) : NULL;
        if (!out || !g) {
            check(0, "%s: %s", cases[c].what, out ? "gdaldem failed" : "no GPU result");
            free(out);
            free(g);
            continue;
        }
        double worst_d = 0;
        long n = 0, flat_bad = 0, flats = 0;
        for (int y = 1; y < d->h - 1; y++)
            for (int x = 1; x < d->w - 1; x++) {
                const size_t k = (size_t)y * d->w + x;
                const float v = out[k * 4];
                double diff;
                if (gi == HILLSHADE) {
                    diff = abs(png8(v) - (int)g[k]);
                } else if (gi == SLOPE) {
                    diff = fabs(v - g[k]) / (g[k] > 1 ? g[k] : 1);
                } else {
                    flats += isnan(g[k]);
                    if (isnan(g[k]) != (v == 0)) {
                        flat_bad++;
                        continue;
                    }
                    diff = isnan(g[k]) ? 0 : fabs(remainder(as_aspect(v) - g[k], 360.0));
                }
                worst_d = diff > worst_d || isnan(diff) ? diff : worst_d;
                n++;
            }
        printf("# %-34s %10.3g %9ld %9.1f %9.1f %7.2fx\n", cases[c].what, worst_d, n, gpu_ms,
               gdal_ms, gdal_ms / gpu_ms);
        if (gi == ASPECT)
            check(worst_d <= cases[c].tol && flat_bad == 0,
                  "%s: gdaldem %s, max difference %.3g degree over %ld pixels (bound %g); flat "
                  "(gdaldem's nodata) on the same %ld pixels (%ld differ)", label,
                  cases[c].what, worst_d, n, cases[c].tol, flats, flat_bad);
        else
            check(worst_d <= cases[c].tol, "%s: gdaldem %s, max difference %.3g %s over %ld "
                  "pixels (bound %g)", label, cases[c].what, worst_d,
                  gi == HILLSHADE ? "LSB" : "(relative above 1)", n, cases[c].tol);
        free(out);
        free(g);
    }
    test_tmpdir_free(dir);
}

int main(void)
{
    const char *top = getenv("top_srcdir") ? getenv("top_srcdir") : ".";
    const char *data = test_data_dir();
    struct gv_filter_limits lim;
    gv_filter_limits_default(&lim);
    for (int i = 0; i < NGRAPH; i++) {
        char path[512];
        size_t len;
        snprintf(path, sizeof path, "%s/filters/library/%s.json", top, graphs[i].file);
        char *json = read_text(path, &len);
        if (!json)
            fail("cannot read %s", path);
        struct gv_error err = {0};
        parsed[i] = gv_filter_graph_parse(json, len, &lim, &err);
        const struct gv_filter_graph *g = parsed[i];
        check(g && g->pad_left == 1 && g->pad_top == 1 && g->pad_right == 1 &&
              g->pad_bottom == 1 && g->output_channels == 1,
              "%s parses (%s): one gray channel, padding 1 on every side", graphs[i].file,
              g ? "ok" : err.text);
        free(json);
        if (!g)
            fail("%s does not parse", graphs[i].file);
    }

    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu) {
        tap_skip(err.text, "the elevation filters on the GPU (no EGL context)");
    } else if (getenv("GV_ELEV_DEM")) {
        double lo = 0, hi = 0;
        if (!getenv("GV_ELEV_RANGE") || sscanf(getenv("GV_ELEV_RANGE"), "%lf:%lf", &lo, &hi) != 2)
            fail("GV_ELEV_DEM needs GV_ELEV_RANGE=LO:HI");
        const double mpl = getenv("GV_ELEV_M") ? atof(getenv("GV_ELEV_M")) : 1;
        const double px = getenv("GV_ELEV_PIXEL") ? atof(getenv("GV_ELEV_PIXEL")) : 1;
        struct dem d;
        load_dem(&d, getenv("GV_ELEV_DEM"), lo, hi);
        gdal_compare(gpu, &d, mpl, px,
                     getenv("GV_ELEV_LABEL") ? getenv("GV_ELEV_LABEL") : getenv("GV_ELEV_DEM"), 3);
        dem_free(&d);
        gv_gpu_close(gpu);
    } else {
        const struct gv_gpu_info *in = gv_gpu_info(gpu);
        printf("# EGL %s platform, %s: %s / %s\n", in->platform, in->api, in->vendor,
               in->renderer);
        char path[512];
        snprintf(path, sizeof path, "%s/etopo-600x400-u16.png", data);
        struct dem d;
        load_dem(&d, path, 1360, 11560);
        const int mx = (d.w - ROI_W) / 2 + 3, my = (d.h - ROI_H) / 2 + 5;
        for (int i = 0; i < NGRAPH; i++)
            for (int s = 0; s < 3; s++) {
                const char *given = s ? graphs[i].given[s - 1] : NULL;
                gpu_vs_ref(gpu, i, &d, 0, 0, given, s, "top-left");
                gpu_vs_ref(gpu, i, &d, d.w - ROI_W, d.h - ROI_H, given, s, "bottom-right");
                gpu_vs_ref(gpu, i, &d, mx, my, given, s, "middle");
            }
        printf("# summary: graph, runs, worst LSB, decisions differing, set aside as "
               "ambiguous\n");
        for (int i = 0; i < NGRAPH; i++)
            printf("# %-10s %d  %d LSB  %ld  %ld\n", graphs[i].file, worst[i].runs,
                   worst[i].lsb, worst[i].decided, worst[i].ambiguous);
        for (int i = 0; i < NGRAPH; i++)
            extremes(gpu, i, &d);
        known_answers(gpu);
        gdal_compare(gpu, &d, 40, 8000, "etopo-600x400-u16.png --range 1360:11560", 1);
        dem_free(&d);
        gv_gpu_close(gpu);
    }
    for (int i = 0; i < NGRAPH; i++)
        gv_filter_graph_free(parsed[i]);
    return tap_done();
}
