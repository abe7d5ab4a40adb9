/*
 * slide_openslide.c - whole-slide images through OpenSlide
 * (slide_openslide.h).
 *
 * Reading: OpenSlide gives any rectangle of any level as premultiplied
 * ARGB (openslide_read_region); this reader asks for level 0 in strips of
 * the full width, as high as a row of the slide's tiles
 * (openslide.level[0].tile-height, 256 when the format has none), halved
 * until a strip is at most STRIP_BYTES, and flattens each pixel onto the
 * slide's background colour (openslide.background-color, white when it
 * has none): c + bg * (255 - a) / 255, rounded, which is c itself where
 * the slide is opaque.  Memory: one strip, whatever the slide's height;
 * OpenSlide's own tile cache is 32 MiB (3.4).  Rows are delivered from
 * the strip; a request across strips refills it.
 *
 * Metadata: the vendor (openslide_detect_vendor), microns per pixel
 * (openslide.mpp-x, mpp-y), the objective power
 * (openslide.objective-power) and the level count, as a JSON object of
 * store metadata; a property missing or not a positive finite number is
 * left out.
 *
 * OpenSlide is opened with dlopen at the first slide (dl_table.h).
 */
#include <jansson.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <openslide.h>

#include "config.h"
#include "imageio/dl_table.h"
#include "imageio/size_limit.h"
#include "imageio/slide_openslide.h"

/* One strip's ARGB at most: 64 MiB is a strip of 256 rows of a slide
 * 65536 pixels wide; wider slides get lower strips. */
#define STRIP_BYTES (64u << 20)
#define DEFAULT_STRIP 256

static struct {
    const char *(*detect_vendor)(const char *);
    openslide_t *(*open)(const char *);
    const char *(*get_error)(openslide_t *);
    void (*get_level0_dimensions)(openslide_t *, int64_t *, int64_t *);
    int32_t (*get_level_count)(openslide_t *);
    void (*read_region)(openslide_t *, uint32_t *, int64_t, int64_t, int32_t,
                        int64_t, int64_t);
    const char *(*get_property_value)(openslide_t *, const char *);
    void (*close)(openslide_t *);
} os;
static int os_ok;
static pthread_once_t os_once = PTHREAD_ONCE_INIT;

static void os_load(void)
{
    const struct gv_dl_sym syms[] = {
        {(void **)&os.detect_vendor, "openslide_detect_vendor"},
        {(void **)&os.open, "openslide_open"},
        {(void **)&os.get_error, "openslide_get_error"},
        {(void **)&os.get_level0_dimensions, "openslide_get_level0_dimensions"},
        {(void **)&os.get_level_count, "openslide_get_level_count"},
        {(void **)&os.read_region, "openslide_read_region"},
        {(void **)&os.get_property_value, "openslide_get_property_value"},
        {(void **)&os.close, "openslide_close"},
    };
    os_ok = gv_dl_table(GV_OPENSLIDE_SONAME, syms, sizeof syms / sizeof syms[0]);
}

struct gv_slide {
    openslide_t *osr;
    char *path;
    uint32_t width, height, next_row;
    uint32_t strip_h;          /* rows a strip holds */
    uint32_t strip_y, strip_n; /* rows strip_y .. +strip_n are in argb */
    uint32_t *argb;
    uint8_t bg[3];
    int failed;
    char *meta;
};

/* A property as a positive finite number, else 0. */
static double positive(openslide_t *osr, const char *name)
{
    const char *v = os.get_property_value(osr, name);
    if (!v || !*v)
        return 0;
    char *end;
    double d = strtod(v, &end);
    return *end == '\0' && isfinite(d) && d > 0 ? d : 0;
}

static char *make_meta(openslide_t *osr, const char *vendor)
{
    json_t *o = json_object();
    if (!o)
        return NULL;
    json_object_set_new(o, "slide.vendor", json_string(vendor));
    static const struct {
        const char *key, *prop;
    } nums[] = {
        {"slide.mpp_x", "openslide.mpp-x"},
        {"slide.mpp_y", "openslide.mpp-y"},
        {"slide.objective_power", "openslide.objective-power"},
    };
    for (size_t i = 0; i < sizeof nums / sizeof nums[0]; i++) {
        double d = positive(osr, nums[i].prop);
        if (d > 0)
            json_object_set_new(o, nums[i].key, json_real(d));
    }
    json_object_set_new(o, "slide.levels",
                        json_integer(os.get_level_count(osr)));
    char *text = json_dumps(o, JSON_COMPACT | JSON_SORT_KEYS |
                                   JSON_REAL_PRECISION(15));
    json_decref(o);
    return text;
}

/* "RRGGBB" into bg, or white. */
static void background(openslide_t *osr, uint8_t bg[3])
{
    const char *v = os.get_property_value(osr, "openslide.background-color");
    unsigned long c = 0xffffff;
    if (v && strlen(v) == 6) {
        char *end;
        unsigned long x = strtoul(v, &end, 16);
        if (*end == '\0')
            c = x;
    }
    bg[0] = (uint8_t)(c >> 16);
    bg[1] = (uint8_t)(c >> 8);
    bg[2] = (uint8_t)c;
}

static uint32_t strip_height(openslide_t *osr, uint32_t width)
{
    double t = positive(osr, "openslide.level[0].tile-height");
    uint32_t h = t >= 1 && t <= 4096 ? (uint32_t)t : DEFAULT_STRIP;
    while (h > 1 && (uint64_t)width * h * 4 > STRIP_BYTES)
        h /= 2;
    return h;
}

struct gv_slide *gv_slide_open(const char *path,
                               const struct gv_image_limits *lim,
                               struct gv_image_info *info,
                               struct gv_error *err)
{
    gv_error_clear(err);
    pthread_once(&os_once, os_load);
    if (!os_ok)
        return NULL;
    const char *vendor = os.detect_vendor(path);
    if (!vendor || strcmp(vendor, "generic-tiff") == 0)
        return NULL;
    struct gv_slide *s = calloc(1, sizeof *s);
    if (!s || !(s->path = strdup(path))) {
        free(s);
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        return NULL;
    }
    s->osr = os.open(path);
    const char *why = s->osr ? os.get_error(s->osr) : "not a slide OpenSlide reads";
    if (!s->osr || why) {
        gv_fail(err, GV_ECORRUPT, "imageio: %s: OpenSlide: %s", path, why);
        goto fail;
    }
    int64_t w = 0, h = 0;
    os.get_level0_dimensions(s->osr, &w, &h);
    if (w <= 0 || h <= 0) {
        gv_fail(err, GV_ECORRUPT, "imageio: %s: OpenSlide: no level 0", path);
        goto fail;
    }
    if (gv_image_size_check(path, (uint64_t)w, (uint64_t)h, lim->max_pixels,
                            err) < 0)
        goto fail;
    s->width = (uint32_t)w;
    s->height = (uint32_t)h;
    s->strip_h = strip_height(s->osr, s->width);
    if ((uint64_t)s->width * s->strip_h * 4 > gv_image_decoder_limit(lim)) {
        gv_fail(err, GV_ELIMIT, "imageio: %s: a strip of %u rows exceeds the "
                "decoder memory limit (--max-decoder-memory)", path, s->strip_h);
        goto fail;
    }
    background(s->osr, s->bg);
    s->meta = make_meta(s->osr, vendor);
    if (!s->meta) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        goto fail;
    }
    memset(info, 0, sizeof *info);
    info->width = s->width;
    info->height = s->height;
    info->channels = 3;
    info->bits = 8;
    info->sample = GV_SAMPLE_U8;
    snprintf(info->format, sizeof info->format, "openslide");
    return s;
fail:
    gv_slide_close(s);
    return NULL;
}

/* Read the strip that starts at row y. */
static int fill(struct gv_slide *s, uint32_t y, struct gv_error *err)
{
    if (!s->argb) {
        s->argb = malloc((size_t)s->width * s->strip_h * 4);
        if (!s->argb)
            return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory for a "
                           "strip of %u rows", s->path, s->strip_h);
    }
    uint32_t n = s->height - y < s->strip_h ? s->height - y : s->strip_h;
    os.read_region(s->osr, s->argb, 0, y, 0, s->width, n);
    const char *why = os.get_error(s->osr);
    if (why)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: OpenSlide: %s", s->path,
                       why);
    s->strip_y = y;
    s->strip_n = n;
    return 0;
}

static uint8_t flatten(uint32_t c, uint32_t a, uint8_t bg)
{
    uint32_t v = c + (bg * (255 - a) + 127) / 255;
    return (uint8_t)(v > 255 ? 255 : v);
}

int gv_slide_read(struct gv_slide *s, uint32_t rows, void *out,
                  struct gv_error *err)
{
    if (gv_image_read_check(s->path, s->failed, rows, s->next_row, s->height,
                            err) < 0)
        return -1;
    uint8_t *dst = out;
    for (uint32_t r = 0; r < rows; r++, s->next_row++) {
        uint32_t y = s->next_row;
        if (!s->argb || y < s->strip_y || y >= s->strip_y + s->strip_n) {
            if (fill(s, y, err) < 0) {
                s->failed = 1;
                return -1;
            }
        }
        const uint32_t *p = s->argb + (size_t)(y - s->strip_y) * s->width;
        for (uint32_t x = 0; x < s->width; x++) {
            uint32_t v = p[x], a = v >> 24;
            *dst++ = flatten((v >> 16) & 255, a, s->bg[0]);
            *dst++ = flatten((v >> 8) & 255, a, s->bg[1]);
            *dst++ = flatten(v & 255, a, s->bg[2]);
        }
    }
    return 0;
}

const char *gv_slide_meta(const struct gv_slide *s)
{
    return s->meta;
}

void gv_slide_close(struct gv_slide *s)
{
    if (!s)
        return;
    if (s->osr)
        os.close(s->osr);
    free(s->argb);
    free(s->meta);
    free(s->path);
    free(s);
}
