/*
 * cmd_mesh.c - `gigaview mesh INPUT [--level L] [--region X,Y,W,H]
 * (--max-error E | --max-triangles N) [--format F] -o OUT`: the TIN of a
 * region of a height field by greedy insertion (lib/mesh, Garland &
 * Heckbert section 4.4), written as GLB, quantized-mesh, PLY or OBJ.
 *
 * INPUT is a height store (gigaview encode --height; any level, heights
 * decoded by the CPU reference decoder) or a single-channel image file
 * (PNG-16, TIFF, EXR; level 0 only, value = sample * --scale + --offset).
 * The mesh of region X,Y,W,H spans samples X .. X+W and Y .. Y+H (one more
 * than the region, clamped to the level), so regions that tile the level
 * share their border samples; with --max-error the border vertices are
 * chosen from those samples alone, and neighbours join without cracks
 * (docs/MESHES.md).  --tile T meshes tiles of the region in parallel and
 * joins them (tin_tiled.c).  The measured error goes into the file and
 * onto stdout, with the time the meshing took.
 */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "base/atomic_file.h"
#include "base/pool.h"
#include "commands.h"
#include "imageio/imageio.h"
#include "mesh/io/mesh_write.h"
#include "mesh/tin.h"
#include "options.h"
#include "region_arg.h"
#include "render/height_region.h"
#include "mesh/zfield.h"
#include "config.h" /* autoconf: GV_HAVE_GPU */
#ifdef GV_HAVE_GPU
#include "gpu/gpu.h"
#include "gpu/gpu_zfield.h"
#endif
#include "render/store_decoder.h"
#include "store/store_read.h"

#define ME "gigaview mesh"
#define DECODER_CACHE (64u << 20)   /* decoded-tile LRU: 64 MiB */
#define MAX_IMAGE_PIXELS (1ull << 32)

struct mesh_args {
    int level;
    const char *region, *output, *format, *geo;
    double max_error, scale, offset, xy_scale;
    uint64_t max_triangles;
    int gzip, no_border, tile, threads, gpu;
    const char *method;
};

#define F(field) offsetof(struct mesh_args, field)
static const struct opt_spec mesh_opts[] = {
    {.name = "level", .short_name = 'l', .kind = OPT_INT, .arg = "L",
     .field = F(level), .min = 0, .max = 64,
     .help = "pyramid level of a height store, 0 = full resolution (default 0)"},
    {.name = "region", .short_name = 'R', .kind = OPT_STRING, .arg = "X,Y,W,H",
     .field = F(region),
     .help = "samples X..X+W, Y..Y+H of that level (default: all of it)"},
    {.name = "max-error", .short_name = 'e', .kind = OPT_DOUBLE, .arg = "E",
     .field = F(max_error), .min = 0, .max = 1e300, .flags = OPT_FINITE,
     .help = "largest vertical error, in source units"},
    {.name = "max-triangles", .short_name = 'n', .kind = OPT_COUNT, .arg = "N",
     .field = F(max_triangles), .help = "at most N triangles"},
    {.name = "format", .short_name = 'f', .kind = OPT_STRING, .arg = "F",
     .field = F(format),
     .help = "glb, qmesh, ply or obj (default: by the extension of OUT)"},
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "OUT",
     .field = F(output), .help = "the mesh file"},
    {.name = "scale", .kind = OPT_DOUBLE, .arg = "S", .field = F(scale),
     .min = -1e300, .max = 1e300, .flags = OPT_FINITE,
     .help = "image input: value = sample * S + O (default 1)"},
    {.name = "offset", .kind = OPT_DOUBLE, .arg = "O", .field = F(offset),
     .min = -1e300, .max = 1e300, .flags = OPT_FINITE,
     .help = "image input: see --scale (default 0)"},
    {.name = "xy-scale", .kind = OPT_DOUBLE, .arg = "U", .field = F(xy_scale),
     .min = 0, .max = 1e300, .flags = OPT_FINITE | OPT_MIN_OPEN,
     .help = "units per sample in x and y (glb, ply, obj; default 1)"},
    {.name = "geo", .kind = OPT_STRING, .arg = "W,S,E,N", .field = F(geo),
     .help = "qmesh: the grid's bounds in degrees, for the tile header"},
    {.name = "gzip", .kind = OPT_FLAG, .field = F(gzip),
     .help = "qmesh: gzip the file"},
    {.name = "no-border-first", .kind = OPT_FLAG, .field = F(no_border),
     .help = "insert border samples with the interior (not crack-free)"},
    {.name = "tile", .kind = OPT_INT, .arg = "T", .field = F(tile),
     .min = 1, .max = GV_TIN_MAX_SIDE,
     .help = "with --max-error: mesh tiles of TxT cells in parallel and\n"
             "join them without cracks (default: one tile)"},
    {.name = "method", .kind = OPT_STRING, .arg = "M", .field = F(method),
     .help = "greedy (insertion, default) or zfield (the block hierarchy of\n"
             "Lindstrom et al.: a (2^k+1)x(2^k+1) grid, --max-error the\n"
             "vertical threshold of each removed vertex)"},
    {.name = "gpu", .kind = OPT_FLAG, .field = F(gpu),
     .help = "zfield: decide the vertices on the GPU (EGL; the same mesh)"},
    {.name = "threads", .short_name = 'j', .kind = OPT_INT, .arg = "N",
     .field = F(threads), .min = 1, .max = 1024,
     .help = "threads for --tile (default: every core)"},
};
#undef F

static const struct opt_command mesh_command = {
    .me = ME,
    .synopsis = "usage: gigaview mesh INPUT [--level L] [--region X,Y,W,H]\n"
                "       (--max-error E | --max-triangles N) [--format F]\n"
                "       [--method greedy|zfield [--gpu]] -o OUT\n"
                "INPUT: a height store, or a one-channel image file (level 0)\n",
    .opts = mesh_opts,
    .nopts = sizeof mesh_opts / sizeof mesh_opts[0],
};

/* The grid of region r of a lw x lh level: one sample more each way,
 * clamped. */
static void grid_of(const struct region *r, uint32_t lw, uint32_t lh,
                    uint32_t *gw, uint32_t *gh)
{
    *gw = r->x + r->w < lw ? r->w + 1 : lw - r->x;
    *gh = r->y + r->h < lh ? r->h + 1 : lh - r->y;
}

/* Heights of region a.region of a height store; *out malloc'ed. */
static int read_store(struct gv_store *s, const struct mesh_args *a,
                      struct region *r, float **out, uint32_t *gw,
                      uint32_t *gh)
{
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    struct gv_decoder *d = gv_decoder_new(s, DECODER_CACHE);
    struct gv_height_meta hm;
    struct gv_error err = {0};
    uint16_t *codes = NULL;
    uint32_t lw, lh;
    int rc = 1;
    if (!d) {
        fprintf(stderr, ME ": out of memory\n");
        goto out;
    }
    if (!gv_height_meta_get(d, &hm)) {
        fprintf(stderr, ME ": not a height store (encode with --height)\n");
        goto out;
    }
    if (gv_level_size(g, a->level, &lw, &lh) < 0) {
        fprintf(stderr, ME ": no level %d (the store has 0..%d)\n", a->level,
                g->root + g->root_mips - 1);
        goto out;
    }
    if ((rc = region_arg_check(ME, a->region, a->level, lw, lh,
                               (uint64_t)GV_TIN_MAX_SIDE * GV_TIN_MAX_SIDE,
                               r)))
        goto out;
    rc = 1;
    grid_of(r, lw, lh, gw, gh);
    codes = malloc((size_t)*gw * *gh * sizeof *codes);
    *out = malloc((size_t)*gw * *gh * sizeof **out);
    if (!codes || !*out) {
        fprintf(stderr, ME ": out of memory\n");
        goto out;
    }
    if (gv_height_region(d, a->level, r->x, r->y, *gw, *gh, codes, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        goto out;
    }
    for (size_t i = 0; i < (size_t)*gw * *gh; i++)
        (*out)[i] = (float)(codes[i] * hm.scale + hm.offset);
    rc = 0;
out:
    free(codes);
    gv_decoder_free(d);
    return rc;
}

/* Heights of region a.region of a one-channel image (channel 0 of more). */
static int read_image(const char *path, const struct mesh_args *a,
                      struct region *r, float **out, uint32_t *gw,
                      uint32_t *gh)
{
    struct gv_image_info info;
    struct gv_error err = {0};
    struct gv_image_in *in = gv_image_open(path, MAX_IMAGE_PIXELS, &info, &err);
    void *row = NULL;
    int rc = 1;
    if (!in) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    if (a->level != 0) {
        fprintf(stderr, ME ": an image file has only level 0 (encode it "
                "with --height for a pyramid)\n");
        goto out;
    }
    if ((rc = region_arg_check(ME, a->region, 0, info.width, info.height,
                               (uint64_t)GV_TIN_MAX_SIDE * GV_TIN_MAX_SIDE,
                               r)))
        goto out;
    rc = 1;
    grid_of(r, info.width, info.height, gw, gh);
    size_t bps = info.sample == GV_SAMPLE_U8 ? 1 : info.sample == GV_SAMPLE_U16
                 ? 2 : 4;
    row = malloc((size_t)info.width * info.channels * bps);
    *out = malloc((size_t)*gw * *gh * sizeof **out);
    if (!row || !*out) {
        fprintf(stderr, ME ": out of memory\n");
        goto out;
    }
    for (uint32_t y = 0; y < r->y + *gh; y++) {
        if (gv_image_read(in, 1, row, &err) < 0) {
            fprintf(stderr, ME ": %s\n", err.text);
            goto out;
        }
        if (y < r->y)
            continue;
        float *o = *out + (size_t)(y - r->y) * *gw;
        for (uint32_t x = 0; x < *gw; x++) {
            size_t i = (size_t)(r->x + x) * info.channels;
            double v = info.sample == GV_SAMPLE_U8 ? ((uint8_t *)row)[i]
                     : info.sample == GV_SAMPLE_U16 ? ((uint16_t *)row)[i]
                     : ((float *)row)[i];
            o[x] = (float)(v * a->scale + a->offset);
        }
    }
    rc = 0;
out:
    free(row);
    gv_image_close(in);
    return rc;
}

static int parse_geo(const char *s, struct gv_mesh_place *pl)
{
    char tail;
    if (sscanf(s, "%lf,%lf,%lf,%lf%c", &pl->west, &pl->south, &pl->east,
               &pl->north, &tail) != 4 || !(pl->west < pl->east) ||
        !(pl->south < pl->north) || pl->west < -180 || pl->east > 180 ||
        pl->south < -90 || pl->north > 90)
        return -1;
    pl->has_geo = 1;
    return 0;
}

/* --method zfield: the enabled vertices on the CPU or the GPU, the mesh
 * and its measured error on the CPU (lib/mesh/zfield.h). */
static int zfield_build(const float *h, uint32_t w, uint32_t hgt, double threshold,
                        int use_gpu, struct gv_mesh *t, struct gv_error *err)
{
    if (w != hgt || !gv_zfield_side_ok(w))
        return gv_fail(err, GV_EINVAL, "--method zfield needs a square grid of "
                       "2^k+1 samples (a region of 2^k x 2^k cells), not %ux%u", w, hgt);
    uint8_t *en = malloc((size_t)w * w);
    if (!en)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    const struct gv_zfield_params p = {.threshold = (float)threshold};
    int rc;
    if (use_gpu) {
#ifdef GV_HAVE_GPU
        struct gv_gpu *g = gv_gpu_open(GV_GPU_PLATFORM_AUTO, err);
        struct gv_gpu_zfield *zf = g ? gv_gpu_zfield_new(g, NULL, err) : NULL;
        rc = zf && gv_gpu_zfield_heights(zf, h, w, err) == 0 &&
                     gv_gpu_zfield_enable(zf, &p, en, err) == 0 ? 0 : -1;
        gv_gpu_zfield_free(zf);
        gv_gpu_close(g);
#else
        rc = gv_fail(err, GV_EFORMAT, "this gigaview was built without the GPU");
#endif
    } else {
        rc = gv_zfield_enable(h, w, &p, en, err);
    }
    if (rc == 0)
        rc = gv_zfield_mesh(h, w, en, 1, t, err);
    free(en);
    return rc;
}

int cmd_mesh(int argc, char **argv)
{
    struct mesh_args a = {.max_error = -1, .scale = 1, .xy_scale = 1};
    int first, rc = opt_parse(&mesh_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (!a.output || first != argc - 1 ||
        (a.max_error < 0 && a.max_triangles == 0)) {
        opt_usage(&mesh_command, stderr);
        return 2;
    }
    enum gv_mesh_format fmt;
    const char *fname = a.format;
    if (!fname) {
        const char *dot = strrchr(a.output, '.');
        fname = dot ? dot + 1 : "";
    }
    if (gv_mesh_format_parse(fname, &fmt) < 0) {
        fprintf(stderr, ME ": unknown format '%s' (glb, qmesh, ply, obj)\n",
                fname);
        return 2;
    }
    struct gv_mesh_place pl = {.level = (uint32_t)a.level,
                               .xy_scale = a.xy_scale, .gzip = a.gzip};
    if (a.geo && parse_geo(a.geo, &pl) < 0) {
        fprintf(stderr, ME ": --geo wants W,S,E,N in degrees, not '%s'\n",
                a.geo);
        return 2;
    }
    if (a.max_triangles > UINT32_MAX)
        a.max_triangles = UINT32_MAX;
    const int zfield = a.method && !strcmp(a.method, "zfield");
    if (a.method && !zfield && strcmp(a.method, "greedy")) {
        fprintf(stderr, ME ": unknown method '%s' (greedy, zfield)\n", a.method);
        return 2;
    }
    if (zfield && (a.max_error < 0 || a.max_triangles || a.tile)) {
        fprintf(stderr, ME ": --method zfield needs --max-error, without "
                "--max-triangles or --tile\n");
        return 2;
    }
    if (a.gpu && !zfield) {
        fprintf(stderr, ME ": --gpu is for --method zfield\n");
        return 2;
    }

    struct gv_error err = {0};
    struct region r;
    float *h = NULL;
    uint32_t gw = 0, gh = 0;
    struct gv_store *s = gv_store_open(argv[first], &err);
    if (s) {
        rc = read_store(s, &a, &r, &h, &gw, &gh);
        gv_store_close(s);
    } else if (err.code == GV_EFORMAT) {
        rc = read_image(argv[first], &a, &r, &h, &gw, &gh);
    } else {
        fprintf(stderr, ME ": %s\n", err.text);
        rc = 1;
    }
    if (rc) {
        free(h);
        return rc;
    }
    pl.x0 = r.x;
    pl.y0 = r.y;

    struct gv_tin_params p = {.max_error = a.max_error,
                              .max_triangles = (uint32_t)a.max_triangles,
                              .border_first = a.max_error >= 0 && !a.no_border};
    struct gv_mesh t;
    struct timespec t0, t1, c0, c1;
    uint8_t *buf = NULL;
    size_t len = 0;
    rc = 1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    if (a.tile && (a.max_error < 0 || a.max_triangles || a.no_border)) {
        fprintf(stderr, ME ": --tile needs --max-error, without "
                "--max-triangles or --no-border-first\n");
        rc = 2;
        goto out;
    }
    int built;
    if (zfield)
        built = zfield_build(h, gw, gh, a.max_error, a.gpu, &t, &err);
    else if (a.tile)
        built = gv_tin_build_tiled(h, gw, gh, gw, &p, (uint32_t)a.tile,
                                   a.threads ? a.threads : gv_cpu_count(), &t, &err);
    else
        built = gv_tin_build(h, gw, gh, gw, &p, &t, &err);
    if (built < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        goto out;
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    double ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 +
                (double)(t1.tv_nsec - t0.tv_nsec) * 1e-6;
    double cpu = (double)(c1.tv_sec - c0.tv_sec) * 1e3 +
                 (double)(c1.tv_nsec - c0.tv_nsec) * 1e-6;
    if (gv_mesh_encode(fmt, &t, &pl, NULL, &buf, &len, &err) < 0 ||
        gv_atomic_file_write(a.output, buf, len, NULL, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
    } else {
        printf("mesh: %ux%u samples, %u vertices, %u triangles, max error "
               "%.6g, %.3f ms (%.3f ms CPU), %zu bytes %s\n",
               gw, gh, t.nverts, t.ntris, t.max_error, ms, cpu, len,
               gv_mesh_format_ext(fmt));
        rc = 0;
    }
    gv_mesh_free(&t);
out:
    free(buf);
    free(h);
    return rc;
}
