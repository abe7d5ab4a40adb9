/*
 * test_filter_library.c - every stock graph (filters/library/NAME.json) run
 * by the GPU engine (EGL; llvmpipe in CI) against its CPU reference
 * (tests/filter_ref.c) on crops of real images.
 *
 * For each graph: parse it, then run it on three ROIs of 160 x 120 (the
 * top-left and bottom-right corners, where the padding is cut by the
 * image's edges, and one in the middle at odd offsets) with the default
 * parameters, and again with other values where the graph has any.  The test builds
 * the padded region itself from the graph's padding and alignment, as the
 * server does.  Point, linear and log-reduce graphs are compared with a
 * reference computed on the whole image, so a padding too small would show;
 * the propagation graphs (distance transform, Voronoi) are defined on the
 * padded region they are given, so their reference runs on that region,
 * and their final sweep state (the graph re-pointed at the last sweep) must
 * match the reference's exactly; the reference's state must also match the
 * CPU path of filters/edt_cpu.c over the whole padded region, and the
 * 2-NN diagram's nearest site a brute force.
 *
 * Tolerances (the filter service's accuracy goals): 8-bit outputs within
 * 1 LSB after the PNG conversion of docs/FILTERS.md section 6; the
 * distance field within 1e-4 (relative above 1 px), feature ids and site
 * offsets exactly.  The distance transform is also checked against an
 * exact EDT of the whole image where the exact distance is at most 32 px
 * (well inside the 64 px of padding): the error bound of thesis eq. 7.17,
 * sqrt(485) - sqrt(481).
 *
 * Without an EGL context the graphs are still parsed and the GPU
 * comparisons are skipped.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "edt_cpu.h"
#include "filter.h"
#include "filter_ref.h"
#include "gpu/gpu.h"
#include "imageio/imageio.h"
#include "encode/source.h"
#include "test_env.h"
#include "util.h"

#define ROI_W 160
#define ROI_H 120

enum { SEEDING, PICOS, ETOPO, NIMAGES };

/* Crops of the test images, taken as whole level images (level
 * coordinates start at the crop's corner). */
static struct image {
    const char *file;
    int cx, cy, w, h;
    uint8_t *rgba;     /* w*h RGBA8 */
    float *f;          /* the same as floats / 255 */
} images[NIMAGES] = {
    {"seeding-640x480.jpg", 120, 90, 400, 300, NULL, NULL},
    {"picos-1100x700.jpg", 420, 260, 480, 360, NULL, NULL},
    {"etopo-600x400-u16.png", 100, 50, 400, 300, NULL, NULL},
};

enum cmp { CMP_PNG, CMP_DISTANCE };

static const struct stock {
    const char *file;          /* filters/library/FILE.json */
    ref_fn ref;
    const char *params[5];     /* "module.param" for the reference's p[i] */
    int padded;                /* reference on the padded region */
    enum cmp cmp;
    int image;
    const char *given;         /* other parameter values, for one more run */
} stock[] = {
    {"threshold", ref_threshold, {"threshold.a", "threshold.b"}, 0, CMP_PNG, SEEDING,
     "{\"threshold\": {\"a\": 0.45, \"b\": 0.55}}"},
    {"negate", ref_negate, {NULL}, 0, CMP_PNG, PICOS, NULL},
    {"gamma", ref_gamma, {"gamma.gamma"}, 0, CMP_PNG, ETOPO,
     "{\"gamma\": {\"gamma\": 2.2}}"},
    {"sine-window", ref_sine_window, {NULL}, 0, CMP_PNG, SEEDING, NULL},
    {"grayscale", ref_grayscale, {NULL}, 0, CMP_PNG, PICOS, NULL},
    {"box-blur-3x3", ref_box3, {NULL}, 0, CMP_PNG, SEEDING, NULL},
    {"box-blur-7x7", ref_box7, {NULL}, 0, CMP_PNG, PICOS, NULL},
    {"gaussian-blur-1", ref_gauss1, {NULL}, 0, CMP_PNG, SEEDING, NULL},
    {"gaussian-blur-2", ref_gauss2, {NULL}, 0, CMP_PNG, PICOS, NULL},
    {"gaussian-blur-4", ref_gauss4, {NULL}, 0, CMP_PNG, ETOPO, NULL},
    {"sobel", ref_sobel, {"magnitude.gain"}, 0, CMP_PNG, PICOS,
     "{\"magnitude\": {\"gain\": 8}}"},
    {"detail-enhance", ref_detail, {"enhance.amount"}, 0, CMP_PNG, SEEDING,
     "{\"enhance\": {\"amount\": -0.5}}"},
    {"block-max", ref_block_max, {"show.level"}, 0, CMP_PNG, PICOS,
     "{\"show\": {\"level\": 7}}"},
    {"block-min", ref_block_min, {"show.level"}, 0, CMP_PNG, SEEDING,
     "{\"show\": {\"level\": 5}}"},
    {"block-mean", ref_block_mean, {"show.level"}, 0, CMP_PNG, ETOPO,
     "{\"show\": {\"level\": 6}}"},
    {"distance-transform", ref_distance,
     {"features.channel", "features.threshold", "features.invert"}, 1, CMP_DISTANCE,
     PICOS, "{\"features\": {\"channel\": 1, \"threshold\": 0.2, \"invert\": 1}}"},
    {"distance-display", ref_distance_display,
     {"features.channel", "features.threshold", "features.invert", "display.scale"}, 1,
     CMP_PNG, PICOS,
     "{\"features\": {\"channel\": 0, \"threshold\": 0.9}, \"display\": {\"scale\": 64}}"},
    {"voronoi-grid", ref_voronoi_grid, {"sites.spacing", "regions.boundaries"}, 1,
     CMP_PNG, SEEDING, "{\"sites\": {\"spacing\": 7}, \"regions\": {\"boundaries\": 0}}"},
    {"voronoi-mosaic", ref_voronoi_mosaic, {"sites.density", "regions.boundaries"}, 1,
     CMP_PNG, SEEDING, "{\"sites\": {\"density\": 0.02}}"},
    {"voronoi-generalized", ref_voronoi_generalized,
     {"features.channel", "features.threshold", "features.invert", "features.levels",
      "regions.boundaries"}, 1, CMP_PNG, PICOS,
     "{\"features\": {\"threshold\": 0.5, \"levels\": 5}}"},
    {"voronoi-knn", ref_voronoi_knn, {"sites.density", "difference.scale"}, 1, CMP_PNG,
     SEEDING, "{\"sites\": {\"density\": 0.001}, \"difference\": {\"scale\": 32}}"},
};
#define NSTOCK ((int)(sizeof stock / sizeof stock[0]))

/* Worst differences seen per graph, for the summary. */
static struct worst {
    int lsb;              /* 8-bit outputs: LSB after the PNG conversion */
    double fdiff;         /* largest |gpu - ref| before conversion */
    double ddist;         /* distance field: largest |gpu - ref| */
    long exact_bad;       /* ids, offsets, states that differ */
    double edt_err;       /* against an exact EDT, where checked */
    int runs;
} worst[NSTOCK];

static void load_image(struct image *im, const char *data)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", data, im->file);
    const char *in[1] = {path};
    struct gv_source_info info;
    struct gv_error err = {0};
    struct gv_source *s = gv_source_open(in, 1, NULL, &info, &err);
    if (!s)
        fail("open %s: %s", path, err.text);
    const int c = info.channels;
    uint8_t *all = malloc((size_t)info.width * info.height * (size_t)c);
    if (!all || gv_source_read(s, info.height, all, &err) < 0)
        fail("read %s: %s", path, all ? err.text : "out of memory");
    gv_source_free(s);
    if ((uint32_t)(im->cx + im->w) > info.width || (uint32_t)(im->cy + im->h) > info.height)
        fail("%s is smaller than its crop", path);
    im->rgba = malloc((size_t)im->w * im->h * 4);
    im->f = malloc(sizeof *im->f * (size_t)im->w * im->h * 4);
    if (!im->rgba || !im->f)
        fail("out of memory");
    for (int y = 0; y < im->h; y++)
        for (int x = 0; x < im->w; x++) {
            const uint8_t *p = all + ((size_t)(im->cy + y) * info.width + im->cx + x) * c;
            uint8_t *q = im->rgba + ((size_t)y * im->w + x) * 4;
            for (int k = 0; k < 3; k++)
                q[k] = p[c == 1 ? 0 : k];
            q[3] = 255;
            for (int k = 0; k < 4; k++)
                im->f[((size_t)y * im->w + x) * 4 + k] = q[k] / 255.0f;
        }
    free(all);
}

/* The graph with its output re-pointed at module `id`, or NULL. */
static struct gv_filter_graph *reoutput(const char *json, size_t len, const char *id)
{
    json_error_t je;
    json_t *root = json_loadb(json, len, 0, &je);
    if (!root)
        return NULL;
    json_object_set_new(root, "output", json_string(id));
    char *s = json_dumps(root, 0);
    json_decref(root);
    if (!s)
        return NULL;
    struct gv_filter_limits lim;
    gv_filter_limits_default(&lim);
    struct gv_error err = {0};
    struct gv_filter_graph *g = gv_filter_graph_parse(s, strlen(s), &lim, &err);
    free(s);
    return g;
}

/* Values of the reference's parameters, looked up by name in the graph's
 * flat parameter array. */
static void ref_params(const struct gv_filter_graph *g, const struct stock *st,
                       const double *values, double *p)
{
    for (int i = 0; i < 5 && st->params[i]; i++) {
        char mod[GV_FILTER_ID_MAX];
        const char *dot = strchr(st->params[i], '.');
        snprintf(mod, sizeof mod, "%.*s", (int)(dot - st->params[i]), st->params[i]);
        const int m = gv_filter_graph_find(g, mod);
        if (m < 0)
            fail("%s: no module %s", st->file, mod);
        int k = -1;
        for (int q = 0; q < g->module[m].nparams; q++)
            if (!strcmp(g->module[m].param[q].name, dot + 1))
                k = q;
        if (k < 0)
            fail("%s: no parameter %s", st->file, st->params[i]);
        p[i] = values[g->module[m].param_base + k];
    }
}

static int png8(float v)
{
    if (isnan(v))
        return -1000;
    return (int)floor((v < 0 ? 0 : v > 1 ? 1 : v) * 255.0 + 0.5);
}

/* One region of one image: the ROI, the padded region around it and the
 * level coordinates of its corner (= its position in the crop). */
struct region {
    int rx, ry;                 /* ROI in the image */
    int x0, y0, x1, y1;         /* padded region [x0, x1) x [y0, y1) */
};

static struct region pad_roi(const struct gv_filter_graph *g, const struct image *im,
                             int rx, int ry)
{
    struct region r = {rx, ry, rx - g->pad_left, ry - g->pad_top, rx + ROI_W + g->pad_right,
                       ry + ROI_H + g->pad_bottom};
    r.x0 = r.x0 < 0 ? 0 : r.x0 / g->align * g->align;
    r.y0 = r.y0 < 0 ? 0 : r.y0 / g->align * g->align;
    r.x1 = r.x1 > im->w ? im->w : r.x1;
    r.y1 = r.y1 > im->h ? im->h : r.y1;
    return r;
}

static int run_gpu(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                   const struct image *im, const struct region *r, const double *values,
                   float **out, struct gv_filter_stats *stats, struct gv_error *err)
{
    const int w = r->x1 - r->x0, h = r->y1 - r->y0;
    uint8_t *buf = malloc((size_t)w * h * 4);
    if (!buf)
        fail("out of memory");
    for (int y = 0; y < h; y++)
        memcpy(buf + (size_t)y * w * 4,
               im->rgba + ((size_t)(r->y0 + y) * im->w + r->x0) * 4, (size_t)w * 4);
    struct gv_filter_input in = {
        .w = (uint32_t)w, .h = (uint32_t)h, .rgba = buf,
        .roi_x = (uint32_t)(r->rx - r->x0), .roi_y = (uint32_t)(r->ry - r->y0),
        .roi_w = ROI_W, .roi_h = ROI_H, .abs_x = r->x0, .abs_y = r->y0,
        .viewport_w = 0, .viewport_h = 0, .params = values};
    int rc = gv_filter_run(gpu, g, &in, out, stats, err);
    free(buf);
    return rc;
}

/* The reference's region: the whole image, or a copy of the padded one. */
static struct ref_region ref_region_of(const struct stock *st, const struct image *im,
                                       const struct region *r, float **copy)
{
    struct ref_region rr;
    *copy = NULL;
    if (!st->padded) {
        rr.img = (struct ref_image){im->w, im->h, im->f};
        rr.roi_x = r->rx, rr.roi_y = r->ry, rr.abs_x = 0, rr.abs_y = 0;
    } else {
        const int w = r->x1 - r->x0, h = r->y1 - r->y0;
        float *f = malloc(sizeof *f * (size_t)w * h * 4);
        if (!f)
            fail("out of memory");
        for (int y = 0; y < h; y++)
            memcpy(f + (size_t)y * w * 4, im->f + ((size_t)(r->y0 + y) * im->w + r->x0) * 4,
                   sizeof *f * (size_t)w * 4);
        rr.img = (struct ref_image){w, h, f};
        rr.roi_x = r->rx - r->x0, rr.roi_y = r->ry - r->y0;
        rr.abs_x = r->x0, rr.abs_y = r->y0;
        *copy = f;
    }
    rr.roi_w = ROI_W, rr.roi_h = ROI_H;
    return rr;
}

/* Compare the ROI; returns whether it passes and describes it in msg. */
static int compare(const struct stock *st, const struct gv_filter_graph *g,
                   const float *gpu, const float *ref, struct worst *wo, char *msg,
                   size_t msz)
{
    const size_t n = (size_t)ROI_W * ROI_H;
    int lsb = 0;
    double fdiff = 0, ddist = 0;
    long bad = 0, first = -1;
    if (st->cmp == CMP_PNG) {
        const int ch = g->output_channels;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < ch; c++) {
                const float a = gpu[i * 4 + c], b = ref[i * 4 + c];
                const int d = abs(png8(a) - png8(b));
                if (d > lsb)
                    lsb = d;
                if (d > 1 && first < 0)
                    first = (long)i;
                if (fabs((double)a - b) > fdiff || isnan(a))
                    fdiff = isnan(a) ? INFINITY : fabs((double)a - b);
            }
        snprintf(msg, msz, "max %d LSB (float %.3g)", lsb, fdiff);
    } else {
        long found = 0;
        for (size_t i = 0; i < n; i++) {
            const float *a = gpu + i * 4, *b = ref + i * 4;
            found += b[0] >= 0;
            const double dd = fabs((double)a[0] - b[0]);
            const int ok = dd <= 1e-4 * (fabs(b[0]) > 1 ? fabs(b[0]) : 1) && a[1] == b[1] &&
                           a[2] == b[2] && a[3] == b[3];
            if (dd > ddist || isnan(a[0]))
                ddist = isnan(a[0]) ? INFINITY : dd;
            if (!ok) {
                bad++;
                if (first < 0)
                    first = (long)i;
            }
        }
        snprintf(msg, msz, "distance max |diff| %.3g px, %ld pixels differ (%ld of %zu "
                 "pixels have a feature)", ddist, bad, found, n);
    }
    if (first >= 0) {
        const float *a = gpu + first * 4, *b = ref + first * 4;
        printf("# %s: first difference at ROI (%ld, %ld): gpu (%g %g %g %g) ref (%g %g %g %g)\n",
               st->file, first % ROI_W, first / ROI_W, a[0], a[1], a[2], a[3], b[0], b[1],
               b[2], b[3]);
    }
    if (lsb > wo->lsb)
        wo->lsb = lsb;
    if (fdiff > wo->fdiff)
        wo->fdiff = fdiff;
    if (ddist > wo->ddist)
        wo->ddist = ddist;
    wo->exact_bad += bad;
    return st->cmp == CMP_PNG ? lsb <= 1 : bad == 0;
}

/* The final sweep state against the reference's, exactly. */
static int compare_state(const float *gpu, const uint32_t *state, const struct ref_region *rr,
                         long *bad_out)
{
    long bad = 0, first = -1;
    for (int j = 0; j < ROI_H; j++)
        for (int i = 0; i < ROI_W; i++) {
            const float *a = gpu + ((size_t)j * ROI_W + i) * 4;
            const uint32_t *s =
                state + ((size_t)(rr->roi_y + j) * rr->img.w + rr->roi_x + i) * 4;
            int diff = 0;
            for (int c = 0; c < 4; c++)
                diff |= a[c] != (float)s[c];
            if (diff) {
                bad++;
                if (first < 0) {
                    first = (long)j * ROI_W + i;
                    printf("# state differs first at ROI (%d, %d): gpu (%.0f %.0f %.0f %.0f) "
                           "ref (%u %u %u %u)\n", i, j, a[0], a[1], a[2], a[3], s[0], s[1],
                           s[2], s[3]);
                }
            }
        }
    *bad_out = bad;
    return bad == 0;
}

/* Distance transform against the exact EDT of the whole image, where the
 * exact distance is at most 32 px.  Returns the largest error. */
static double check_exact(const struct image *im, const struct region *r, const double *p,
                          const float *gpu, long *checked)
{
    uint8_t *mask = malloc((size_t)im->w * im->h);
    if (!mask)
        fail("out of memory");
    for (size_t i = 0; i < (size_t)im->w * im->h; i++)
        mask[i] = (uint8_t)ref_is_feature(im->f + i * 4, p[0], p[1], p[2]);
    double worst_err = 0;
    *checked = 0;
    for (int j = 0; j < ROI_H; j++)
        for (int i = 0; i < ROI_W; i++) {
            const double e = ref_exact_distance(mask, im->w, im->h, r->rx + i, r->ry + j);
            if (e < 0 || e > 32)
                continue;
            const double err = fabs(gpu[((size_t)j * ROI_W + i) * 4] - e);
            (*checked)++;
            if (err > worst_err)
                worst_err = err;
        }
    free(mask);
    return worst_err;
}

/* The CPU path of the distance transform (filters/edt_cpu.c) on the same
 * sites must give the reference's state over the whole padded region. */
static void check_edt_cpu(const struct stock *st, const struct ref_region *rr,
                          const double *p, const uint32_t *state, const char *label)
{
    const size_t n = (size_t)rr->img.w * (size_t)rr->img.h;
    uint32_t *ids = malloc(sizeof *ids * n), *sid = malloc(sizeof *sid * n);
    int32_t *sx = malloc(sizeof *sx * n), *sy = malloc(sizeof *sy * n);
    if (!ids || !sid || !sx || !sy || ref_initial_ids(st->ref, rr, p, ids) < 0)
        fail("out of memory");
    struct gv_edt_out o = {sx, sy, sid, NULL};
    struct gv_error err = {0};
    long bad = 0;
    if (gv_edt_cpu(ids, (uint32_t)rr->img.w, (uint32_t)rr->img.h, 1, &o, &err) < 0)
        fail("gv_edt_cpu: %s", err.text);
    for (size_t i = 0; i < n; i++) {
        const uint32_t *s = state + i * 4;
        const int same = s[3] ? sx[i] != GV_EDT_NONE && (uint32_t)(sx[i] + rr->abs_x) == s[0] &&
                                    (uint32_t)(sy[i] + rr->abs_y) == s[1] && sid[i] == s[2]
                              : sx[i] == GV_EDT_NONE;
        bad += !same;
    }
    check(bad == 0, "%s: filters/edt_cpu.c finds the reference's sites and ids over the "
          "whole padded region (%ld of %zu differ)", label, bad, n);
    free(ids);
    free(sid);
    free(sx);
    free(sy);
}

/* 2-NN: the GPU's two sites (its final state) against a brute force over
 * the sites of the padded region.  The nearest must be within the bound of
 * eq. 7.17; for the second one, which propagation does not guarantee,
 * report how often and how far it misses. */
static void check_knn(const float *state, const struct region *r, const double *p)
{
    int nsites = 0, cap = 1024;
    int *sx = malloc(sizeof *sx * (size_t)cap), *sy = malloc(sizeof *sy * (size_t)cap);
    for (int y = r->y0; y < r->y1; y++)
        for (int x = r->x0; x < r->x1; x++)
            if (ref_random_site((uint32_t)x, (uint32_t)y, p[0])) {
                if (nsites == cap) {
                    cap *= 2;
                    sx = realloc(sx, sizeof *sx * (size_t)cap);
                    sy = realloc(sy, sizeof *sy * (size_t)cap);
                }
                if (!sx || !sy)
                    fail("out of memory");
                sx[nsites] = x, sy[nsites] = y, nsites++;
            }
    double err1 = 0, err2 = 0;
    long miss2 = 0, n = 0;
    for (int j = 0; j < ROI_H; j++)
        for (int i = 0; i < ROI_W; i++) {
            const int x = r->rx + i, y = r->ry + j;
            double e1 = INFINITY, e2 = INFINITY;
            for (int k = 0; k < nsites; k++) {
                const double d = hypot(sx[k] - x, sy[k] - y);
                if (d < e1)
                    e2 = e1, e1 = d;
                else if (d < e2)
                    e2 = d;
            }
            const float *s = state + ((size_t)j * ROI_W + i) * 4;
            if (isinf(e2) || s[2] >= 4294967295.0f)
                continue;
            const double d1 = hypot(s[0] - x, s[1] - y), d2 = hypot(s[2] - x, s[3] - y);
            n++;
            if (fabs(d1 - e1) > err1)
                err1 = fabs(d1 - e1);
            if (fabs(d2 - e2) > 1e-9)
                miss2++;
            if (fabs(d2 - e2) > err2)
                err2 = fabs(d2 - e2);
        }
    check(err1 <= sqrt(485.0) - sqrt(481.0) + 1e-9,
          "2-NN against brute force over %d sites, %ld pixels: nearest site max error %.4f px "
          "(bound 0.091034); second site off in %ld pixels (%.2f%%), by up to %.3f px",
          nsites, n, err1, miss2, n ? 100.0 * miss2 / n : 0.0, err2);
    free(sx);
    free(sy);
}

/* With GV_TEST_DUMP=DIR, write each GPU result as DIR/GRAPH-WHERE[-p].png
 * for people to look at (the distance field as distance / 64). */
static void dump(const struct stock *st, const struct gv_filter_graph *g, const float *out,
                 const char *where, int given)
{
    const char *dir = getenv("GV_TEST_DUMP");
    if (!dir)
        return;
    const int ch = g->output_channels == 1 || st->cmp == CMP_DISTANCE ? 1 : 3;
    uint8_t *px = malloc((size_t)ROI_W * ROI_H * (size_t)ch);
    if (!px)
        fail("out of memory");
    for (size_t i = 0; i < (size_t)ROI_W * ROI_H; i++)
        for (int c = 0; c < ch; c++)
            px[i * (size_t)ch + (size_t)c] = (uint8_t)png8(
                st->cmp == CMP_DISTANCE ? out[i * 4] / 64.0f : out[i * 4 + (size_t)c]);
    char path[512];
    snprintf(path, sizeof path, "%s/%s-%s%s.png", dir, st->file, where, given ? "-p" : "");
    struct gv_error err = {0};
    if (gv_image_write(path, ROI_W, ROI_H, ch, px, &err) < 0)
        printf("# %s: %s\n", path, err.text);
    free(px);
}

static void run_case(struct gv_gpu *gpu, int si, const struct gv_filter_graph *g,
                     const struct gv_filter_graph *gs, int rx, int ry, const char *given,
                     const char *where)
{
    const struct stock *st = &stock[si];
    const struct image *im = &images[st->image];
    struct gv_error err = {0};
    double *values = calloc((size_t)g->nparams + 1, sizeof *values), p[5] = {0};
    if (!values)
        fail("out of memory");
    json_t *gj = NULL;
    if (given) {
        json_error_t je;
        gj = json_loads(given, 0, &je);
        if (!gj)
            fail("%s: bad test parameters: %s", st->file, je.text);
    }
    if (gv_filter_params(g, gj, values, &err) < 0)
        fail("%s: params: %s", st->file, err.text);
    json_decref(gj);
    ref_params(g, st, values, p);

    const struct region r = pad_roi(g, im, rx, ry);
    char label[256];
    snprintf(label, sizeof label, "%s, %s ROI %dx%d at (%d,%d) of %s, padded [%d,%d)x[%d,%d)%s",
             st->file, where, ROI_W, ROI_H, rx, ry, im->file, r.x0, r.x1, r.y0, r.y1,
             given ? ", other parameters" : "");

    float *out = NULL;
    struct gv_filter_stats stats;
    if (run_gpu(gpu, g, im, &r, values, &out, &stats, &err) < 0) {
        check(0, "%s: gv_filter_run: %s", label, err.text);
        free(values);
        return;
    }
    dump(st, g, out, where, given != NULL);
    float *copy, *ref = malloc(sizeof *ref * ROI_W * ROI_H * 4);
    struct ref_region rr = ref_region_of(st, im, &r, &copy);
    uint32_t *state = NULL;
    if (st->padded) {
        state = malloc(sizeof *state * (size_t)rr.img.w * rr.img.h * 4);
        if (!state)
            fail("out of memory");
    }
    if (!ref || st->ref(&rr, p, ref, state) < 0)
        fail("reference: out of memory");
    char msg[160];
    struct worst *wo = &worst[si];
    wo->runs++;
    check(compare(st, g, out, ref, wo, msg, sizeof msg), "%s: %s (%d passes, %d textures)",
          label, msg, stats.passes, stats.textures);

    if (gs) {
        /* The same graph ending at its last sweep: the state itself. */
        float *sout = NULL;
        long bad = 0;
        if (run_gpu(gpu, gs, im, &r, values, &sout, NULL, &err) < 0)
            check(0, "%s: state: gv_filter_run: %s", label, err.text);
        else {
            const int same = compare_state(sout, state, &rr, &bad);
            check(same, "%s: final sweep state equals the reference's (%ld of %d differ)",
                  label, bad, ROI_W * ROI_H);
        }
        wo->exact_bad += bad;
        if (sout && st->ref == ref_voronoi_knn)
            check_knn(sout, &r, p);
        free(sout);
    }
    if (st->padded && st->ref != ref_voronoi_knn)
        check_edt_cpu(st, &rr, p, state, label);
    if (st->cmp == CMP_DISTANCE) {
        long n;
        const double e = check_exact(im, &r, p, out, &n);
        if (e > wo->edt_err)
            wo->edt_err = e;
        check(e <= sqrt(485.0) - sqrt(481.0) + 1e-6,
              "%s: against an exact EDT, max error %.6f px over %ld pixels within 32 px of "
              "a feature (bound 0.091034)", label, e, n);
    }
    free(state);
    free(copy);
    free(ref);
    free(out);
    free(values);
}

int main(void)
{
    const char *top = getenv("top_srcdir") ? getenv("top_srcdir") : ".";
    const char *data = getenv("TESTDATA") ? getenv("TESTDATA") : "tests/data";
    struct gv_filter_limits lim;
    gv_filter_limits_default(&lim);

    /* Parse every stock graph first: that needs no GPU. */
    struct gv_filter_graph *graph[NSTOCK], *state_graph[NSTOCK];
    for (int i = 0; i < NSTOCK; i++) {
        char path[512];
        size_t len;
        snprintf(path, sizeof path, "%s/filters/library/%s.json", top, stock[i].file);
        char *json = (char *)test_read_file_found(path, &len);
        struct gv_error err = {0};
        graph[i] = gv_filter_graph_parse(json, len, &lim, &err);
        state_graph[i] = NULL;
        if (graph[i] && stock[i].padded)
            state_graph[i] = reoutput(json, len, "my");
        check(graph[i] != NULL && (!stock[i].padded || state_graph[i] != NULL),
              "%s parses (%s; padding %d/%d/%d/%d, align %d, %d textures)", stock[i].file,
              graph[i] ? "ok" : err.text, graph[i] ? graph[i]->pad_left : 0,
              graph[i] ? graph[i]->pad_top : 0, graph[i] ? graph[i]->pad_right : 0,
              graph[i] ? graph[i]->pad_bottom : 0, graph[i] ? graph[i]->align : 0,
              graph[i] ? graph[i]->ntextures : 0);
        free(json);
    }

    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu) {
        tap_skip(err.text, "the filter library on the GPU (no EGL context)");
    } else {
        const struct gv_gpu_info *in = gv_gpu_info(gpu);
        printf("# EGL %s platform, %s: %s / %s\n", in->platform, in->api, in->vendor,
               in->renderer);
        for (int i = 0; i < NIMAGES; i++)
            load_image(&images[i], data);
        for (int i = 0; i < NSTOCK; i++) {
            if (!graph[i])
                continue;
            const struct image *im = &images[stock[i].image];
            const int mx = (im->w - ROI_W) / 2 + 3, my = (im->h - ROI_H) / 2 + 5;
            run_case(gpu, i, graph[i], state_graph[i], 0, 0, NULL, "top-left");
            run_case(gpu, i, graph[i], state_graph[i], im->w - ROI_W, im->h - ROI_H, NULL,
                     "bottom-right");
            run_case(gpu, i, graph[i], state_graph[i], mx, my, NULL, "middle");
            if (!stock[i].given)
                continue;
            run_case(gpu, i, graph[i], state_graph[i], 0, 0, stock[i].given, "top-left");
            run_case(gpu, i, graph[i], state_graph[i], im->w - ROI_W, im->h - ROI_H,
                     stock[i].given, "bottom-right");
            run_case(gpu, i, graph[i], state_graph[i], mx, my, stock[i].given, "middle");
        }
        printf("# summary: graph, runs, worst LSB (8-bit), worst float diff, worst "
               "distance diff, exact mismatches, worst error against exact EDT\n");
        for (int i = 0; i < NSTOCK; i++)
            printf("# %-20s %d  %d LSB  %.3g  %.3g px  %ld  %.6f px\n", stock[i].file,
                   worst[i].runs, worst[i].lsb, worst[i].fdiff, worst[i].ddist,
                   worst[i].exact_bad, worst[i].edt_err);
        gv_gpu_close(gpu);
    }
    for (int i = 0; i < NSTOCK; i++) {
        gv_filter_graph_free(graph[i]);
        gv_filter_graph_free(state_graph[i]);
    }
    for (int i = 0; i < NIMAGES; i++) {
        free(images[i].rgba);
        free(images[i].f);
    }
    return tap_done();
}
