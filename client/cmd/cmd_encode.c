/*
 * cmd_encode.c - `gigaview encode INPUT... -o STORE`.
 *
 * Parses options into struct gv_encode_opts, draws the progress bar on a
 * terminal, and prints a summary: size, levels, tiles, rates, the bits
 * per source pixel of the whole file and the PSNR of level 0 against the
 * target.  -q is the whole image's level-0 PSNR (the default equal-slope
 * mode); --min-tile-psnr picks the per-tile mode instead.  With
 * --shard I/N it writes one shard file instead (docs/OPERATIONS.md,
 * "Encoding on many machines"), which `gigaview merge` assembles.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/parse_uint.h"
#include "commands.h"
#include "encode/height_encode.h"
#include "encode/shard_plan.h"
#include "encode/stream_encoder.h"
#include "imageio/imageio.h"
#include "options.h"
#include "progress.h"
#include "summary.h"

#define ME "gigaview encode"
#define MAX_JOBS 1024
#define MAX_MOSAIC_SIDE 65536   /* inputs in a mosaic row or column */

struct encode_args {
    struct gv_encode_opts o;
    const char *output;
    int progress, quiet;
    double psnr, min_tile_psnr;   /* -q, --min-tile-psnr; 0 = not given */
    int rd;                       /* --rd: the default mode, accepted */
    int layouts_given;            /* --layouts was given */
    int height;                   /* --height: a height store */
    int bits;                     /* --bits: 16 for a sample store */
    const char *colours;          /* --colours, with --bits 16 */
    double max_error;             /* --max-error, source units */
    const char *unit;             /* --unit */
    double hscale, hoffset;       /* --scale, --offset (0 scale: not given) */
    int hoffset_given;
};

/* --offset O (any finite number, 0 included) */
static int parse_offset(const char *arg, void *fields, const char **wants)
{
    struct encode_args *a = fields;
    char *end;
    double v = strtod(arg, &end);
    *wants = "a finite number";
    if (end == arg || *end || !isfinite(v))
        return -1;
    a->hoffset = v;
    a->hoffset_given = 1;
    return 0;
}

/* --mosaic COLSxROWS */
static int parse_mosaic(const char *arg, void *fields, const char **wants)
{
    struct gv_source_opts *src = &((struct encode_args *)fields)->o.source;
    int cols, rows;
    char tail;
    (void)wants;
    if (sscanf(arg, "%dx%d%c", &cols, &rows, &tail) != 2 || cols < 1 || rows < 1 ||
        cols > MAX_MOSAIC_SIDE || rows > MAX_MOSAIC_SIDE)
        return -1;
    src->mosaic_cols = cols;
    src->mosaic_rows = rows;
    return 0;
}

/* --layouts d|all|vq */
static int parse_layouts(const char *arg, void *fields, const char **wants)
{
    struct encode_args *a = fields;
    (void)wants;
    if (!strcmp(arg, "d"))
        a->o.dct = GV_LAYOUTS_D;
    else if (!strcmp(arg, "all"))
        a->o.dct = GV_LAYOUTS_ALL;
    else if (!strcmp(arg, "vq"))
        a->o.dct = GV_LAYOUTS_VQ;
    else
        return -1;
    a->layouts_given = 1;
    return 0;
}

/* --range LO:HI */
static int parse_range(const char *arg, void *fields, const char **wants)
{
    struct gv_source_opts *src = &((struct encode_args *)fields)->o.source;
    const char *colon = strchr(arg, ':');
    char *end;
    if (!colon)
        return -1;
    *wants = "LO:HI with LO < HI";
    double lo = strtod(arg, &end);
    if (end == arg || end != colon)
        return -1;
    double hi = strtod(colon + 1, &end);
    if (end == colon + 1 || *end || !isfinite(lo) || !isfinite(hi) || hi <= lo)
        return -1;
    src->range_lo = lo;
    src->range_hi = hi;
    return 0;
}

/* --max-decoder-memory SIZE: a size as gigaviewd.conf's
 * (base/parse_uint.h: digits with an optional K, M, G or T, powers of
 * 1024), at least 1. */
static int parse_decoder_memory(const char *arg, void *fields,
                                const char **wants)
{
    struct gv_source_opts *src = &((struct encode_args *)fields)->o.source;
    uint64_t v;
    (void)wants;
    if (gv_parse_uint(arg, 1, &v) < 0 || v == 0)
        return -1;
    src->max_decoder_bytes = v;
    return 0;
}

/* --plane Z[,T]: an OME-TIFF stack's plane, from 0 (T 0 when not given). */
static int parse_plane(const char *arg, void *fields, const char **wants)
{
    struct gv_source_opts *src = &((struct encode_args *)fields)->o.source;
    char *end;
    (void)wants;
    errno = 0;
    unsigned long z = strtoul(arg, &end, 10), t = 0;
    if (end == arg || !isdigit((unsigned char)*arg) || errno || z > 999999)
        return -1;
    if (*end == ',') {
        const char *p = end + 1;
        t = strtoul(p, &end, 10);
        if (end == p || !isdigit((unsigned char)*p) || errno || t > 999999)
            return -1;
    }
    if (*end)
        return -1;
    src->plane = (struct gv_image_plane){.set = 1, .z = (uint32_t)z, .t = (uint32_t)t};
    return 0;
}

/* --shard I/N */
static int parse_shard(const char *arg, void *fields, const char **wants)
{
    struct gv_encode_opts *o = &((struct encode_args *)fields)->o;
    (void)wants;
    return gv_shard_parse(arg, &o->shard_index, &o->shard_count);
}

_Static_assert(GV_IMAGE_MAX_DECODER_BYTES == 1ull << 30,
               "--max-decoder-memory's help says the default is 1G");

#define F(field) offsetof(struct encode_args, field)
static const struct opt_spec encode_opts[] = {
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "STORE",
     .field = F(output), .help = "store file to write (replaced atomically)"},
    {.name = "psnr", .short_name = 'q', .kind = OPT_DOUBLE, .arg = "DB",
     .field = F(psnr), .min = 0, .max = 99, .flags = OPT_MIN_OPEN,
     .wants = "a number of dB in (0, 99]",
     .help = "quality: the PSNR of the whole image (level 0)\n"
             "to aim for, in dB (default " OPT_STR(GV_DEFAULT_PSNR) "); lands within\n"
             "1 dB on photographs, unless the rate cap or the\n"
             "prediction alone binds (docs/FORMAT.md 8)"},
    {.name = "min-tile-psnr", .kind = OPT_DOUBLE, .arg = "DB",
     .field = F(min_tile_psnr), .min = 0, .max = 99, .flags = OPT_MIN_OPEN,
     .wants = "a number of dB in (0, 99]",
     .help = "per-tile mode instead of -q: every tile at\n"
             "least DB (unless at the rate cap); about 1 dB\n"
             "worse than the default at equal size"},
    {.name = "max-rate", .short_name = 'r', .kind = OPT_INT, .arg = "R",
     .field = F(o.max_rate), .min = 1, .max = GV_MAX_RATE,
     .wants = "1.." OPT_STR(GV_MAX_RATE),
     .help = "cap on bits per index, 1.." OPT_STR(GV_MAX_RATE)
             " (default " OPT_STR(GV_DEFAULT_MAX_RATE) ")"},
    {.name = "jobs", .short_name = 'j', .kind = OPT_INT, .arg = "N",
     .field = F(o.threads), .min = 1, .max = MAX_JOBS,
     .wants = "1.." OPT_STR(MAX_JOBS), .help = "worker threads (default: every CPU)"},
    {.name = "mosaic", .short_name = 'm', .kind = OPT_CUSTOM, .arg = "COLSxROWS",
     .parse = parse_mosaic, .wants = "COLSxROWS",
     .help = "inputs are a grid, listed row by row"},
    {.name = "range", .kind = OPT_CUSTOM, .arg = "LO:HI", .parse = parse_range,
     .flags = OPT_NO_ECHO, .wants = "LO:HI",
     .help = "map input values LO..HI to 0..255"},
    {.name = "window", .kind = OPT_STRING, .arg = "B,W,G[;...]",
     .field = F(o.window),
     .help = "the image's default display window, kept in the\n"
             "store (black, white, gamma; one, or one a channel)"},
    {.name = "max-pixels", .kind = OPT_COUNT, .arg = "N",
     .field = F(o.source.max_pixels), .flags = OPT_NO_ECHO,
     .wants = "a positive count", .help = "refuse inputs larger than N pixels"},
    {.name = "max-decoder-memory", .kind = OPT_CUSTOM, .arg = "SIZE",
     .parse = parse_decoder_memory,
     .wants = "a positive size: digits with an optional K, M, G or T",
     .help = "memory a decoder may hold for one whole input\n"
             "(a progressive JPEG: 3 to 6 bytes a pixel;\n"
             "an interlaced PNG: its pixels);\n"
             "larger ones are refused (default 1G)"},
    {.name = "plane", .kind = OPT_CUSTOM, .arg = "Z[,T]", .parse = parse_plane,
     .wants = "Z or Z,T: integers from 0",
     .help = "the plane of an OME-TIFF Z stack or time\n"
             "series to encode (from 0; T 0 when not given)"},
    {.name = "tmpdir", .kind = OPT_STRING, .arg = "DIR", .field = F(o.tmpdir),
     .help = "scratch directory (default: the output's)"},
    {.name = "progress", .kind = OPT_FLAG, .field = F(progress),
     .help = "draw the progress bar even off a terminal"},
    {.name = "quiet", .kind = OPT_FLAG, .field = F(quiet), .help = "no summary"},
    {.name = "rd", .kind = OPT_FLAG, .field = F(rd),
     .help = "equal-slope allocation, the default mode\n"
             "(accepted for older scripts)"},
    {.name = "layouts", .kind = OPT_CUSTOM, .arg = "d|all|vq",
     .parse = parse_layouts, .wants = "d, all or vq",
     .help = "tile layouts: d, 8x8 transforms or the\n"
             "prediction alone; all, also VQ (slower, a few\n"
             "tiles smaller); vq, VQ only: a format version 2\n"
             "store for older readers (default " GV_DEFAULT_LAYOUTS ")"},
    {.name = "shard", .kind = OPT_CUSTOM, .arg = "I/N", .parse = parse_shard,
     .wants = "I/N with 0 <= I < N <= " OPT_STR(GV_SHARD_MAX),
     .help = "encode only shard I of N (0 <= I < N) into a\n"
             "shard file at -o; run all N (on any machines)\n"
             "with the same input and options, then\n"
             "'gigaview merge -o STORE SHARD...' writes the\n"
             "store, identical to an unsharded encode"},
    {.name = "bits", .kind = OPT_INT, .arg = "N", .field = F(bits),
     .min = 8, .max = 16, .wants = "8 or 16",
     .help = "16: keep every channel (1 to 8) at 16 bits in\n"
             "a sample store (docs/FORMAT.md 13), lossless\n"
             "unless -q or --max-error; 8: the default"},
    {.name = "colours", .kind = OPT_STRING, .arg = "RRGGBB;...",
     .field = F(colours),
     .help = "--bits 16: each channel's colour on screen,\n"
             "one per channel (docs/API.md, Sample stores)"},
    {.name = "height", .kind = OPT_FLAG, .field = F(height),
     .help = "write a height store: one 16-bit or float\n"
             "channel of elevations (docs/FORMAT.md 12)"},
    {.name = "max-error", .kind = OPT_DOUBLE, .arg = "E", .field = F(max_error),
     .min = 0, .max = 1e30, .flags = OPT_FINITE, .wants = "a number >= 0",
     .help = "--height, --bits 16: largest error in\nsource units (default 0: lossless)"},
    {.name = "unit", .kind = OPT_STRING, .arg = "NAME", .field = F(unit),
     .help = "--height: unit of the values, e.g. m"},
    {.name = "scale", .kind = OPT_DOUBLE, .arg = "S", .field = F(hscale),
     .min = 0, .max = 1e30, .flags = OPT_MIN_OPEN | OPT_FINITE,
     .wants = "a number > 0",
     .help = "--height, integer input: value = code*S + O\n(default 1)"},
    {.name = "offset", .kind = OPT_CUSTOM, .arg = "O", .parse = parse_offset,
     .wants = "a finite number", .help = "--height, integer input: O (default 0)"},
};
#undef F

static const struct opt_command encode_command = {
    .me = ME,
    .synopsis =
        "usage: gigaview encode [OPTIONS] INPUT... -o STORE\n"
        "\n"
        "INPUT is an image in TIFF/BigTIFF, JPEG, PNG, OpenEXR, WebP, JPEG 2000,\n"
        "PNM, BMP, Targa, HDR, PSD, FITS or GIF (16-bit and float included),\n"
        "a whole-slide image through OpenSlide (SVS, NDPI, MIRAX, SCN...) or\n"
        "a GeoTIFF, COG or JPEG 2000 through GDAL, in builds with them,\n"
        "several images with --mosaic, or\n"
        "synth:WIDTHxHEIGHT[:gray] for a procedural test image.\n"
        "With --height, one single-channel INPUT (PNG-16, TIFF, EXR...), a\n"
        "--mosaic of them, or synth-height:WIDTHxHEIGHT (fractal terrain)\n"
        "gives a height store.\n"
        "With --bits 16, one image (or a --mosaic) of 1 to 8 channels of 8, 16\n"
        "or float samples gives a sample store that keeps them.\n",
    .opts = encode_opts,
    .nopts = sizeof encode_opts / sizeof encode_opts[0],
};

/* The mode and its target from -q, --min-tile-psnr and --rd.  Returns
 * OPT_GO_ON, or 2 after a message. */
static int pick_mode(struct encode_args *a)
{
    if (a->min_tile_psnr > 0 && (a->psnr > 0 || a->rd)) {
        fprintf(stderr, ME ": --min-tile-psnr is a mode of its own: "
                "give it without -q or --rd\n");
        return 2;
    }
    a->o.per_tile = a->min_tile_psnr > 0;
    if (a->o.per_tile && a->layouts_given && a->o.dct != GV_LAYOUTS_VQ) {
        fprintf(stderr, ME ": --min-tile-psnr codes VQ tiles only: "
                "give it without --layouts (or with --layouts vq)\n");
        return 2;
    }
    if (!a->layouts_given)
        a->o.dct = a->o.per_tile ? GV_LAYOUTS_VQ : GV_DEFAULT_DCT;
    if (a->o.per_tile)
        a->o.target_psnr = a->min_tile_psnr;
    else if (a->psnr > 0)
        a->o.target_psnr = a->psnr;
    return OPT_GO_ON;
}

/* Check the operands (ninputs of them) against -o and --mosaic.  Returns
 * OPT_GO_ON, or 2 after a message. */
static int check_inputs(const struct encode_args *a, int ninputs)
{
    const struct gv_source_opts *src = &a->o.source;
    if (!a->output || ninputs < 1) {
        opt_usage(&encode_command, stderr);
        return 2;
    }
    if (src->mosaic_cols && (long)src->mosaic_cols * src->mosaic_rows != ninputs) {
        fprintf(stderr, ME ": a %dx%d mosaic needs %d inputs, got %d\n",
                src->mosaic_cols, src->mosaic_rows,
                src->mosaic_cols * src->mosaic_rows, ninputs);
        return 2;
    }
    if (!src->mosaic_cols && ninputs > 1) {
        fprintf(stderr, ME ": several inputs need --mosaic COLSxROWS\n");
        return 2;
    }
    return OPT_GO_ON;
}

static void on_progress(void *ctx, const struct gv_encode_progress *p)
{
    progress_update(ctx, p->fraction, p->source_pixels, p->phase);
}

/* Encode with the progress bar on stderr (drawn on a terminal or with
 * --progress).  Returns 0 with *r filled, or -1 after a message. */
static int encode_with_progress(struct encode_args *a, const char *const *inputs,
                                int ninputs, struct gv_encode_result *r)
{
    struct progress *bar = progress_new(stderr, a->progress);
    a->o.progress = on_progress;
    a->o.progress_ctx = bar;
    struct gv_error err = {0};
    gv_error_clear(&err);
    int rc = gv_encode(inputs, ninputs, a->output, &a->o, r, &err);
    progress_free(bar);
    if (rc < 0)
        fprintf(stderr, ME ": %s\n", err.text);
    return rc;
}

static void print_shard_summary(const struct encode_args *a,
                                const struct gv_encode_result *r)
{
    printf("shard      %d/%d of a %u x %u image -> %s\n", a->o.shard_index,
           a->o.shard_count, r->geometry.width, r->geometry.height, a->output);
    printf("tiles      %llu\n", (unsigned long long)r->tiles);
    printf("size       %llu bytes\n", (unsigned long long)r->file_bytes);
    printf("time       %.2f s\n", r->seconds);
}

/* encode --height, or --bits 16: one input or a mosaic, no other image
 * options.  Returns the exit code. */
static int encode_codes(const struct encode_args *a, const char *const *inputs,
                        int ninputs)
{
    struct progress *bar = progress_new(stderr, a->progress);
    const int samples = a->bits == 16;
    struct gv_height_opts ho = {.samples = samples,
                                .max_error = a->max_error,
                                .target_psnr = a->psnr,
                                .window = a->o.window,
                                .colours = a->colours,
                                .mapped = a->hscale > 0 || a->hoffset_given,
                                .scale = a->hscale > 0 ? a->hscale : 1,
                                .offset = a->hoffset, .unit = a->unit,
                                .max_pixels = a->o.source.max_pixels,
                                .max_decoder_bytes =
                                    a->o.source.max_decoder_bytes,
                                .plane = a->o.source.plane,
                                .threads = a->o.threads,
                                .mosaic_cols = a->o.source.mosaic_cols,
                                .mosaic_rows = a->o.source.mosaic_rows,
                                .tmpdir = a->o.tmpdir,
                                .progress = on_progress,
                                .progress_ctx = bar};
    struct gv_height_result r;
    struct gv_error err = {0};
    gv_error_clear(&err);
    int rc = gv_height_encode(inputs, ninputs, a->output, &ho, &r, &err);
    progress_free(bar);
    if (rc < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    if (a->quiet)
        return 0;
    if (samples)
        printf("samples    %u x %u x %d channels, %d levels -> %s\n",
               r.geometry.width, r.geometry.height, r.channels,
               r.geometry.root + r.geometry.root_mips, a->output);
    else
        printf("height     %u x %u, %d levels -> %s\n", r.geometry.width,
               r.geometry.height, r.geometry.root + r.geometry.root_mips,
               a->output);
    printf("values     %.9g .. %.9g %s (code * %.9g + %.9g)\n", r.min, r.max,
           a->unit ? a->unit : "", r.scale, r.offset);
    printf("max error  %.9g (%d codes%s)\n", r.max_error, r.e,
           r.src_float ? " + float quantization" : "");
    if (samples)
        printf("psnr       %.2f dB over the full range (99: lossless)\n", r.psnr0);
    if (samples && r.trial_tries)
        printf("trial      e = %d after %d tries (the sample: %.2f dB; the "
               "uniform rule: e = %d)\n", r.e, r.trial_tries, r.trial_psnr,
               r.uniform_e);
    printf("tiles      %llu\n", (unsigned long long)r.tiles);
    printf("size       %llu bytes, %.3f bits per sample\n",
           (unsigned long long)r.file_bytes,
           8.0 * (double)r.file_bytes /
               ((double)r.geometry.width * r.geometry.height * r.channels));
    printf("scratch    %llu bytes\n", (unsigned long long)r.scratch_bytes);
    printf("time       %.2f s\n", r.seconds);
    return 0;
}

int cmd_encode(int argc, char **argv)
{
    struct encode_args a = {.output = NULL};
    gv_encode_opts_default(&a.o);
    int first, rc = opt_parse(&encode_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    const int ninputs = argc - first;
    if (a.bits != 0 && a.bits != 8 && a.bits != 16) {
        fprintf(stderr, ME ": --bits wants 8 or 16\n");
        return 2;
    }
    if (a.height && a.bits) {
        fprintf(stderr, ME ": --height stores are 16-bit already: give "
                "--height or --bits, not both\n");
        return 2;
    }
    if (a.height) {
        if (!a.output || a.o.shard_count > 0 || a.psnr > 0 ||
            a.min_tile_psnr > 0 || a.o.window || a.colours) {
            fprintf(stderr, ME ": --height takes INPUT (or --mosaic's "
                    "INPUTs) and -o STORE (not -q, --shard, --window or "
                    "--colours)\n");
            return 2;
        }
        if ((rc = check_inputs(&a, ninputs)) != OPT_GO_ON)
            return rc;
        return encode_codes(&a, (const char *const *)argv + first, ninputs);
    }
    if (a.bits == 16) {
        if (!a.output || a.o.shard_count > 0 || a.min_tile_psnr > 0 ||
            a.layouts_given || a.o.source.range_hi > a.o.source.range_lo ||
            a.unit || a.hscale > 0 || a.hoffset_given ||
            (a.psnr > 0 && a.max_error > 0)) {
            fprintf(stderr, ME ": --bits 16 takes INPUT (or --mosaic's "
                    "INPUTs), -o STORE, -q or --max-error, --window, "
                    "--colours (not "
                    "--shard, --layouts, --min-tile-psnr, --range, --unit, "
                    "--scale or --offset)\n");
            return 2;
        }
        if ((rc = check_inputs(&a, ninputs)) != OPT_GO_ON)
            return rc;
        return encode_codes(&a, (const char *const *)argv + first, ninputs);
    }
    if (a.colours) {
        fprintf(stderr, ME ": --colours needs --bits 16\n");
        return 2;
    }
    if (a.max_error > 0 || a.unit || a.hscale > 0 || a.hoffset_given) {
        fprintf(stderr, ME ": --max-error needs --height or --bits 16; "
                "--unit, --scale and --offset need --height\n");
        return 2;
    }
    if ((rc = check_inputs(&a, ninputs)) != OPT_GO_ON ||
        (rc = pick_mode(&a)) != OPT_GO_ON)
        return rc;
    struct gv_encode_result r;
    if (encode_with_progress(&a, (const char *const *)argv + first, ninputs, &r) < 0)
        return 1;
    if (a.quiet)
        return 0;
    if (a.o.shard_count > 0)
        print_shard_summary(&a, &r);
    else
        print_store_summary(a.output, &r, a.o.target_psnr);
    return 0;
}
