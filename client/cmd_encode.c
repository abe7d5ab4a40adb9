/*
 * cmd_encode.c - `gigaview encode INPUT... -o STORE`.
 *
 * Parses options into struct gv_encode_opts, draws the progress bar on a
 * terminal, and prints a summary: size, levels, tiles, rates, the bits
 * per source pixel of the whole file and the PSNR of level 0.  With
 * --shard I/N it writes one shard file instead (docs/OPERATIONS.md,
 * "Encoding on many machines"), which `gigaview merge` assembles.
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "encode/stream_encoder.h"
#include "options.h"
#include "progress.h"
#include "encode/shard_plan.h"
#include "summary.h"

static void usage(FILE *out)
{
    fprintf(out,
        "usage: gigaview encode [OPTIONS] INPUT... -o STORE\n"
        "\n"
        "INPUT is an image in TIFF/BigTIFF, JPEG, PNG, OpenEXR, WebP, JPEG 2000,\n"
        "PNM, BMP, Targa, HDR, PSD, FITS or GIF (16-bit and float included),\n"
        "several images with --mosaic, or\n"
        "synth:WIDTHxHEIGHT[:gray] for a procedural test image.\n"
        "\n"
        "  -o, --output STORE     store file to write (replaced atomically)\n"
        "  -q, --psnr DB          per-tile quality target in dB (default %.1f)\n"
        "  -r, --max-rate R       cap on bits per index, 1..12 (default %d)\n"
        "      --rd               rate-distortion mode: spend bits where they\n"
        "                         lower the error most, at the slope of -q\n"
        "  -j, --jobs N           worker threads (default: every CPU)\n"
        "  -m, --mosaic COLSxROWS inputs are a grid, listed row by row\n"
        "      --range LO:HI      map input values LO..HI to 0..255\n"
        "      --max-pixels N     refuse inputs larger than N pixels\n"
        "      --tmpdir DIR       scratch directory (default: the output's)\n"
        "      --shard I/N        encode only shard I of N (0 <= I < N) into a\n"
        "                         shard file at -o; run all N (on any machines)\n"
        "                         with the same input and options, then\n"
        "                         'gigaview merge -o STORE SHARD...' writes the\n"
        "                         store, identical to an unsharded encode\n"
        "      --progress         draw the progress bar even off a terminal\n"
        "      --quiet            no summary\n",
        GV_DEFAULT_PSNR, GV_DEFAULT_MAX_RATE);
}

static int parse_double(const char *s, double *out)
{
    char *end;
    *out = strtod(s, &end);
    return end != s && *end == '\0' ? 0 : -1;
}

static int parse_int(const char *s, long lo, long hi, long *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static void on_progress(void *ctx, const struct gv_encode_progress *p)
{
    progress_update(ctx, p->fraction, p->source_pixels, p->phase);
}

int cmd_encode(int argc, char **argv)
{
    enum { OPT_RANGE = 256, OPT_MAXPX, OPT_TMPDIR, OPT_PROGRESS, OPT_QUIET, OPT_RD,
           OPT_SHARD };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"psnr", required_argument, NULL, 'q'},
        {"max-rate", required_argument, NULL, 'r'},
        {"jobs", required_argument, NULL, 'j'},
        {"mosaic", required_argument, NULL, 'm'},
        {"range", required_argument, NULL, OPT_RANGE},
        {"max-pixels", required_argument, NULL, OPT_MAXPX},
        {"tmpdir", required_argument, NULL, OPT_TMPDIR},
        {"progress", no_argument, NULL, OPT_PROGRESS},
        {"quiet", no_argument, NULL, OPT_QUIET},
        {"rd", no_argument, NULL, OPT_RD},
        {"shard", required_argument, NULL, OPT_SHARD},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    struct gv_encode_opts o;
    gv_encode_opts_default(&o);
    const char *output = NULL;
    int force_progress = 0, quiet = 0, c;
    long v;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:q:r:j:m:h", longopts, NULL)) != -1) {
        switch (c) {
        case 'o':
            output = optarg;
            break;
        case 'q':
            if (parse_double(optarg, &o.target_psnr) < 0 || o.target_psnr <= 0 ||
                o.target_psnr > 99) {
                fprintf(stderr, "gigaview encode: --psnr wants a number of dB in (0, 99], not '%s'\n", optarg);
                return 2;
            }
            break;
        case 'r':
            if (parse_int(optarg, 1, GV_MAX_RATE, &v) < 0) {
                fprintf(stderr, "gigaview encode: --max-rate wants 1..%d, not '%s'\n", GV_MAX_RATE, optarg);
                return 2;
            }
            o.max_rate = (int)v;
            break;
        case 'j':
            if (parse_int(optarg, 1, 1024, &v) < 0) {
                fprintf(stderr, "gigaview encode: --jobs wants 1..1024, not '%s'\n", optarg);
                return 2;
            }
            o.threads = (int)v;
            break;
        case 'm': {
            int cols, rows;
            char tail;
            if (sscanf(optarg, "%dx%d%c", &cols, &rows, &tail) != 2 || cols < 1 ||
                rows < 1 || cols > 65536 || rows > 65536) {
                fprintf(stderr, "gigaview encode: --mosaic wants COLSxROWS, not '%s'\n", optarg);
                return 2;
            }
            o.source.mosaic_cols = cols;
            o.source.mosaic_rows = rows;
            break;
        }
        case OPT_RANGE: {
            char *colon = strchr(optarg, ':');
            if (!colon) {
                fprintf(stderr, "gigaview encode: --range wants LO:HI\n");
                return 2;
            }
            *colon = '\0';
            if (parse_double(optarg, &o.source.range_lo) < 0 ||
                parse_double(colon + 1, &o.source.range_hi) < 0 ||
                o.source.range_hi <= o.source.range_lo) {
                fprintf(stderr, "gigaview encode: --range wants LO:HI with LO < HI\n");
                return 2;
            }
            break;
        }
        case OPT_MAXPX: {
            unsigned long long n;
            if (parse_count(optarg, &n) < 0) {
                fprintf(stderr, "gigaview encode: --max-pixels wants a positive count\n");
                return 2;
            }
            o.source.max_pixels = n;
            break;
        }
        case OPT_TMPDIR:
            o.tmpdir = optarg;
            break;
        case OPT_PROGRESS:
            force_progress = 1;
            break;
        case OPT_QUIET:
            quiet = 1;
            break;
        case OPT_RD:
            o.rd = 1;
            break;
        case OPT_SHARD:
            if (gv_shard_parse(optarg, &o.shard_index, &o.shard_count) < 0) {
                fprintf(stderr, "gigaview encode: --shard wants I/N with 0 <= I < N <= %d, not '%s'\n",
                        GV_SHARD_MAX, optarg);
                return 2;
            }
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            usage(stderr);
            return 2;
        }
    }
    int ninputs = argc - optind;
    if (!output || ninputs < 1) {
        usage(stderr);
        return 2;
    }
    if (o.source.mosaic_cols &&
        (long)o.source.mosaic_cols * o.source.mosaic_rows != ninputs) {
        fprintf(stderr, "gigaview encode: a %dx%d mosaic needs %d inputs, got %d\n",
                o.source.mosaic_cols, o.source.mosaic_rows,
                o.source.mosaic_cols * o.source.mosaic_rows, ninputs);
        return 2;
    }
    if (!o.source.mosaic_cols && ninputs > 1) {
        fprintf(stderr, "gigaview encode: several inputs need --mosaic COLSxROWS\n");
        return 2;
    }

    struct progress *bar = progress_new(stderr, force_progress);
    o.progress = on_progress;
    o.progress_ctx = bar;
    struct gv_encode_result r;
    struct gv_error err;
    gv_error_clear(&err);
    int rc = gv_encode((const char *const *)argv + optind, ninputs, output, &o, &r, &err);
    progress_free(bar);
    if (rc < 0) {
        fprintf(stderr, "gigaview encode: %s\n", err.text);
        return 1;
    }
    if (quiet)
        return 0;
    if (o.shard_count > 0) {
        printf("shard      %d/%d of a %u x %u image -> %s\n", o.shard_index,
               o.shard_count, r.geometry.width, r.geometry.height, output);
        printf("tiles      %llu\n", (unsigned long long)r.tiles);
        printf("size       %llu bytes\n", (unsigned long long)r.file_bytes);
        printf("time       %.2f s\n", r.seconds);
        return 0;
    }
    print_store_summary(output, &r, o.target_psnr);
    return 0;
}
