/*
 * test_native_write.c - gv_image_encode's JPEG through libjpeg-turbo
 * (lib/imageio/native_jpeg_write.c) against the OpenImageIO module, which
 * it must equal byte for byte: the IIIF and region answers are these
 * bytes, and their ETags and cached copies were made from the module's.
 *
 * Images of many sizes (1x1, odd sides that leave partial MCUs, a 512
 * tile, wide and tall strips), gray and RGB, smooth, noisy and flat, at
 * qualities 1, 50, 75, 90, 100 and the clamped 0 and 101, are encoded by
 * the module (GIGAVIEW_NATIVE_WRITERS=0), by gv_native_jpeg_encode and
 * by gv_image_encode with native writers allowed.  Negative control: the
 * same image at quality 89 differs from the module's at 90, so the
 * comparison can fail.  Images the native writer declines (2 channels,
 * 70000 pixels wide) go to the module, which answers in its own words.
 *
 * WebP (native_webp_write.c) the same way, on half the sizes, gray and
 * RGB, with its negative control and the images it declines.
 *
 * PNG (native_png_write.c) the same way: 1 and 3 channels of 8-bit and 1
 * to 4 of 16-bit samples, through gv_image_encode_typed (and
 * gv_image_encode for 8-bit), against the module's bytes; 2 and 4 of 8
 * bits are refused by both; float samples go to the module.  A PNG file
 * written by gv_image_write_typed (natively) equals the module's file; a
 * file in a missing directory is refused with GV_EIO and its errno.  Negative control: one sample changed changes the bytes.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "test_env.h"
#include "util.h"
#include "imageio/imageio.h"
#include "imageio/native_jpeg_write.h"
#include "imageio/native_png_write.h"
#include "imageio/native_webp_write.h"

/* Pixels of kind 0 (smooth gradients), 1 (noise) or 2 (flat). */
static uint8_t *make_image(uint32_t w, uint32_t h, int c, int kind,
                           uint64_t *rng)
{
    uint8_t *p = malloc((size_t)w * h * c + 1);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (int k = 0; k < c; k++) {
                size_t i = ((size_t)y * w + x) * c + k;
                p[i] = kind == 0 ? (uint8_t)((x * 3 + y * 5 + k * 70) & 255)
                     : kind == 1 ? (uint8_t)test_rand(rng)
                                 : (uint8_t)(40 + 60 * k);
            }
    return p;
}

/* Encode in fmt ("jpg" or "webp") by the module, the native writer
 * ("direct") or gv_image_encode with native writers allowed. */
static int encode_by(int native, const char *how, const char *fmt,
                     uint32_t w, uint32_t h, int c, const uint8_t *px, int q,
                     uint8_t **out, size_t *len, struct gv_error *err)
{
    if (strcmp(how, "direct") == 0)
        return strcmp(fmt, "webp") == 0
                   ? gv_native_webp_encode(w, h, c, px, q, out, len, err)
                   : gv_native_jpeg_encode(w, h, c, px, q, out, len, err);
    if (native)
        unsetenv("GIGAVIEW_NATIVE_WRITERS");
    else
        setenv("GIGAVIEW_NATIVE_WRITERS", "0", 1);
    int rc = gv_image_encode(fmt, w, h, c, px, q, out, len, err);
    unsetenv("GIGAVIEW_NATIVE_WRITERS");
    return rc;
}

/* Encode one image every way; 1 when all equal the module's bytes. */
static int compare(const char *fmt, uint32_t w, uint32_t h, int c, int kind,
                   int q, uint64_t *rng)
{
    uint8_t *px = make_image(w, h, c, kind, rng);
    uint8_t *ref = NULL, *a = NULL, *b = NULL;
    size_t nref = 0, na = 0, nb = 0;
    struct gv_error e1 = {0}, e2 = {0}, e3 = {0};
    int r1 = encode_by(0, "module", fmt, w, h, c, px, q, &ref, &nref, &e1);
    int r2 = encode_by(1, "direct", fmt, w, h, c, px, q, &a, &na, &e2);
    int r3 = encode_by(1, "loader", fmt, w, h, c, px, q, &b, &nb, &e3);
    int same = r1 == 0 && r2 == 0 && r3 == 0 && nref == na && nref == nb &&
               memcmp(ref, a, nref) == 0 && memcmp(ref, b, nref) == 0;
    check(same, "%s %ux%u x%d kind %d quality %d: module %d (%zu bytes%s%s), "
          "native %zu, through gv_image_encode %zu, equal bytes", fmt, w, h, c,
          kind, q, r1, nref, r1 ? ": " : "", r1 ? e1.text : "", na, nb);
    free(px);
    free(ref);
    free(a);
    free(b);
    return same;
}

/* 16-bit samples of kind 0 (gradients over the whole range), 1 (noise)
 * or 2 (flat), as bytes in host order. */
static uint8_t *make_image16(uint32_t w, uint32_t h, int c, int kind,
                             uint64_t *rng)
{
    uint16_t *p = malloc(sizeof *p * ((size_t)w * h * c + 1));
    for (size_t i = 0; i < (size_t)w * h * c; i++) {
        size_t x = i / (size_t)c % w, y = i / ((size_t)c * w);
        p[i] = kind == 0 ? (uint16_t)(x * 517 + y * 1031 + i % (size_t)c * 9000)
             : kind == 1 ? (uint16_t)test_rand(rng)
                         : (uint16_t)(4000 + 12000 * (i % (size_t)c));
    }
    return (uint8_t *)p;
}

/* PNG of one image by the module, natively and through the loader (both
 * entry points where they apply); 1 when all equal the module's bytes. */
static int compare_png(uint32_t w, uint32_t h, int c, enum gv_sample t,
                       int kind, uint64_t *rng)
{
    uint8_t *px = t == GV_SAMPLE_U16 ? make_image16(w, h, c, kind, rng)
                                     : make_image(w, h, c, kind, rng);
    uint8_t *ref = NULL, *a = NULL, *b = NULL, *d = NULL;
    size_t nref = 0, na = 0, nb = 0, nd = 0;
    struct gv_error e1 = {0}, e2 = {0}, e3 = {0}, e4 = {0};
    setenv("GIGAVIEW_NATIVE_WRITERS", "0", 1);
    int r1 = gv_image_encode_typed("png", w, h, c, t, px, &ref, &nref, &e1);
    if (t == GV_SAMPLE_U8 && (c == 2 || c == 4)) {
        /* Not the module's: both refuse, in the module's words. */
        int r3 = gv_image_encode_typed("png", w, h, c, t, px, &b, &nb, &e3);
        check(r1 < 0 && r3 < 0 && !gv_native_png_encodes(w, h, c, t) &&
              strcmp(e1.text, e3.text) == 0, "png %ux%u x%d 8-bit: refused "
              "by the module, natively declined (%s)", w, h, c, e3.text);
        free(px);
        free(ref);
        free(b);
        return r1 < 0 && r3 < 0;
    }
    unsetenv("GIGAVIEW_NATIVE_WRITERS");
    int r2 = gv_native_png_encode(w, h, c, t, px, &a, &na, &e2);
    int r3 = gv_image_encode_typed("png", w, h, c, t, px, &b, &nb, &e3);
    int plain = t == GV_SAMPLE_U8 && (c == 1 || c == 3);
    int r4 = plain ? gv_image_encode("png", w, h, c, px, 90, &d, &nd, &e4) : 0;
    int same = r1 == 0 && r2 == 0 && r3 == 0 && r4 == 0 && nref == na &&
               nref == nb && memcmp(ref, a, nref) == 0 &&
               memcmp(ref, b, nref) == 0 &&
               (!plain || (nd == nref && memcmp(ref, d, nref) == 0));
    check(same, "png %ux%u x%d %d-bit kind %d: module %d (%zu bytes%s%s), "
          "native %zu, through gv_image_encode_typed %zu%s, equal bytes", w,
          h, c, t == GV_SAMPLE_U16 ? 16 : 8, kind, r1, nref, r1 ? ": " : "",
          r1 ? e1.text : "", na, nb, plain ? " and gv_image_encode" : "");
    free(px);
    free(ref);
    free(a);
    free(b);
    free(d);
    return same;
}

static void png_checks(uint64_t *rng)
{
    static const uint32_t sizes[][2] = {
        {1, 1}, {7, 5}, {513, 513}, {326, 163}, {1000, 3}, {3, 700}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (int c = 1; c <= 4; c++)
            for (int depth = 0; depth < 2; depth++)
                compare_png(sizes[s][0], sizes[s][1], c,
                            depth ? GV_SAMPLE_U16 : GV_SAMPLE_U8,
                            (int)((s + (size_t)c) % 3), rng);

    /* Negative control: one sample changed is other bytes. */
    uint8_t *px = make_image16(64, 64, 1, 0, rng), *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    struct gv_error err = {0};
    int r = gv_native_png_encode(64, 64, 1, GV_SAMPLE_U16, px, &a, &na, &err);
    px[2 * 700] ^= 1;
    r |= gv_native_png_encode(64, 64, 1, GV_SAMPLE_U16, px, &b, &nb, &err);
    check(r == 0 && !(na == nb && memcmp(a, b, na) == 0),
          "negative control: one 16-bit sample changed changes the PNG");
    free(a);
    free(b);
    free(px);

    /* Declined: float samples, 5 channels; they go to the module. */
    check(!gv_native_png_encodes(8, 8, 1, GV_SAMPLE_F32) &&
          !gv_native_png_encodes(8, 8, 2, GV_SAMPLE_U8) &&
          !gv_native_png_encodes(8, 8, 5, GV_SAMPLE_U16) &&
          gv_native_png_encodes(8, 8, 4, GV_SAMPLE_U16),
          "png: float samples, 2 of 8 bits and 5 channels are declined, 4 of 16 bits taken");
    float f[4] = {0};
    uint8_t *out = NULL;
    size_t len = 0;
    err = (struct gv_error){0};
    check(gv_native_png_encode(2, 2, 1, GV_SAMPLE_F32, f, &out, &len, &err) < 0 &&
          err.code == GV_EINVAL, "the native PNG writer refuses float samples");
    free(out);
}

static void png_file_checks(uint64_t *rng)
{
    char dir[4096];
    test_tmpdir_new(dir, sizeof dir, "gv-native-write");
    const char *a = test_path_in(dir, "native.png");
    const char *b = test_path_in(dir, "module.png");
    const char *bad = test_path_in(dir, "missing/x.png");
    uint8_t *px = make_image16(300, 200, 3, 1, rng);
    struct gv_error e1 = {0}, e2 = {0}, e3 = {0};
    int r1 = gv_image_write_typed(a, 300, 200, 3, GV_SAMPLE_U16, px, &e1);
    setenv("GIGAVIEW_NATIVE_WRITERS", "0", 1);
    int r2 = gv_image_write_typed(b, 300, 200, 3, GV_SAMPLE_U16, px, &e2);
    unsetenv("GIGAVIEW_NATIVE_WRITERS");
    size_t na = 0, nb = 0;
    uint8_t *fa = test_read_file(a, &na), *fb = test_read_file(b, &nb);
    check(r1 == 0 && r2 == 0 && fa && fb && na == nb && na > 0 &&
          memcmp(fa, fb, na) == 0, "a 16-bit PNG file written natively "
          "equals the module's (%zu and %zu bytes)", na, nb);
    int r3 = gv_image_write_typed(bad, 300, 200, 3, GV_SAMPLE_U16, px, &e3);
    check(r3 < 0 && e3.code == GV_EIO && strstr(e3.text, "imageio"),
          "a PNG file in a missing directory: GV_EIO (%s)", e3.text);
    free(fa);
    free(fb);
    free(px);
    test_tmpdir_free(dir);
}

/* WebP's negative control and the images its native writer declines. */
static void webp_checks(uint64_t *rng)
{
    uint8_t *px = make_image(64, 64, 3, 1, rng), *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    struct gv_error err = {0};
    check(encode_by(0, "module", "webp", 64, 64, 3, px, 90, &a, &na, &err) == 0 &&
          gv_native_webp_encode(64, 64, 3, px, 89, &b, &nb, &err) == 0 &&
          !(na == nb && memcmp(a, b, na) == 0),
          "webp negative control: quality 89 differs from the module's 90");
    free(a);
    free(b);
    free(px);
    check(!gv_native_webp_encodes(8, 8, 2) && !gv_native_webp_encodes(8, 8, 4) &&
          !gv_native_webp_encodes(16384, 1, 3) && gv_native_webp_encodes(16383, 1, 1),
          "webp: 2 and 4 channels and 16384 pixels wide are declined, 16383 taken");
    uint8_t two[8 * 8 * 2] = {0};
    err = (struct gv_error){0};
    check(gv_native_webp_encode(8, 8, 2, two, 90, &a, &na, &err) < 0 &&
          err.code == GV_EINVAL, "the native webp writer refuses 2 channels");
}

int main(void)
{
    uint64_t rng = 12345;
    static const uint32_t sizes[][2] = {
        {1, 1}, {7, 5}, {16, 16}, {17, 9}, {512, 512}, {326, 163},
        {16, 396}, {512, 96}, {1000, 3}, {3, 700}};
    static const int quality[] = {90, 1, 50, 75, 100, 0, 101};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (int c = 1; c <= 3; c += 2)
            for (int kind = 0; kind < 3; kind++)
                compare("jpg", sizes[s][0], sizes[s][1], c, kind,
                        quality[(s + (size_t)kind) % 7], &rng);
    for (size_t i = 0; i < sizeof quality / sizeof quality[0]; i++)
        compare("jpg", 64, 48, 3, 1, quality[i], &rng);
    /* WebP (method 6 is slow: fewer sizes, every kind and channel count) */
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s += 2)
        for (int c = 1; c <= 3; c += 2)
            for (int kind = 0; kind < 3; kind++)
                compare("webp", sizes[s][0], sizes[s][1], c, kind,
                        quality[(s + (size_t)kind + (size_t)c) % 7], &rng);
    webp_checks(&rng);

    /* Negative control: quality 89 is not the module's 90. */
    uint8_t *px = make_image(64, 64, 3, 0, &rng), *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    struct gv_error err = {0};
    check(encode_by(0, "module", "jpg", 64, 64, 3, px, 90, &a, &na, &err) == 0 &&
          gv_native_jpeg_encode(64, 64, 3, px, 89, &b, &nb, &err) == 0 &&
          !(na == nb && memcmp(a, b, na) == 0),
          "negative control: quality 89 differs from the module's 90");
    free(a);
    free(b);
    free(px);

    /* Declined: 2 channels and a side past libjpeg's 65500. */
    check(!gv_native_jpeg_encodes(8, 8, 2) &&
          !gv_native_jpeg_encodes(70000, 1, 3) &&
          gv_native_jpeg_encodes(65500, 1, 1),
          "2 channels and 70000 pixels wide are declined, 65500 taken");
    uint8_t two[8 * 8 * 2] = {0};
    uint8_t *out = NULL;
    size_t len = 0;
    err = (struct gv_error){0};
    check(gv_image_encode("jpg", 8, 8, 2, two, 90, &out, &len, &err) < 0 &&
          err.code == GV_EINVAL && strstr(err.text, "channels"),
          "2 channels go to the module, which refuses them: %s", err.text);
    free(out);
    err = (struct gv_error){0};
    check(gv_native_jpeg_encode(8, 8, 2, two, 90, &out, &len, &err) < 0 &&
          err.code == GV_EINVAL, "the native writer refuses 2 channels too");
    png_checks(&rng);
    png_file_checks(&rng);
    return tap_done();
}
