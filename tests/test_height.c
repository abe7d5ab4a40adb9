/*
 * test_height.c - height stores (docs/FORMAT.md section 9): every sample
 * of every level of a decoded store is within the bound of that level's
 * exact box-filtered codes, lossless at E = 0; the header's metadata;
 * float input; damaged tiles are refused.
 *
 * Inputs: tests/data/etopo5-himalaya-1030x300-u16.png (three tiles
 * across at level 0, two at level 1: the rule of FORMAT.md section 2),
 * also cut into a 2 x 2 mosaic; synth-height: terrain, one of them two
 * pages wide; and a float field written by the test.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "codec/height_tile.h"
#include "encode/height_encode.h"
#include "imageio/imageio.h"
#include "render/height_region.h"
#include "store/store_read.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

/* The input PNG as codes. */
static uint16_t *read_png(const char *path, uint32_t *w, uint32_t *h)
{
    struct gv_error err = {0};
    struct gv_image_info ii;
    struct gv_image_in *in = gv_image_open(path, 1u << 30, &ii, &err);
    if (!in)
        fail("open %s: %s", path, err.text);
    if (ii.sample != GV_SAMPLE_U16 || ii.channels != 1)
        fail("%s is not one 16-bit channel", path);
    uint16_t *c = malloc(sizeof *c * ii.width * ii.height);
    if (!c || gv_image_read(in, ii.height, c, &err) < 0)
        fail("read %s", path);
    gv_image_close(in);
    *w = ii.width;
    *h = ii.height;
    return c;
}

/* Decode every level of `path` and compare with the exact pyramid of
 * codes (level 0 given) within e codes; returns the largest difference
 * seen (or -1 on a decoding failure). */
static int max_diff(const char *path, const uint16_t *codes, uint32_t w,
                    uint32_t h)
{
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s) {
        check(0, "open %s: %s", path, err.text);
        return -1;
    }
    struct gv_decoder *d = gv_decoder_new(s, 64u << 20);
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    uint16_t *exact = malloc(sizeof *exact * w * h), *next = malloc(sizeof *next * w * h);
    uint16_t *got = malloc(sizeof *got * w * h);
    memcpy(exact, codes, sizeof *exact * w * h);
    int worst = 0;
    uint32_t lw = w, lh = h;
    for (int k = 0; k < g->root + g->root_mips; k++) {
        if (gv_height_region(d, k, 0, 0, lw, lh, got, &err) < 0) {
            check(0, "level %d: %s", k, err.text);
            worst = -1;
            break;
        }
        for (size_t i = 0; i < (size_t)lw * lh; i++) {
            int dd = abs((int)got[i] - (int)exact[i]);
            worst = dd > worst ? dd : worst;
        }
        gv_codes_box_reduce(exact, lw, lh, 1, next);
        lw = (lw + 1) / 2;
        lh = (lh + 1) / 2;
        uint16_t *t = exact;
        exact = next;
        next = t;
    }
    free(exact);
    free(next);
    free(got);
    gv_decoder_free(d);
    gv_store_close(s);
    return worst;
}

static void test_etopo(const char *data)
{
    char png[1024], out[1200];
    snprintf(png, sizeof png, "%s/etopo5-himalaya-1030x300-u16.png", data);
    uint32_t w, h;
    uint16_t *codes = read_png(png, &w, &h);
    const double errors[] = {0, 1, 20, 300};
    uint64_t prev = 0;
    for (size_t i = 0; i < sizeof errors / sizeof errors[0]; i++) {
        snprintf(out, sizeof out, "%s/etopo-%zu.gv", dir, i);
        struct gv_height_opts o = {.max_error = errors[i], .unit = "m",
                                   .mapped = 1, .scale = 1, .offset = -11000};
        struct gv_height_result r;
        struct gv_error err = {0};
        if (gv_height_encode((const char *[]){png}, 1, out, &o, &r, &err) < 0)
            fail("encode E=%g: %s", errors[i], err.text);
        check(r.e == (int)errors[i] && r.max_error == errors[i],
              "E=%g: e %d, bound %g", errors[i], r.e, r.max_error);
        check(r.geometry.root == 2 && r.geometry.level[0].tiles_x == 3 &&
              r.geometry.level[1].tiles_x == 2, "E=%g: root %d, %u and %u "
              "tiles across", errors[i], r.geometry.root,
              r.geometry.level[0].tiles_x, r.geometry.level[1].tiles_x);
        int worst = max_diff(out, codes, w, h);
        check(worst >= 0 && worst <= (int)errors[i], "E=%g: every sample of "
              "every level within the bound (largest error %d)", errors[i], worst);
        if (i > 0)
            check(r.file_bytes < prev, "E=%g: %llu bytes, fewer than %llu at "
                  "the smaller bound", errors[i], (unsigned long long)r.file_bytes,
                  (unsigned long long)prev);
        prev = r.file_bytes;

        struct gv_store *s = gv_store_open(out, &err);
        struct gv_decoder *d = s ? gv_decoder_new(s, 16u << 20) : NULL;
        struct gv_height_meta m;
        if (!d || !gv_height_meta_get(d, &m)) {
            check(0, "E=%g: metadata", errors[i]);
        } else {
            uint16_t lo = 65535, hi = 0;
            for (size_t j = 0; j < (size_t)w * h; j++) {
                lo = codes[j] < lo ? codes[j] : lo;
                hi = codes[j] > hi ? codes[j] : hi;
            }
            check(m.scale == 1 && m.offset == -11000 && m.max_error == errors[i] &&
                  m.min == lo - 11000.0 && m.max == hi - 11000.0 &&
                  strcmp(m.unit, "m") == 0, "E=%g: meta scale %g offset %g "
                  "bound %g range %g..%g unit '%s'", errors[i], m.scale,
                  m.offset, m.max_error, m.min, m.max, m.unit);
            /* Outside the level: GV_EINVAL. */
            uint16_t one;
            gv_error_clear(&err);
            check(gv_height_region(d, 0, w, 0, 1, 1, &one, &err) < 0 &&
                  err.code == GV_EINVAL, "E=%g: a region outside level 0 is "
                  "GV_EINVAL", errors[i]);
            /* The 8-bit path maps min..max to 0..255. */
            uint8_t gray[4];
            check(gv_decode_region(d, 0, 0, 0, 4, 1, gray, &err) == 0,
                  "E=%g: gray region", errors[i]);
        }
        gv_decoder_free(d);
        gv_store_close(s);
    }
    free(codes);
}

/* synth-height at a size with three tiled levels, e = 2. */
static void test_synth(void)
{
    char out[1200];
    snprintf(out, sizeof out, "%s/synth.gv", dir);
    struct gv_height_opts o = {.max_error = 2, .threads = 1};
    struct gv_height_result r;
    struct gv_error err = {0};
    if (gv_height_encode((const char *[]){"synth-height:2100x1100"}, 1, out, &o, &r, &err) < 0)
        fail("synth: %s", err.text);
    check(r.geometry.root == 3, "synth: root level %d", r.geometry.root);
    /* The same terrain again: synth-height is a function of (x, y). */
    uint16_t *codes = malloc(sizeof *codes * 2100 * 1100);
    char out2[1200];
    snprintf(out2, sizeof out2, "%s/synth-lossless.gv", dir);
    o.max_error = 0;
    if (gv_height_encode((const char *[]){"synth-height:2100x1100"}, 1, out2, &o, &r, &err) < 0)
        fail("synth: %s", err.text);
    struct gv_store *s = gv_store_open(out2, &err);
    struct gv_decoder *d = s ? gv_decoder_new(s, 64u << 20) : NULL;
    if (!d || gv_height_region(d, 0, 0, 0, 2100, 1100, codes, &err) < 0)
        fail("synth lossless: %s", err.text);
    gv_decoder_free(d);
    gv_store_close(s);
    int worst = max_diff(out, codes, 2100, 1100);
    check(worst >= 0 && worst <= 2, "synth: every sample of every level "
          "within 2 (largest %d)", worst);
    uint16_t lo = 65535, hi = 0;
    for (size_t i = 0; i < 2100u * 1100u; i++) {
        lo = codes[i] < lo ? codes[i] : lo;
        hi = codes[i] > hi ? codes[i] : hi;
    }
    check(hi - lo > 1000, "synth: terrain spans %u..%u", lo, hi);
    free(codes);
    /* Any number of threads writes the same bytes. */
    char out3[1200];
    snprintf(out3, sizeof out3, "%s/synth-j3.gv", dir);
    o.max_error = 2;
    o.threads = 3;
    if (gv_height_encode((const char *[]){"synth-height:2100x1100"}, 1, out3, &o, &r, &err) < 0)
        fail("synth -j3: %s", err.text);
    char cmd[2600];
    snprintf(cmd, sizeof cmd, "cmp -s %s %s", out, out3);
    check(system(cmd) == 0, "synth: 3 threads write the same store as 1");
}

/* A float field: the bound holds against the float input itself. */
static void test_float(void)
{
    const uint32_t w = 700, h = 520;
    float *f = malloc(sizeof *f * w * h);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            f[y * w + x] = (float)(-431.25 + 900.0 * sin(x / 37.0) * cos(y / 53.0) +
                                   0.37 * x + 0.01 * (double)((x * 7 + y * 13) % 11));
    char tif[1200], out[1200];
    snprintf(tif, sizeof tif, "%s/float.tif", dir);
    snprintf(out, sizeof out, "%s/float.gv", dir);
    struct gv_error err = {0};
    if (gv_image_write_typed(tif, w, h, 1, GV_SAMPLE_F32, f, &err) < 0)
        fail("write %s: %s", tif, err.text);
    const double errors[] = {0, 0.5};
    for (size_t i = 0; i < 2; i++) {
        struct gv_height_opts o = {.max_error = errors[i]};
        struct gv_height_result r;
        if (gv_height_encode((const char *[]){tif}, 1, out, &o, &r, &err) < 0)
            fail("float E=%g: %s", errors[i], err.text);
        check(r.src_float && (errors[i] == 0 ? r.max_error < 0.02 :
                              r.max_error <= errors[i]),
              "float E=%g: bound %g, scale %g", errors[i], r.max_error, r.scale);
        struct gv_store *s = gv_store_open(out, &err);
        struct gv_decoder *d = s ? gv_decoder_new(s, 16u << 20) : NULL;
        uint16_t *c = malloc(sizeof *c * w * h);
        struct gv_height_meta m;
        if (!d || !gv_height_meta_get(d, &m) ||
            gv_height_region(d, 0, 0, 0, w, h, c, &err) < 0)
            fail("float decode: %s", err.text);
        double worst = 0;
        for (size_t j = 0; j < (size_t)w * h; j++) {
            double dv = fabs(c[j] * m.scale + m.offset - f[j]);
            worst = dv > worst ? dv : worst;
        }
        check(worst <= m.max_error, "float E=%g: level 0 within %g of the "
              "float input (largest %g)", errors[i], m.max_error, worst);
        free(c);
        gv_decoder_free(d);
        gv_store_close(s);
    }
    free(f);
}

/* The columns x0 .. x0+tw-1 and rows y0 .. y0+th-1 of w-wide codes
 * written to `path` (PNG-16 or TIFF by its name). */
static void write_part(const char *path, const uint16_t *codes, uint32_t w,
                       uint32_t x0, uint32_t y0, uint32_t tw, uint32_t th)
{
    uint16_t *t = malloc(sizeof *t * tw * th);
    for (uint32_t y = 0; y < th; y++)
        memcpy(t + (size_t)y * tw, codes + (size_t)(y0 + y) * w + x0, sizeof *t * tw);
    struct gv_error err = {0};
    if (gv_image_write_typed(path, tw, th, 1, GV_SAMPLE_U16, t, &err) < 0)
        fail("write %s: %s", path, err.text);
    free(t);
}

/* A 2 x 2 mosaic of PNG-16 and TIFF tiles cut from the Himalaya crop
 * writes the store of the crop itself, every level within the bound. */
static void test_mosaic(const char *data)
{
    char png[1024], part[4][1200], one[1200], mos[1200];
    snprintf(png, sizeof png, "%s/etopo5-himalaya-1030x300-u16.png", data);
    uint32_t w, h;
    uint16_t *codes = read_png(png, &w, &h);
    const uint32_t cx = 600, cy = 170;   /* not on a tile boundary */
    const char *names[4] = {"p00.png", "p10.tif", "p01.tif", "p11.png"};
    for (int i = 0; i < 4; i++) {
        snprintf(part[i], sizeof part[i], "%s/%s", dir, names[i]);
        const uint32_t x0 = i % 2 ? cx : 0, y0 = i / 2 ? cy : 0;
        write_part(part[i], codes, w, x0, y0, i % 2 ? w - cx : cx, i / 2 ? h - cy : cy);
    }
    snprintf(one, sizeof one, "%s/whole.gv", dir);
    snprintf(mos, sizeof mos, "%s/mosaic.gv", dir);
    struct gv_height_opts o = {.max_error = 3, .threads = 2};
    struct gv_height_result r;
    struct gv_error err = {0};
    if (gv_height_encode((const char *[]){png}, 1, one, &o, &r, &err) < 0)
        fail("mosaic: whole: %s", err.text);
    o.mosaic_cols = 2;
    o.mosaic_rows = 2;
    const char *inputs[4] = {part[0], part[1], part[2], part[3]};
    if (gv_height_encode(inputs, 4, mos, &o, &r, &err) < 0)
        fail("mosaic: %s", err.text);
    char cmd[2600];
    snprintf(cmd, sizeof cmd, "cmp -s %s %s", one, mos);
    check(system(cmd) == 0, "mosaic: 2x2 tiles write the store of the whole");
    int worst = max_diff(mos, codes, w, h);
    check(worst >= 0 && worst <= 3, "mosaic: every sample of every level "
          "within 3 (largest %d)", worst);
    free(codes);
}

struct seen {
    double last;
    int backwards, done;
};

static void on_progress(void *ctx, const struct gv_encode_progress *p)
{
    struct seen *s = ctx;
    s->backwards |= p->fraction < s->last;
    s->last = p->fraction;
    s->done += strcmp(p->phase, "done") == 0 && p->fraction == 1.0;
}

/* Two columns of pages at level 0 (ragged): every level within the bound,
 * and progress that only moves forward to "done". */
static void test_pages(void)
{
    const uint32_t w = 4700, h = 600;
    char lossless[1200], out[1200];
    snprintf(lossless, sizeof lossless, "%s/pages-0.gv", dir);
    snprintf(out, sizeof out, "%s/pages-4.gv", dir);
    const char *in[1] = {"synth-height:4700x600"};
    struct gv_height_opts o = {.threads = 2};
    struct gv_height_result r;
    struct gv_error err = {0};
    if (gv_height_encode(in, 1, lossless, &o, &r, &err) < 0)
        fail("pages: %s", err.text);
    check(r.geometry.level[0].pages_x == 2, "pages: %u pages across level 0",
          r.geometry.level[0].pages_x);
    uint16_t *codes = malloc(sizeof *codes * w * h);
    struct gv_store *s = gv_store_open(lossless, &err);
    struct gv_decoder *d = s ? gv_decoder_new(s, 64u << 20) : NULL;
    if (!d || gv_height_region(d, 0, 0, 0, w, h, codes, &err) < 0)
        fail("pages lossless: %s", err.text);
    gv_decoder_free(d);
    gv_store_close(s);
    struct seen seen = {0};
    o.max_error = 4;
    o.progress = on_progress;
    o.progress_ctx = &seen;
    if (gv_height_encode(in, 1, out, &o, &r, &err) < 0)
        fail("pages: %s", err.text);
    check(!seen.backwards && seen.done == 1, "pages: progress forward to done");
    int worst = max_diff(out, codes, w, h);
    check(worst >= 0 && worst <= 4, "pages: every sample of every level "
          "within 4 (largest %d)", worst);
    free(codes);
}

/* Damaged buffers fail as GV_ECORRUPT, never crash. */
static void test_damage(void)
{
    uint16_t *parent = malloc(sizeof *parent * GV_HT_SAMPLES);
    uint16_t *orig = malloc(sizeof *orig * GV_HT_SAMPLES);
    uint16_t *dec = malloc(sizeof *dec * GV_HT_SAMPLES);
    uint16_t *out = malloc(sizeof *out * GV_HT_SAMPLES);
    uint8_t *buf = malloc(GV_HT_BUF_MAX);
    for (int i = 0; i < GV_HT_SAMPLES; i++) {
        parent[i] = (uint16_t)(1000 + (i * 7) % 300);
        orig[i] = (uint16_t)(i % 513 == 0 ? 65535 : 900 + (i * 13) % 500);
    }
    size_t len = gv_height_tile_encode(orig, parent, 1, 0, 0, 513, 513, buf, dec);
    struct gv_error err = {0};
    check(len > GV_HT_CUM_AT && gv_height_tile_decode(buf, len, parent, 1, 0, out, &err) == 0 &&
          memcmp(out, orig, sizeof *out * GV_HT_SAMPLES) == 0 &&
          memcmp(dec, orig, sizeof *dec * GV_HT_SAMPLES) == 0,
          "lossless tile with extreme values round-trips (%zu bytes)", len);
    int refused = 0, tries = 0;
    for (size_t at = 0; at < len; at += len / 97 + 1, tries++) {
        buf[at] ^= 0x5a;
        if (gv_height_tile_decode(buf, len, parent, 1, 0, out, &err) < 0 &&
            err.code == GV_ECORRUPT)
            refused++;
        buf[at] ^= 0x5a;
    }
    check(refused >= tries * 9 / 10, "damaged tiles refused: %d of %d", refused, tries);
    gv_error_clear(&err);
    check(gv_height_tile_decode(buf, len - 4, parent, 1, 0, out, &err) < 0,
          "a truncated tile is refused");
    free(parent);
    free(orig);
    free(dec);
    free(out);
    free(buf);
}

int main(void)
{
    const char *data = test_data_dir();
    test_tmpdir_new(dir, sizeof dir, "gv-test-height");
    test_damage();
    test_etopo(data);
    test_synth();
    test_float();
    test_mosaic(data);
    test_pages();
    test_tmpdir_free(dir);
    return tap_done();
}
