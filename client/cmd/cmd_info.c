/*
 * cmd_info.c - `gigaview info STORE [--json]`: what a store holds.
 * `gigaview info URL` (http:// or https://) lists a server's images.
 *
 * Validates the store while opening it (header, root and index CRCs), then
 * prints dimensions, levels with their tile and page grids, and the bits
 * per pixel each level costs, plus the whole file's bits per source pixel.
 */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jansson.h>

#include "commands.h"
#include "encode/source.h"
#include "options.h"
#include "remote/http_fetch.h"
#include "remote_opts.h"
#include "store/store_read.h"

#define ME "gigaview info"

struct info_args {
    int json;
    struct remote_opts remote;   /* --timeout, for a URL */
};

static const struct opt_spec info_opts[] = {
    {.name = "json", .kind = OPT_FLAG, .field = offsetof(struct info_args, json),
     .help = "one line of JSON instead of the table (not for a URL)"},
    REMOTE_OPT_TIMEOUT(offsetof(struct info_args, remote)),
};

static const struct opt_command info_command = {
    .me = ME,
    .synopsis = "usage: gigaview info STORE [--json]\n"
                "       gigaview info URL [--timeout SEC]\n"
                "\n"
                "Describe a store file, or list the images of the gigaviewd at URL\n"
                "(http:// or https://); GIGAVIEW_TOKEN, if set, is sent as the access\n"
                "token, which lists the restricted images it opens.\n",
    .opts = info_opts,
    .nopts = sizeof info_opts / sizeof info_opts[0],
};

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

/* List the images of the server at url, each request bounded by
 * timeout_ms.  Returns the exit status. */
static int info_server(const char *url, long timeout_ms)
{
    struct gv_error err = {0};
    struct gv_http *h = gv_http_new(url, timeout_ms, 0, &err);
    int bad = !h || gv_http_print_images(h, stdout, &err) < 0;
    if (bad)
        fprintf(stderr, ME ": %s\n", err.text);
    gv_http_free(h);
    return bad;
}

/* Tiles in the tiled levels of g. */
static uint64_t tile_count(const struct gv_geometry *g)
{
    uint64_t tiles = 0;
    for (int k = 0; k < g->root; k++)
        tiles += (uint64_t)g->level[k].tiles_x * g->level[k].tiles_y;
    return tiles;
}

/* The JSON members of a height or sample store (after a comma), or
 * nothing. */
static void print_height_json(const struct gv_header *h)
{
    if (h->kind == GV_KIND_SAMPLES) {
        printf("\"kind\":\"samples\",\"bits\":16,\"scale\":%.17g,"
               "\"offset\":%.17g,\"min\":%.9g,\"max\":%.9g,"
               "\"max_error\":%.17g,\"error_codes\":%u,\"float_source\":%s,",
               h->height_scale, h->height_offset, (double)h->height_min,
               (double)h->height_max, h->height_max_error, h->height_e,
               h->height_float ? "true" : "false");
        return;
    }
    if (h->kind != GV_KIND_HEIGHT)
        return;
    printf("\"kind\":\"height\",\"unit\":\"%s\",\"scale\":%.17g,"
           "\"offset\":%.17g,\"min\":%.9g,\"max\":%.9g,\"max_error\":%.17g,"
           "\"error_codes\":%u,\"float_source\":%s,", h->height_unit,
           h->height_scale, h->height_offset, (double)h->height_min,
           (double)h->height_max, h->height_max_error, h->height_e,
           h->height_float ? "true" : "false");
}

static void print_json(struct gv_store *s)
{
    const struct gv_header *h = &gv_store_info(s)->header;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    double src_px = (double)g->width * g->height;
    printf("{\"width\":%u,\"height\":%u,\"channels\":%d,\"version\":%u,"
           "\"levels\":%d,\"root_level\":%d,\"root_mips\":%d,\"tiles\":%llu,"
           "\"pages\":%llu,\"bytes\":%llu,\"bpp\":%.6f,\"psnr0\":%.3f,"
           "\"target_psnr\":%.3f,\"max_rate\":%u,",
           g->width, g->height, g->channels, h->version, g->root + 1, g->root,
           g->root_mips, (unsigned long long)tile_count(g),
           (unsigned long long)h->pages, (unsigned long long)h->file_size,
           8.0 * h->file_size / src_px, h->psnr0_mdb / 1000.0,
           h->target_mpsnr / 1000.0, h->max_rate);
    print_height_json(h);
    if (gv_store_meta(s))   /* a JSON object, checked at open */
        printf("\"metadata\":%s,", gv_store_meta(s));
    printf("\"level\":[");
    for (int k = 0; k <= g->root; k++) {
        const struct gv_level *l = &g->level[k];
        uint64_t b = k == g->root ? h->root_size : gv_store_level_bytes(s, k);
        printf("%s{\"level\":%d,\"width\":%u,\"height\":%u,\"tiles_x\":%u,"
               "\"tiles_y\":%u,\"bytes\":%llu,\"bpp\":%.6f}",
               k ? "," : "", k, l->width, l->height, l->tiles_x, l->tiles_y,
               (unsigned long long)b, 8.0 * b / ((double)l->width * l->height));
    }
    printf("]}\n");
}

/* The store's metadata (store/store_meta.h), one key a line; strings
 * longer than a line (a CRS's WKT) are cut, `info --json` gives them
 * whole. */
static void print_meta(const struct gv_store *s)
{
    const char *text = gv_store_meta(s);
    json_t *o = text ? json_loads(text, 0, NULL) : NULL;
    if (!o)
        return;
    const char *k;
    json_t *v;
    int first = 1;
    json_object_foreach(o, k, v) {
        printf("%-13s%s = ", first ? "metadata" : "", k);
        first = 0;
        if (json_is_string(v)) {
            const char *str = json_string_value(v);
            size_t n = strcspn(str, "\n");
            if (n > 60 || str[n])
                printf("%.*s... (%zu bytes)\n", (int)(n < 60 ? n : 60), str,
                       strlen(str));
            else
                printf("%s\n", str);
        } else {
            char *d = json_dumps(v, JSON_COMPACT | JSON_ENCODE_ANY |
                                        JSON_REAL_PRECISION(10));
            printf("%s\n", d ? d : "?");
            free(d);
        }
    }
    json_decref(o);
}

/* The per-level table of the text form. */
static void print_levels(struct gv_store *s)
{
    const struct gv_header *h = &gv_store_info(s)->header;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    printf("\nlevel      width     height   tiles      pages        bytes    bpp\n");
    for (int k = 0; k <= g->root; k++) {
        const struct gv_level *l = &g->level[k];
        double lp = (double)l->width * l->height;
        if (k == g->root) {
            printf("%5d %10u %10u   root, lossless %-15s %12llu %6.3f\n",
                   k, l->width, l->height,
                   gv_header_codes(h) ? "deflate" : "WebP",
                   (unsigned long long)h->root_size, 8.0 * h->root_size / lp);
            continue;
        }
        uint64_t b = gv_store_level_bytes(s, k);
        printf("%5d %10u %10u %4ux%-5u %4ux%-5u %12llu %6.3f\n", k, l->width,
               l->height, l->tiles_x, l->tiles_y, l->pages_x, l->pages_y,
               (unsigned long long)b, 8.0 * b / lp);
    }
}

static void print_text(struct gv_store *s, const char *path)
{
    const struct gv_header *h = &gv_store_info(s)->header;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    double src_px = (double)g->width * g->height;
    printf("store        %s (format version %u)\n", path, h->version);
    if (h->kind == GV_KIND_HEIGHT) {
        const char *u = h->height_unit;
        printf("height field %u x %u, 16-bit codes: value = code * %.9g + %.9g%s%s\n",
               g->width, g->height, h->height_scale, h->height_offset,
               *u ? " " : "", u);
        printf("source       %d-bit%s, range %.9g .. %.9g%s%s\n", h->src_bits,
               h->height_float ? " float" : "", (double)h->height_min,
               (double)h->height_max, *u ? " " : "", u);
        printf("max error    %.9g%s%s (%u codes%s)%s\n", h->height_max_error,
               *u ? " " : "", u, h->height_e,
               h->height_float ? " + float quantization" : "",
               h->height_max_error == 0 ? ", lossless" : "");
        printf("levels       %d (0..%d; %d is the root, with %d mips)\n", g->root + 1,
               g->root, g->root, g->root_mips);
        printf("tiles        %llu in %llu pages\n", (unsigned long long)tile_count(g),
               (unsigned long long)h->pages);
        printf("size         %llu bytes, %.3f bits per source sample\n",
               (unsigned long long)h->file_size, 8.0 * h->file_size / src_px);
        print_levels(s);
        return;
    }
    if (h->kind == GV_KIND_SAMPLES) {
        printf("samples      %u x %u, %u channels of 16-bit codes: value = "
               "code * %.9g + %.9g\n", g->width, g->height, g->channels,
               h->height_scale, h->height_offset);
        printf("source       %d-bit%s, range %.9g .. %.9g\n", h->src_bits,
               h->height_float ? " float" : "", (double)h->height_min,
               (double)h->height_max);
        printf("max error    %.9g (%u codes%s)%s, level-0 PSNR %.2f dB\n",
               h->height_max_error, h->height_e,
               h->height_float ? " + float quantization" : "",
               h->height_max_error == 0 ? ", lossless" : "",
               h->psnr0_mdb / 1000.0);
        printf("levels       %d (0..%d; %d is the root, with %d mips)\n",
               g->root + 1, g->root, g->root, g->root_mips);
        printf("tiles        %llu in %llu pages\n",
               (unsigned long long)tile_count(g), (unsigned long long)h->pages);
        printf("size         %llu bytes, %.3f bits per source sample\n",
               (unsigned long long)h->file_size,
               8.0 * h->file_size / (src_px * g->channels));
        print_meta(s);
        print_levels(s);
        return;
    }
    printf("image        %u x %u, %s\n", g->width, g->height,
           g->channels == 1 ? "gray" : "RGB");
    printf("source       %d-bit%s, %s\n", h->src_bits, h->src_float ? " float" : "",
           tone_name(h->tone));
    printf("encoding     target %.1f dB, rate cap %u, level-0 PSNR %.2f dB reached\n",
           h->target_mpsnr / 1000.0, h->max_rate, h->psnr0_mdb / 1000.0);
    printf("levels       %d (0..%d; %d is the root, with %d mips)\n", g->root + 1,
           g->root, g->root, g->root_mips);
    printf("tiles        %llu in %llu pages\n", (unsigned long long)tile_count(g),
           (unsigned long long)h->pages);
    printf("size         %llu bytes, %.3f bits per source pixel\n",
           (unsigned long long)h->file_size, 8.0 * h->file_size / src_px);
    print_meta(s);
    print_levels(s);
}

int cmd_info(int argc, char **argv)
{
    struct info_args a = {0};
    remote_opts_init(&a.remote);
    int first, rc = opt_parse(&info_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (first != argc - 1) {
        opt_usage(&info_command, stderr);
        return 2;
    }
    const char *path = argv[first];
    if (!strncmp(path, "http://", 7) || !strncmp(path, "https://", 8))
        return info_server(path, remote_timeout_ms(&a.remote));
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    if (a.json)
        print_json(s);
    else
        print_text(s, path);
    gv_store_close(s);
    return 0;
}
