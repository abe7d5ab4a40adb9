/*
 * cmd_export.c - `gigaview export STORE [--level L] [--region x,y,w,h]
 * -o OUT`: decode a region with the CPU reference decoder and write it as
 * PNG, TIFF or JPEG (by extension).  The output appears under its name
 * only when complete.
 */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "options.h"
#include "render/store_decoder.h"
#include "imageio/imageio.h"
#include "store/store_read.h"

#define DEFAULT_MAX_PIXELS (256ull << 20)  /* 256 MP: 768 MiB of RGB */

static void usage(FILE *out)
{
    fprintf(out,
        "usage: gigaview export STORE [--level L] [--region X,Y,W,H] -o OUT\n"
        "\n"
        "  -l, --level L          pyramid level, 0 = full resolution (default 0)\n"
        "  -R, --region X,Y,W,H   pixels of that level (default: all of it)\n"
        "  -o, --output OUT       .png, .tif/.tiff or .jpg\n"
        "      --max-pixels N     refuse larger regions (default %llu)\n",
        DEFAULT_MAX_PIXELS);
}

int cmd_export(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"level", required_argument, NULL, 'l'},
        {"region", required_argument, NULL, 'R'},
        {"output", required_argument, NULL, 'o'},
        {"max-pixels", required_argument, NULL, 'M'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *output = NULL, *region = NULL;
    long level = 0;
    unsigned long long max_pixels = DEFAULT_MAX_PIXELS;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "l:R:o:h", longopts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'l':
            level = strtol(optarg, &end, 10);
            if (end == optarg || *end || level < 0 || level > 64) {
                fprintf(stderr, "gigaview export: bad --level '%s'\n", optarg);
                return 2;
            }
            break;
        case 'R':
            region = optarg;
            break;
        case 'o':
            output = optarg;
            break;
        case 'M':
            if (parse_count(optarg, &max_pixels) < 0) {
                fprintf(stderr, "gigaview export: bad --max-pixels '%s'\n", optarg);
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
    if (!output || optind != argc - 1) {
        usage(stderr);
        return 2;
    }
    struct gv_error err;
    struct gv_store *s = gv_store_open(argv[optind], &err);
    if (!s) {
        fprintf(stderr, "gigaview export: %s\n", err.text);
        return 1;
    }
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    int rc = 1;
    uint8_t *pixels = NULL;
    struct gv_decoder *d = NULL;
    if (level >= g->root + g->root_mips) {
        fprintf(stderr, "gigaview export: no level %ld (the store has 0..%d)\n",
                level, g->root + g->root_mips - 1);
        goto out;
    }
    uint32_t lw, lh;
    if (level >= g->root)
        gv_store_root(s, (int)level - g->root, &lw, &lh);
    else {
        lw = g->level[level].width;
        lh = g->level[level].height;
    }
    unsigned long long x = 0, y = 0, w = lw, h = lh;
    if (region) {
        char tail;
        if (sscanf(region, "%llu,%llu,%llu,%llu%c", &x, &y, &w, &h, &tail) != 4) {
            fprintf(stderr, "gigaview export: --region wants X,Y,W,H, not '%s'\n", region);
            rc = 2;
            goto out;
        }
    }
    if (w == 0 || h == 0 || x >= lw || y >= lh || w > lw - x || h > lh - y) {
        fprintf(stderr, "gigaview export: region %llu,%llu,%llu,%llu is outside "
                "level %ld (%u x %u)\n", x, y, w, h, level, lw, lh);
        goto out;
    }
    if (w * h > max_pixels) {
        fprintf(stderr, "gigaview export: region of %llu pixels exceeds the limit "
                "of %llu (--max-pixels)\n", w * h, max_pixels);
        goto out;
    }
    pixels = malloc((size_t)(w * h * g->channels));
    d = gv_decoder_new(s, 64u << 20);
    if (!pixels || !d) {
        fprintf(stderr, "gigaview export: out of memory\n");
        goto out;
    }
    if (gv_decode_region(d, (int)level, (uint32_t)x, (uint32_t)y, (uint32_t)w,
                         (uint32_t)h, pixels, &err) < 0 ||
        gv_image_write(output, (uint32_t)w, (uint32_t)h, g->channels, pixels, &err) < 0) {
        fprintf(stderr, "gigaview export: %s\n", err.text);
        goto out;
    }
    rc = 0;
out:
    gv_decoder_free(d);
    free(pixels);
    gv_store_close(s);
    return rc;
}
