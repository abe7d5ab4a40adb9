/*
 * cmd_info.c - `gigaview info STORE [--json]`: what a store holds.
 * `gigaview info URL` (http:// or https://) lists a server's images.
 *
 * Validates the store while opening it (header, root and index CRCs), then
 * prints dimensions, levels with their tile and page grids, and the bits
 * per pixel each level costs, plus the whole file's bits per source pixel.
 */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "http_fetch.h"
#include "encode/source.h"
#include "store/store_read.h"

static const char *tone_name(int tone)
{
    switch (tone) {
    case GV_TONE_NONE: return "none (8-bit input)";
    case GV_TONE_SCALE: return "scaled to 8 bits";
    case GV_TONE_SRGB_CLIP: return "float: clipped to [0,1], sRGB-encoded";
    case GV_TONE_RANGE: return "--range mapped to 0..255";
    default: return "unknown";
    }
}

int cmd_info(int argc, char **argv)
{
    const char *path = NULL;
    int json = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--json"))
            json = 1;
        else if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: gigaview info STORE [--json]\n");
            return 0;
        } else if (!path)
            path = argv[i];
        else {
            fprintf(stderr, "usage: gigaview info STORE [--json]\n");
            return 2;
        }
    }
    if (!path) {
        fprintf(stderr, "usage: gigaview info STORE [--json]\n");
        return 2;
    }
    struct gv_error err;
    if (!strncmp(path, "http://", 7) || !strncmp(path, "https://", 8)) {
        /* A server: list its images (client/http_fetch.c). */
        struct gv_http *h = gv_http_new(path, 30000, 0, &err);
        int bad = !h || gv_http_print_images(h, stdout, &err) < 0;
        if (bad)
            fprintf(stderr, "gigaview info: %s\n", err.text);
        gv_http_free(h);
        return bad;
    }
    struct gv_store *s = gv_store_open(path, &err);
    if (!s) {
        fprintf(stderr, "gigaview info: %s\n", err.text);
        return 1;
    }
    const struct gv_store_info *in = gv_store_info(s);
    const struct gv_header *h = &in->header;
    const struct gv_geometry *g = &in->geometry;
    double src_px = (double)g->width * g->height;
    uint64_t tiles = 0;
    for (int k = 0; k < g->root; k++)
        tiles += (uint64_t)g->level[k].tiles_x * g->level[k].tiles_y;
    if (json) {
        printf("{\"width\":%u,\"height\":%u,\"channels\":%d,\"version\":%u,"
               "\"levels\":%d,\"root_level\":%d,\"root_mips\":%d,\"tiles\":%llu,"
               "\"pages\":%llu,\"bytes\":%llu,\"bpp\":%.6f,\"psnr0\":%.3f,"
               "\"target_psnr\":%.3f,\"max_rate\":%u,\"level\":[",
               g->width, g->height, g->channels, h->version, g->root + 1, g->root,
               g->root_mips, (unsigned long long)tiles, (unsigned long long)h->pages,
               (unsigned long long)h->file_size, 8.0 * h->file_size / src_px,
               h->psnr0_mdb / 1000.0, h->target_mpsnr / 1000.0, h->max_rate);
        for (int k = 0; k <= g->root; k++) {
            const struct gv_level *l = &g->level[k];
            uint64_t b = k == g->root ? h->root_size : gv_store_level_bytes(s, k);
            printf("%s{\"level\":%d,\"width\":%u,\"height\":%u,\"tiles_x\":%u,"
                   "\"tiles_y\":%u,\"bytes\":%llu,\"bpp\":%.6f}",
                   k ? "," : "", k, l->width, l->height, l->tiles_x, l->tiles_y,
                   (unsigned long long)b, 8.0 * b / ((double)l->width * l->height));
        }
        printf("]}\n");
        gv_store_close(s);
        return 0;
    }
    printf("store        %s (format version %u)\n", path, h->version);
    printf("image        %u x %u, %s\n", g->width, g->height,
           g->channels == 1 ? "gray" : "RGB");
    printf("source       %d-bit%s, %s\n", h->src_bits, h->src_float ? " float" : "",
           tone_name(h->tone));
    printf("encoding     target %.1f dB per tile, rate cap %u, level-0 PSNR %.2f dB\n",
           h->target_mpsnr / 1000.0, h->max_rate, h->psnr0_mdb / 1000.0);
    printf("levels       %d (0..%d; %d is the root, with %d mips)\n", g->root + 1,
           g->root, g->root, g->root_mips);
    printf("tiles        %llu in %llu pages\n", (unsigned long long)tiles,
           (unsigned long long)h->pages);
    printf("size         %llu bytes, %.3f bits per source pixel\n",
           (unsigned long long)h->file_size, 8.0 * h->file_size / src_px);
    printf("\nlevel      width     height   tiles      pages        bytes    bpp\n");
    for (int k = 0; k <= g->root; k++) {
        const struct gv_level *l = &g->level[k];
        double lp = (double)l->width * l->height;
        if (k == g->root) {
            printf("%5d %10u %10u   root, lossless WebP             %12llu %6.3f\n",
                   k, l->width, l->height, (unsigned long long)h->root_size,
                   8.0 * h->root_size / lp);
            continue;
        }
        uint64_t b = gv_store_level_bytes(s, k);
        printf("%5d %10u %10u %4ux%-5u %4ux%-5u %12llu %6.3f\n", k, l->width,
               l->height, l->tiles_x, l->tiles_y, l->pages_x, l->pages_y,
               (unsigned long long)b, 8.0 * b / lp);
    }
    gv_store_close(s);
    return 0;
}
