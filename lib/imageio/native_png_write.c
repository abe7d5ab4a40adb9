/*
 * native_png_write.c - PNG output through libpng (see
 * native_png_write.h).
 *
 * What OpenImageIO 2.4's PNG writer (pngoutput.cpp, png_pvt.h
 * write_info) does for the image specs the module's encode gives it (no
 * metadata, unassociated alpha, origin 0,0), and so this file: IHDR of
 * the samples' depth and colour type (gray, gray-alpha, RGB, RGBA by the
 * channel count), not interlaced; an oFFs chunk of 0,0 pixels (the
 * spec's origin); zlib level 6 with the default strategy (libpng's
 * own default is Z_FILTERED), libpng's adaptive filters and IDAT size; png_set_swap on a little-endian host for
 * 16-bit samples; one png_write_row per row, top to bottom; IEND.  No
 * gAMA, sRGB, pHYs or text chunk.  tests/test_native_write.c compares the
 * bytes with the module's over sizes, channel counts and both depths.
 *
 * The output grows in a buffer of our own (libpng calls write_bytes with
 * each piece), starting at a guess of the compressed size.  libpng's
 * errors longjmp back here: the buffer is freed and its message kept.
 */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>
#include <zlib.h>

#include "imageio/native_png_write.h"

/* The growing output, and libpng's last error. */
struct sink {
    uint8_t *buf;
    size_t len, cap;
    int oom;
    char msg[200];
};

static void write_bytes(png_structp png, png_bytep data, size_t n)
{
    struct sink *s = png_get_io_ptr(png);
    if (n > s->cap - s->len) {
        size_t cap = s->cap ? s->cap : 4096;
        while (n > cap - s->len) {
            if (cap > SIZE_MAX / 2) {
                s->oom = 1;
                png_error(png, "output too large");
            }
            cap *= 2;
        }
        uint8_t *b = realloc(s->buf, cap);
        if (!b) {
            s->oom = 1;
            png_error(png, "out of memory");
        }
        s->buf = b;
        s->cap = cap;
    }
    memcpy(s->buf + s->len, data, n);
    s->len += n;
}

static void flush_bytes(png_structp png)
{
    (void)png;
}

/* libpng's error callback: keep the message, jump back.  Must not
 * return. */
static void on_error(png_structp png, png_const_charp msg)
{
    struct sink *s = png_get_error_ptr(png);
    snprintf(s->msg, sizeof s->msg, "%s", msg);
    png_longjmp(png, 1);
}

/* Warnings cannot concern our own well-formed samples: not printed. */
static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

int gv_native_png_encodes(uint32_t width, uint32_t height, int channels,
                          enum gv_sample sample)
{
    return ((sample == GV_SAMPLE_U8 && (channels == 1 || channels == 3)) ||
            (sample == GV_SAMPLE_U16 && channels >= 1 && channels <= 4)) &&
           width >= 1 && height >= 1 && width <= PNG_UINT_31_MAX &&
           height <= PNG_UINT_31_MAX;
}

/* Whether this host stores 16-bit values least significant byte first. */
static int little_endian(void)
{
    const uint16_t one = 1;
    return *(const uint8_t *)&one == 1;
}

/* gv_native_png_encode of a checked image, into s.  0, or -1. */
static int write_png(uint32_t width, uint32_t height, int channels,
                    enum gv_sample sample, const uint8_t *pixels,
                    struct sink *s)
{
    static const int colour[5] = {0, PNG_COLOR_TYPE_GRAY,
                                  PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                  PNG_COLOR_TYPE_RGB_ALPHA};
    const int depth = sample == GV_SAMPLE_U16 ? 16 : 8;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, s,
                                              on_error, on_warning);
    if (!png) {
        s->oom = 1;
        return -1;
    }
    png_infop info = png_create_info_struct(png);
    if (!info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, info ? &info : NULL);
        return -1;
    }
    png_set_write_fn(png, s, write_bytes, flush_bytes);
    png_set_IHDR(png, info, width, height, depth, colour[channels],
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_oFFs(png, info, 0, 0, PNG_OFFSET_PIXEL);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
    png_write_info(png, info);
    if (depth == 16 && little_endian())
        png_set_swap(png);
    const size_t row = (size_t)width * (size_t)channels * (size_t)(depth / 8);
    for (uint32_t y = 0; y < height; y++)   /* libpng copies, never writes it */
        png_write_row(png, (png_const_bytep)(pixels + (size_t)y * row));
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return 0;
}

int gv_native_png_encode(uint32_t width, uint32_t height, int channels,
                         enum gv_sample sample, const void *pixels,
                         uint8_t **out, size_t *len, struct gv_error *err)
{
    if (!gv_native_png_encodes(width, height, channels, sample))
        return gv_fail(err, GV_EINVAL, "imageio: cannot encode %ux%u pixels "
                       "of %d channels of this sample type as PNG", width,
                       height, channels);
    struct sink s = {0};
    /* A guess of the size: half the samples' bytes and the chunks, at
     * most 64 MiB (it doubles from there). */
    size_t guess = (size_t)width * height * (size_t)channels *
                   (sample == GV_SAMPLE_U16 ? 2u : 1u) / 2 + 1024;
    if (guess > (size_t)1 << 26)
        guess = (size_t)1 << 26;
    s.buf = malloc(guess);
    s.cap = s.buf ? guess : 0;
    if (write_png(width, height, channels, sample, pixels, &s) < 0) {
        free(s.buf);
        if (s.oom)
            return gv_fail(err, GV_ENOMEM, "imageio: encoding png: out of "
                           "memory");
        return gv_fail(err, GV_EIO, "imageio: encoding png: %s", s.msg);
    }
    *out = s.buf;
    *len = s.len;
    return 0;
}
