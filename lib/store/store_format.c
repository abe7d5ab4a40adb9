/*
 * store_format.c - header (de)serialization, the root codec and the
 * box filter that defines every pyramid level (see store_format.h and
 * docs/FORMAT.md).
 */
#include <math.h>
#include <stdlib.h>

#include <webp/decode.h>
#include <webp/encode.h>
#include <zlib.h>

#include "base/error.h"
#include "store/geometry.h"
#include "store/store_format.h"

/* IEEE 754 doubles and floats, little-endian like every other field. */
static void gv_put_f64(uint8_t *p, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    gv_put64(p, u);
}
static void gv_put_f32(uint8_t *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    gv_put32(p, u);
}
static double gv_get_f64(const uint8_t *p)
{
    uint64_t u = gv_get64(p);
    double v;
    memcpy(&v, &u, 8);
    return v;
}
static float gv_get_f32(const uint8_t *p)
{
    uint32_t u = gv_get32(p);
    float v;
    memcpy(&v, &u, 4);
    return v;
}

/* Same shape as head_pack and record_pack in encode/shard_file.c, and its own
 * height fields below: deliberately separate, one field of the store header a
 * line. */
void gv_header_pack(const struct gv_header *h, uint8_t out[GV_HEADER_SIZE])
{
    memset(out, 0, GV_HEADER_SIZE);
    memcpy(out, GV_MAGIC, 8);
    gv_put16(out + 8, h->version);
    gv_put16(out + 10, GV_HEADER_SIZE);
    gv_put32(out + 12, h->width);
    gv_put32(out + 16, h->height);
    out[20] = h->channels;
    out[21] = h->root;
    out[22] = h->root_mips;
    out[23] = h->max_rate;
    gv_put16(out + 24, GV_TILE);
    gv_put16(out + 26, GV_STEP);
    out[28] = GV_PAGE_TILES;
    out[29] = h->src_bits;
    out[30] = h->src_float;
    out[31] = h->tone;
    gv_put32(out + 32, h->target_mpsnr);
    gv_put32(out + 36, h->psnr0_mdb);
    gv_put64(out + 40, h->root_offset);
    gv_put64(out + 48, h->root_size);
    gv_put64(out + 56, h->index_offset);
    gv_put64(out + 64, h->pages);
    gv_put64(out + 72, h->file_size);
    if (h->kind == GV_KIND_HEIGHT) {
        out[80] = h->kind;
        out[81] = h->height_float;
        gv_put16(out + 82, h->height_e);
        gv_put_f64(out + 84, h->height_scale);
        gv_put_f64(out + 92, h->height_offset);
        gv_put_f64(out + 100, h->height_max_error);
        gv_put_f32(out + 108, h->height_min);
        gv_put_f32(out + 112, h->height_max);
        memcpy(out + 116, h->height_unit, strnlen(h->height_unit, GV_HEIGHT_UNIT));
    } else {
        gv_put64(out + 80, h->meta_offset);
        gv_put32(out + 88, h->meta_size);
        gv_put32(out + 92, h->meta_crc);
        if (h->version >= GV_VERSION_SMALL_ROOT)
            gv_put16(out + 96, h->root_side);
    }
    if (h->kind == GV_KIND_SAMPLES) {   /* version 7: section 13 */
        out[98] = h->height_float;
        gv_put16(out + 100, h->height_e);
        gv_put_f64(out + 102, h->height_scale);
        gv_put_f64(out + 110, h->height_offset);
        gv_put16(out + 118, h->samples_lo);
        gv_put16(out + 120, h->samples_hi);
    }
    gv_put32(out + 124, gv_crc32(0, out, 124));
}

/* Same shape as head_unpack and record_unpack in encode/shard_file.c:
 * deliberately separate, the store header is its own layout. */
int gv_header_unpack(const uint8_t in[GV_HEADER_SIZE], struct gv_header *h,
                     struct gv_error *err)
{
    if (memcmp(in, GV_MAGIC, 8) != 0)
        return gv_fail(err, GV_EFORMAT, "store: not a gigaview store (bad magic)");
    h->version = gv_get16(in + 8);
    if (h->version < GV_VERSION_MIN || h->version > GV_VERSION_MAX)
        return gv_fail(err, GV_EFORMAT, "store: format version %u is not "
                       "supported (this build reads versions %d to %d)",
                       h->version, GV_VERSION_MIN, GV_VERSION_MAX);
    if (gv_get32(in + 124) != gv_crc32(0, in, 124))
        return gv_fail(err, GV_ECORRUPT, "store: header CRC mismatch");
    if (gv_get16(in + 10) != GV_HEADER_SIZE || gv_get16(in + 24) != GV_TILE ||
        gv_get16(in + 26) != GV_STEP || in[28] != GV_PAGE_TILES)
        return gv_fail(err, GV_ECORRUPT, "store: unexpected header or tile "
                       "layout constants");
    h->width = gv_get32(in + 12);
    h->height = gv_get32(in + 16);
    h->channels = in[20];
    h->root = in[21];
    h->root_mips = in[22];
    h->max_rate = in[23];
    h->src_bits = in[29];
    h->src_float = in[30];
    h->tone = in[31];
    h->target_mpsnr = gv_get32(in + 32);
    h->psnr0_mdb = gv_get32(in + 36);
    h->root_offset = gv_get64(in + 40);
    h->root_size = gv_get64(in + 48);
    h->index_offset = gv_get64(in + 56);
    h->pages = gv_get64(in + 64);
    h->file_size = gv_get64(in + 72);
    h->kind = GV_KIND_IMAGE;
    h->height_float = 0;
    h->height_e = 0;
    h->height_scale = 1;
    h->height_offset = h->height_max_error = 0;
    h->height_min = h->height_max = 0;
    memset(h->height_unit, 0, sizeof h->height_unit);
    h->samples_lo = h->samples_hi = 0;
    h->meta_offset = 0;
    h->meta_size = h->meta_crc = 0;
    if (h->version != GV_VERSION_HEIGHT) {
        /* Image stores: the metadata section, or zeros (section 6). */
        h->meta_offset = gv_get64(in + 80);
        h->meta_size = gv_get32(in + 88);
        h->meta_crc = gv_get32(in + 92);
    }
    h->root_side = GV_ROOT_MAX;
    if (h->version >= GV_VERSION_SMALL_ROOT) {
        h->root_side = gv_get16(in + 96);
        if (h->root_side < 1 || h->root_side > GV_ROOT_MAX)
            return gv_fail(err, GV_ECORRUPT, "store: root side %u is not "
                           "1..%d", h->root_side, GV_ROOT_MAX);
    }
    if (h->version == GV_VERSION_HEIGHT) {
        /* Version 3 is the height store: one channel, finite mapping. */
        h->kind = in[80];
        h->height_float = in[81];
        h->height_e = gv_get16(in + 82);
        h->height_scale = gv_get_f64(in + 84);
        h->height_offset = gv_get_f64(in + 92);
        h->height_max_error = gv_get_f64(in + 100);
        h->height_min = gv_get_f32(in + 108);
        h->height_max = gv_get_f32(in + 112);
        memcpy(h->height_unit, in + 116, GV_HEIGHT_UNIT);
        int bad_unit = 0;
        for (int i = 0; i < GV_HEIGHT_UNIT; i++)
            bad_unit |= h->height_unit[i] && (h->height_unit[i] < 0x21 ||
                                              h->height_unit[i] > 0x7e);
        if (bad_unit || h->kind != GV_KIND_HEIGHT || h->channels != 1 || in[81] > 1 ||
            h->height_e > 32767 || !isfinite(h->height_scale) ||
            !(h->height_scale > 0) || !isfinite(h->height_offset) ||
            !isfinite(h->height_max_error) || h->height_max_error < 0 ||
            !isfinite(h->height_min) || !isfinite(h->height_max) ||
            h->height_min > h->height_max)
            return gv_fail(err, GV_ECORRUPT, "store: bad height store header");
    } else if (h->version == GV_VERSION_SAMPLES) {
        /* Version 7 is the sample store: 1..8 channels, finite mapping. */
        h->kind = GV_KIND_SAMPLES;
        h->height_float = in[98];
        h->height_e = gv_get16(in + 100);
        h->height_scale = gv_get_f64(in + 102);
        h->height_offset = gv_get_f64(in + 110);
        h->samples_lo = gv_get16(in + 118);
        h->samples_hi = gv_get16(in + 120);
        if (h->channels < 1 || h->channels > GV_SAMPLES_MAX_CHANNELS ||
            in[98] > 1 || in[99] || gv_get16(in + 122) ||
            h->height_e > 32767 || !isfinite(h->height_scale) ||
            !(h->height_scale > 0) || !isfinite(h->height_offset) ||
            h->samples_lo > h->samples_hi)
            return gv_fail(err, GV_ECORRUPT, "store: bad sample store header");
        gv_samples_derive(h);
    } else if (h->channels != 1 && h->channels != 3) {
        return gv_fail(err, GV_ECORRUPT, "store: an image store has %u "
                       "channels (1 or 3)", h->channels);
    }
    return 0;
}

void gv_samples_derive(struct gv_header *h)
{
    const double s = h->height_scale, o = h->height_offset;
    h->height_min = (float)(h->samples_lo * s + o);
    h->height_max = (float)(h->samples_hi * s + o);
    h->height_max_error = h->height_float
        ? s * (h->height_e + 0.5) + 1e-12 * fmax(fabs((double)h->height_min),
                                                 fabs((double)h->height_max))
        : s * h->height_e;
}

uint64_t gv_root_pixels_size(uint32_t w, uint32_t h, int channels)
{
    uint64_t total = 0;
    for (;;) {
        total += (uint64_t)w * h * (unsigned)channels;
        if (w == 1 && h == 1)
            break;
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
    return total;
}

/* gv_box_reduce_row for a channel count known at compile time (1 or 3,
 * always_inline), in two steps that the compiler vectorizes: the columns'
 * sums of the two rows in 16 bits, 64 pixels at a time, then the pairs of
 * them.  The same sums as the one-step formula, 1.7 times faster (perf:
 * 3.6 -> 2.1 % of a 54 MP mosaic's encode; 12 % of a 1 GP one's pass 1
 * was here). */
__attribute__((always_inline)) static inline void
box_reduce_row_c(const uint8_t *r0, const uint8_t *r1, uint32_t sw,
                 const int c, uint8_t *dst)
{
    enum { SPAN = 64 };
    uint16_t v[SPAN * 3];
    const uint32_t pairs = sw / 2;
    for (uint32_t x0 = 0; x0 < pairs; x0 += SPAN / 2) {
        const uint32_t n = pairs - x0 < SPAN / 2 ? pairs - x0 : SPAN / 2;
        const uint8_t *a = r0 + (size_t)2 * x0 * c, *b = r1 + (size_t)2 * x0 * c;
        for (uint32_t i = 0; i < 2 * n * (uint32_t)c; i++)
            v[i] = (uint16_t)(a[i] + b[i]);
        uint8_t *d = dst + (size_t)x0 * c;
        for (uint32_t x = 0; x < n; x++)
            for (int ch = 0; ch < c; ch++)
                d[x * c + ch] = (uint8_t)((v[2 * x * c + ch] +
                                           v[(2 * x + 1) * c + ch] + 2) >> 2);
    }
    if (sw & 1) {   /* the last column pairs with itself */
        const uint32_t a = sw - 1;
        for (int ch = 0; ch < c; ch++)
            dst[pairs * c + ch] = (uint8_t)((2 * r0[a * c + ch] +
                                             2 * r1[a * c + ch] + 2) >> 2);
    }
}

void gv_box_reduce_row(const uint8_t *r0, const uint8_t *r1, uint32_t sw,
                       int channels, uint8_t *dst)
{
    if (channels == 3) {
        box_reduce_row_c(r0, r1, sw, 3, dst);
        return;
    }
    if (channels == 1) {
        box_reduce_row_c(r0, r1, sw, 1, dst);
        return;
    }
    const uint32_t dw = (sw + 1) / 2;
    for (uint32_t x = 0; x < dw; x++) {
        uint32_t a = 2 * x, b = 2 * x + 1 < sw ? 2 * x + 1 : 2 * x;
        for (int c = 0; c < channels; c++) {
            unsigned s = r0[a * channels + c] + r0[b * channels + c] +
                         r1[a * channels + c] + r1[b * channels + c] + 2;
            dst[x * channels + c] = (uint8_t)(s >> 2);
        }
    }
}

void gv_box_reduce(const uint8_t *src, uint32_t sw, uint32_t sh, int channels,
                   uint8_t *dst)
{
    const uint32_t dw = (sw + 1) / 2, dh = (sh + 1) / 2;
    const size_t srow = (size_t)sw * channels, drow = (size_t)dw * channels;
    for (uint32_t y = 0; y < dh; y++) {
        const uint8_t *r0 = src + (size_t)(2 * y) * srow;
        const uint8_t *r1 = 2 * y + 1 < sh ? r0 + srow : r0;
        gv_box_reduce_row(r0, r1, sw, channels, dst + (size_t)y * drow);
    }
}

/* The root as RGB rows: gray roots are widened to three equal channels
 * (WebP has no gray mode; its lossless transforms make the copies nearly
 * free).  near_lossless is libwebp's setting: 100 is lossless. */
static int root_webp(const uint8_t *pixels, uint32_t w, uint32_t h, int channels,
                     int near_lossless, uint8_t **out, size_t *len,
                     struct gv_error *err)
{
    const uint8_t *rgb = pixels;
    uint8_t *wide = NULL;
    if (channels == 1) {
        wide = malloc((size_t)w * h * 3);
        if (!wide)
            return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
        for (size_t i = 0; i < (size_t)w * h; i++)
            wide[3 * i] = wide[3 * i + 1] = wide[3 * i + 2] = pixels[i];
        rgb = wide;
    }
    WebPConfig cfg;
    WebPPicture pic;
    WebPMemoryWriter wr;
    int ok = WebPConfigInit(&cfg) && WebPConfigLosslessPreset(&cfg, GV_ROOT_EFFORT) &&
             WebPPictureInit(&pic);
    if (!ok) {
        free(wide);
        return gv_fail(err, GV_EFORMAT, "store: libwebp version mismatch");
    }
    /* exact (keep RGB under transparent pixels: there are none) would
     * switch the near-lossless quantization off. */
    cfg.exact = near_lossless >= 100;
    cfg.near_lossless = near_lossless;
    pic.use_argb = 1;
    pic.width = (int)w;
    pic.height = (int)h;
    WebPMemoryWriterInit(&wr);
    pic.writer = WebPMemoryWrite;
    pic.custom_ptr = &wr;
    ok = WebPPictureImportRGB(&pic, rgb, (int)w * 3) && WebPEncode(&cfg, &pic);
    WebPPictureFree(&pic);
    free(wide);
    if (!ok) {
        WebPMemoryWriterClear(&wr);
        return gv_fail(err, GV_ENOMEM, "store: WebP lossless encoding of the "
                       "root failed (%d)", pic.error_code);
    }
    *out = wr.mem;   /* allocated by libwebp with malloc; freed with free() */
    *len = wr.size;
    return 0;
}

int gv_root_pack(const uint8_t *pixels, uint32_t w, uint32_t h, int channels,
                 uint8_t **out, size_t *len, struct gv_error *err)
{
    return root_webp(pixels, w, h, channels, 100, out, len, err);
}

int gv_root_near_lossless(double target_psnr)
{
    /* Measured on two photographs in --rd mode (docs/FORMAT.md section
     * 6): q 28 -> 40, 32 -> 60, 36 -> 80 gain 0 to 1.6 dB at equal bytes;
     * one step lower loses up to 0.5 dB at q 36 and above. */
    long level = lround(5.0 * target_psnr - 100.0);
    return level < 0 ? 0 : (level > 100 ? 100 : (int)level);
}

int gv_root_approx(uint8_t *pixels, uint32_t w, uint32_t h, int channels,
                   int near_lossless, struct gv_error *err)
{
    if (near_lossless >= 100)
        return 0;
    uint8_t *z;
    size_t zlen;
    if (root_webp(pixels, w, h, channels, near_lossless, &z, &zlen, err) < 0)
        return -1;
    int rc = gv_root_unpack(z, zlen, w, h, channels, pixels, err);
    free(z);
    return rc;
}

int gv_root_unpack(const uint8_t *in, size_t len, uint32_t w, uint32_t h,
                   int channels, uint8_t *out, struct gv_error *err)
{
    int fw = 0, fh = 0;
    if (!WebPGetInfo(in, len, &fw, &fh) || fw != (int)w || fh != (int)h)
        return gv_fail(err, GV_ECORRUPT, "store: the root is not a %ux%u "
                       "WebP image", w, h);
    const size_t n = (size_t)w * h * 3;
    uint8_t *rgb = channels == 3 ? out : malloc(n);
    if (!rgb)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
    if (!WebPDecodeRGBInto(in, len, rgb, n, (int)w * 3)) {
        if (rgb != out)
            free(rgb);
        return gv_fail(err, GV_ECORRUPT, "store: the root does not decode");
    }
    if (channels == 1) {
        for (size_t i = 0; i < (size_t)w * h; i++)
            out[i] = rgb[3 * i];
        free(rgb);
    }
    return 0;
}

void gv_root_build_mips(uint8_t *buf, uint32_t w, uint32_t h, int channels)
{
    uint8_t *cur = buf;
    while (w > 1 || h > 1) {
        uint8_t *next = cur + (size_t)w * h * channels;
        gv_box_reduce(cur, w, h, channels, next);
        cur = next;
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
}

int gv_codes_root_pack(const uint16_t *codes, uint32_t w, uint32_t h, int c,
                       uint8_t **out, size_t *len, struct gv_error *err)
{
    const size_t n = (size_t)w * h * (size_t)c, row = (size_t)w * c;
    uint8_t *raw = malloc(2 * n);
    uLongf zlen = compressBound((uLong)(2 * n));
    uint8_t *z = malloc(zlen);
    if (!raw || !z) {
        free(raw);
        free(z);
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
    }
    for (uint32_t y = 0; y < h; y++)
        for (size_t x = 0; x < row; x++) {
            size_t i = (size_t)y * row + x;
            gv_put16(raw + 2 * i, (uint16_t)(codes[i] - (x >= (size_t)c ? codes[i - c] : 0)));
        }
    int zr = compress2(z, &zlen, raw, (uLong)(2 * n), 9);
    free(raw);
    if (zr != Z_OK) {
        free(z);
        return gv_fail(err, GV_ENOMEM, "store: deflate of the root failed");
    }
    *out = z;
    *len = zlen;
    return 0;
}

int gv_codes_root_unpack(const uint8_t *in, size_t len, uint32_t w,
                         uint32_t h, int c, uint16_t *out,
                         struct gv_error *err)
{
    const size_t n = (size_t)w * h * (size_t)c, row = (size_t)w * c;
    uint8_t *raw = malloc(2 * n + 1);
    if (!raw)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
    uLongf got = (uLongf)(2 * n + 1);
    int zr = uncompress(raw, &got, in, (uLong)len);
    if (zr != Z_OK || got != 2 * n) {
        free(raw);
        return gv_fail(err, GV_ECORRUPT, "store: the root does not inflate "
                       "to %ux%u pixels of %d codes", w, h, c);
    }
    for (uint32_t y = 0; y < h; y++)
        for (size_t x = 0; x < row; x++) {
            size_t i = (size_t)y * row + x;
            out[i] = (uint16_t)(gv_get16(raw + 2 * i) + (x >= (size_t)c ? out[i - c] : 0));
        }
    free(raw);
    return 0;
}

void gv_codes_box_reduce_row(const uint16_t *r0, const uint16_t *r1,
                             uint32_t sw, int c, uint16_t *dst)
{
    const uint32_t dw = (sw + 1) / 2;
    for (uint32_t x = 0; x < dw; x++) {
        size_t a = (size_t)2 * x * c;
        size_t b = (2 * x + 1 < sw ? (size_t)(2 * x + 1) : (size_t)2 * x) * c;
        for (int k = 0; k < c; k++)
            dst[(size_t)x * c + k] =
                (uint16_t)((r0[a + k] + r0[b + k] + r1[a + k] + r1[b + k] + 2u) >> 2);
    }
}

void gv_codes_box_reduce(const uint16_t *src, uint32_t sw, uint32_t sh, int c,
                         uint16_t *dst)
{
    const uint32_t dw = (sw + 1) / 2, dh = (sh + 1) / 2;
    const size_t srow = (size_t)sw * c;
    for (uint32_t y = 0; y < dh; y++) {
        const uint16_t *r0 = src + (size_t)(2 * y) * srow;
        const uint16_t *r1 = 2 * y + 1 < sh ? r0 + srow : r0;
        gv_codes_box_reduce_row(r0, r1, sw, c, dst + (size_t)y * dw * c);
    }
}
