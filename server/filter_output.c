/*
 * filter_output.c - PNG, TIFF and raw encoders for filter results
 * (filter_output.h).
 *
 * PNG: IHDR, one IDAT (zlib level 6 over rows with the Sub filter, which
 * suits smooth images), IEND; colour type 0, 2 or 6 for 1, 3 or 4
 * channels.  TIFF: "II*\0", one IFD at offset 8 with the baseline tags and
 * SampleFormat (1 unsigned, 3 float), ExtraSamples = 2 (unassociated
 * alpha) for RGBA, and the pixels as one uncompressed strip.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <zlib.h>

#include "filter_output.h"
#include "imageio/output_format.h"

/* Each form's name, and the output format (imageio/output_format.h)
 * whose MIME type it has. */
static const struct {
    const char *name, *format;
} forms[] = {
    [FILTER_OUT_PNG] = {"png", "png"},
    [FILTER_OUT_TIFF16] = {"tiff16", "tif"},
    [FILTER_OUT_TIFF32F] = {"tiff32f", "tif"},
    [FILTER_OUT_RAW] = {"raw", "raw"},
};

int filter_output_parse(const char *name, enum filter_output_form *form)
{
    for (size_t i = 0; i < sizeof forms / sizeof forms[0]; i++)
        if (!strcmp(name, forms[i].name)) {
            *form = (enum filter_output_form)i;
            return 0;
        }
    return -1;
}

const char *filter_output_type(enum filter_output_form form)
{
    return gv_output_format_find(forms[form].format)->mime;
}

static uint8_t to_u8(float v)
{
    if (!(v > 0))
        return 0; /* negative or NaN */
    if (v >= 1)
        return 255;
    return (uint8_t)floorf(v * 255.0f + 0.5f);
}

static uint16_t to_u16(double v)
{
    if (!(v > 0))
        return 0;
    if (v >= 65535)
        return 65535;
    return (uint16_t)floor(v + 0.5);
}

static void be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

/* A PNG chunk at p: length, type, data (already there at p + 8), CRC. */
static size_t chunk(uint8_t *p, const char *type, size_t n)
{
    be32(p, (uint32_t)n);
    memcpy(p + 4, type, 4);
    be32(p + 8 + n, (uint32_t)crc32(crc32(0, NULL, 0), p + 4, (uInt)(n + 4)));
    return 12 + n;
}

static int encode_png(const float *rgba, uint32_t w, uint32_t h, int c,
                      uint8_t **out, size_t *len, struct gv_error *err)
{
    size_t stride = (size_t)w * (size_t)c + 1;
    size_t raw_len = stride * h;
    uint8_t *raw = malloc(raw_len);
    uLong bound = compressBound((uLong)raw_len);
    uint8_t *png = malloc(8 + 25 + 12 + bound + 12);
    if (!raw || !png || raw_len > UINT32_MAX) {
        free(raw);
        free(png);
        return gv_fail(err, GV_ENOMEM, "filter: out of memory for a %ux%u PNG", w, h);
    }
    for (uint32_t y = 0; y < h; y++) {
        uint8_t *row = raw + (size_t)y * stride;
        const float *src = rgba + (size_t)y * w * 4;
        row[0] = 1; /* Sub: each byte minus the one a pixel to the left */
        for (uint32_t x = 0; x < w; x++)
            for (int k = 0; k < c; k++)
                row[1 + (size_t)x * c + k] = to_u8(src[(size_t)x * 4 + k]);
        for (size_t i = stride - 1; i > (size_t)c; i--)
            row[i] = (uint8_t)(row[i] - row[i - c]);
    }
    static const uint8_t sig[8] = {137, 'P', 'N', 'G', 13, 10, 26, 10};
    static const uint8_t color[5] = {0, 0, 0, 2, 6};
    uint8_t *p = png;
    memcpy(p, sig, 8);
    p += 8;
    be32(p + 8, w);
    be32(p + 12, h);
    p[16] = 8;             /* bit depth */
    p[17] = color[c];      /* gray, RGB or RGBA */
    p[18] = p[19] = p[20] = 0; /* deflate, adaptive filters, no interlace */
    p += chunk(p, "IHDR", 13);
    uLongf zlen = bound;
    int zrc = compress2(p + 8, &zlen, raw, (uLong)raw_len, 6);
    free(raw);
    if (zrc != Z_OK) {
        free(png);
        return gv_fail(err, GV_ENOMEM, "filter: zlib error %d", zrc);
    }
    p += chunk(p, "IDAT", zlen);
    p += chunk(p, "IEND", 0);
    *out = png;
    *len = (size_t)(p - png);
    return 0;
}

static void le16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void le32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

/* One IFD entry: SHORT (type 3) or LONG (type 4), count, value or offset. */
static uint8_t *entry(uint8_t *p, uint16_t tag, uint16_t type, uint32_t count,
                      uint32_t value)
{
    le16(p, tag);
    le16(p + 2, type);
    le32(p + 4, count);
    le32(p + 8, 0);
    if (type == 3 && count == 1)
        le16(p + 8, (uint16_t)value);
    else
        le32(p + 8, value);
    return p + 12;
}

static int encode_tiff(const float *rgba, uint32_t w, uint32_t h, int c,
                       int float32, double scale, uint8_t **out, size_t *len,
                       struct gv_error *err)
{
    unsigned bytes = float32 ? 4 : 2;
    uint64_t data = (uint64_t)w * h * (uint64_t)c * bytes;
    int ntags = 11 + (c == 4);
    /* header, IFD, then two SHORT[c] arrays (bits, sample format) when
     * they do not fit in an entry, then the strip at an 8-byte boundary */
    uint32_t ifd = 8, arrays = ifd + 2 + 12 * (uint32_t)ntags + 4;
    uint32_t start = (arrays + 2 * 2 * (uint32_t)c + 7) & ~7u;
    if (data + start > UINT32_MAX)
        return gv_fail(err, GV_ELIMIT, "filter: a %ux%u TIFF would exceed 4 GiB", w, h);
    uint8_t *t = calloc(1, (size_t)(start + data));
    if (!t)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory for a %ux%u TIFF", w, h);
    memcpy(t, "II*\0", 4);
    le32(t + 4, ifd);
    le16(t + ifd, (uint16_t)ntags);
    uint32_t bits_at = arrays, fmt_at = arrays + 2 * (uint32_t)c;
    for (int k = 0; k < c; k++) {
        le16(t + bits_at + 2 * k, (uint16_t)(bytes * 8));
        le16(t + fmt_at + 2 * k, float32 ? 3 : 1);
    }
    /* c <= 2 SHORTs fit in the entry itself; here c is 1, 3 or 4 */
    uint32_t bits_val = c == 1 ? bytes * 8 : bits_at;
    uint32_t fmt_val = c == 1 ? (float32 ? 3u : 1u) : fmt_at;
    uint8_t *e = t + ifd + 2;
    e = entry(e, 256, 4, 1, w);                       /* ImageWidth */
    e = entry(e, 257, 4, 1, h);                       /* ImageLength */
    e = entry(e, 258, 3, (uint32_t)c, bits_val);      /* BitsPerSample */
    e = entry(e, 259, 3, 1, 1);                       /* no compression */
    e = entry(e, 262, 3, 1, c == 1 ? 1 : 2);          /* BlackIsZero, RGB */
    e = entry(e, 273, 4, 1, start);                   /* StripOffsets */
    e = entry(e, 277, 3, 1, (uint32_t)c);             /* SamplesPerPixel */
    e = entry(e, 278, 4, 1, h);                       /* RowsPerStrip */
    e = entry(e, 279, 4, 1, (uint32_t)data);          /* StripByteCounts */
    e = entry(e, 284, 3, 1, 1);                       /* chunky */
    if (c == 4)
        e = entry(e, 338, 3, 1, 2);                   /* unassociated alpha */
    e = entry(e, 339, 3, (uint32_t)c, fmt_val);       /* SampleFormat */
    le32(e, 0);                                       /* no next IFD */
    uint8_t *px = t + start;
    size_t n = (size_t)w * h;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < c; k++) {
            float v = rgba[i * 4 + (size_t)k];
            if (float32) {
                uint32_t u;
                memcpy(&u, &v, 4);
                le32(px, u);
                px += 4;
            } else {
                le16(px, to_u16((double)v * scale));
                px += 2;
            }
        }
    *out = t;
    *len = (size_t)(start + data);
    return 0;
}

static int encode_raw(const float *rgba, uint32_t w, uint32_t h, int c,
                      uint8_t **out, size_t *len, struct gv_error *err)
{
    size_t n = (size_t)w * h;
    uint8_t *o = malloc(n * (size_t)c * 4 + 1);
    if (!o)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory for %ux%u floats", w, h);
    uint8_t *p = o;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < c; k++) {
            uint32_t u;
            memcpy(&u, &rgba[i * 4 + (size_t)k], 4);
            le32(p, u);
            p += 4;
        }
    *out = o;
    *len = n * (size_t)c * 4;
    return 0;
}

int filter_output_encode(enum filter_output_form form, const float *rgba,
                         uint32_t w, uint32_t h, int channels, double scale,
                         uint8_t **out, size_t *len, struct gv_error *err)
{
    if (channels != 1 && channels != 3 && channels != 4)
        return gv_fail(err, GV_EINVAL, "filter: %d output channels", channels);
    switch (form) {
    case FILTER_OUT_PNG:
        return encode_png(rgba, w, h, channels, out, len, err);
    case FILTER_OUT_TIFF16:
        return encode_tiff(rgba, w, h, channels, 0, scale, out, len, err);
    case FILTER_OUT_TIFF32F:
        return encode_tiff(rgba, w, h, channels, 1, scale, out, len, err);
    case FILTER_OUT_RAW:
        return encode_raw(rgba, w, h, channels, out, len, err);
    }
    return gv_fail(err, GV_EINVAL, "filter: unknown output form");
}
