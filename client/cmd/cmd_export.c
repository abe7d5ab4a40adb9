/*
 * cmd_export.c - `gigaview export STORE [--level L] [--region X,Y,W,H]
 * -o OUT`: decode a region with the CPU reference decoder and write it as
 * PNG, TIFF or JPEG (by extension).  The output appears under its name
 * only when complete.  The 8-bit picture by default (a sample store's
 * through its default window); --bits 16 writes the 16-bit codes of a
 * height or sample store, every channel, as PNG (up to 4) or TIFF.
 */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>

#include "commands.h"
#include "imageio/imageio.h"
#include "options.h"
#include "region_arg.h"
#include "render/samples_region.h"
#include "render/store_decoder.h"
#include "store/store_read.h"

#define ME "gigaview export"
#define DECODER_CACHE (64u << 20)   /* decoded-tile LRU: 64 MiB */

struct export_args {
    int level;
    const char *region, *output;
    uint64_t max_pixels;
    int bits;
};

#define F(field) offsetof(struct export_args, field)
static const struct opt_spec export_opts[] = {
    {.name = "level", .short_name = 'l', .kind = OPT_INT, .arg = "L",
     .field = F(level), .min = 0, .max = 64,
     .help = "pyramid level, 0 = full resolution (default 0)"},
    {.name = "region", .short_name = 'R', .kind = OPT_STRING, .arg = "X,Y,W,H",
     .field = F(region), .help = "pixels of that level (default: all of it)"},
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "OUT",
     .field = F(output), .help = ".png, .tif/.tiff or .jpg"},
    {.name = "bits", .kind = OPT_INT, .arg = "N", .field = F(bits),
     .min = 8, .max = 16, .wants = "8 or 16",
     .help = "16: the codes of a height or sample store,\n"
             "every channel (.png up to 4, .tif any);\n"
             "8: the picture (default)"},
    {.name = "max-pixels", .kind = OPT_COUNT, .arg = "N", .field = F(max_pixels),
     .help = "refuse larger regions (default "
             OPT_STR(REGION_DEFAULT_MAX_PIXELS) ")"},
};
#undef F

static const struct opt_command export_command = {
    .me = ME,
    .synopsis = "usage: gigaview export STORE [--level L] [--region X,Y,W,H] -o OUT\n",
    .opts = export_opts,
    .nopts = sizeof export_opts / sizeof export_opts[0],
};

/* The size of level k of s (a tiled level or a root mip), or -1 with a
 * message when the store has no such level. */
static int level_size(struct gv_store *s, int k, uint32_t *lw, uint32_t *lh)
{
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    if (gv_level_size(g, k, lw, lh) < 0) {
        fprintf(stderr, ME ": no level %d (the store has 0..%d)\n", k,
                g->root + g->root_mips - 1);
        return -1;
    }
    return 0;
}

/* Decode region r of level k of s and write it to `output`.  Returns the
 * exit status. */
static int decode_and_write(struct gv_store *s, int k, const struct region *r,
                            const char *output, int codes)
{
    const struct gv_header *h = &gv_store_info(s)->header;
    const int c = codes ? h->channels : gv_display_channels(h);
    uint8_t *pixels = malloc((size_t)r->w * r->h * c * (codes ? 2 : 1));
    struct gv_decoder *d = gv_decoder_new(s, DECODER_CACHE);
    struct gv_error err = {0};
    int rc = 1;
    if (!pixels || !d)
        fprintf(stderr, ME ": out of memory\n");
    else if (codes
                 ? gv_decoder_copy_region(d, "export", k, r->x, r->y, r->w,
                                          r->h, pixels, &err) < 0 ||
                   gv_image_write_typed(output, r->w, r->h, c, GV_SAMPLE_U16,
                                        pixels, &err) < 0
                 : gv_decode_region(d, k, r->x, r->y, r->w, r->h, pixels,
                                    &err) < 0 ||
                   gv_image_write(output, r->w, r->h, c, pixels, &err) < 0)
        fprintf(stderr, ME ": %s\n", err.text);
    else
        rc = 0;
    gv_decoder_free(d);
    free(pixels);
    return rc;
}

int cmd_export(int argc, char **argv)
{
    struct export_args a = {.max_pixels = REGION_DEFAULT_MAX_PIXELS};
    int first, rc = opt_parse(&export_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (!a.output || first != argc - 1) {
        opt_usage(&export_command, stderr);
        return 2;
    }
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(argv[first], &err);
    if (!s) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    uint32_t lw, lh;
    struct region r;
    const int codes = a.bits == 16;
    if (codes && !gv_header_codes(&gv_store_info(s)->header)) {
        fprintf(stderr, ME ": --bits 16 is for height and sample stores; "
                "%s is an 8-bit image store\n", argv[first]);
        rc = 2;
    } else if (a.bits && a.bits != 8 && !codes) {
        fprintf(stderr, ME ": --bits wants 8 or 16\n");
        rc = 2;
    } else if (level_size(s, a.level, &lw, &lh) < 0)
        rc = 1;
    else if (!(rc = region_arg_check(ME, a.region, a.level, lw, lh, a.max_pixels, &r)))
        rc = decode_and_write(s, a.level, &r, a.output, codes);
    gv_store_close(s);
    return rc;
}
