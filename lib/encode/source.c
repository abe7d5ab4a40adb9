/*
 * source.c - the encoder's input: one image, a mosaic of images or a
 * procedural pattern, delivered as 8-bit gray or RGB rows, top to bottom.
 *
 * Design.  A single image is a 1 x 1 mosaic.  Opening probes every tile
 * header (gv_image_open, then close) to validate the grid and compute the
 * total size; reading then opens one grid row at a time, keeping that
 * row's `cols` inputs open, and concatenates their scanlines.  A single
 * image is read through the handle of its probe: opening a progressive
 * JPEG decodes all its scans, which took twice the time of the rest of
 * pass 1 when done twice (an 8 MP photograph: 0.63 -> 0.55 s encode).
 * Tiles are read in chunks of rows into one scratch buffer (about 4 MiB),
 * so memory does not grow with the image height, and the whole grid row
 * is never held.  The synthetic pattern computes each pixel from (x, y) alone.
 *
 * Channels: 1 channel is gray; 2 (gray + alpha) is gray, alpha dropped;
 * 3 or more give RGB from the first three.  Every tile of a mosaic must
 * agree on gray or colour and on sample type and depth, so that one rule
 * (info->tone) covers the whole image.
 *
 * Bringing samples to 8 bits, exactly (v is the sample as gv_image_read
 * delivers it: 0..255 for files of 8 bits or fewer, the file's own units
 * 0..2^bits-1 for 9..16-bit integer files, the raw value for float files;
 * "round(t)" below is floor(t + 0.5) computed in double precision):
 *
 *   GV_TONE_NONE       8-bit (or narrower) integer input: out = v.
 *   GV_TONE_SCALE      9..16-bit integer input, m = 2^bits - 1:
 *                      out = (v * 255 + (m - 1) / 2) / m   (integer division,
 *                      i.e. v * 255 / m rounded to nearest).
 *   GV_TONE_SRGB_CLIP  half/float/double input, taken as linear light:
 *                      c = v clipped to [0, 1] (NaN counts as 0);
 *                      e = 12.92 c                    if c < 0.0031308,
 *                      e = 1.055 c^(1/2.4) - 0.055    otherwise;
 *                      out = round(255 e).
 *                      Implemented without pow() per sample: the 255 float
 *                      thresholds at which out steps up are found once per
 *                      source by evaluating that formula, and a sample is
 *                      placed among them by an 8-step binary search, so
 *                      the result equals the formula for every float.
 *   GV_TONE_RANGE      any input when opts->range_hi > opts->range_lo, with
 *                      lo, hi in the same units as v:
 *                      out = round((v - lo) * 255 / (hi - lo)) clamped to
 *                      [0, 255]; NaN gives 0.
 * Integer rules go through a table of 256 or 65536 entries.
 *
 * Native mode (opts->native, for height stores) skips all of the above:
 * samples are copied as gv_image_read delivers them, every channel, and
 * the terrain pattern synth-height: is one more kind of input.
 */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "imageio/imageio.h"
#include "encode/source.h"
#include "encode/synth_height.h"

/* Rows read from a tile per gv_image_read call are capped so that the
 * scratch buffer stays near this size (but always at least one row). */
#define CHUNK_BYTES (4u << 20)

enum kind { KIND_IMAGES, KIND_SYNTH, KIND_SYNTH_HEIGHT };

struct tile {
    char *path;
    struct gv_image_info info;
    uint32_t x0;            /* first column of this tile in the image */
};

struct gv_source {
    enum kind kind;
    uint32_t width, height;
    int channels;           /* 1 or 3 (native: the input's) */
    int native;             /* samples copied as they are */
    size_t px_bytes;        /* bytes of a delivered pixel */
    uint32_t next_row;
    int failed;             /* an input failed: refuse further reads */

    /* images (a single image is a 1 x 1 grid) */
    int cols, rows;
    struct tile *tiles;     /* cols * rows, row by row */
    uint32_t *row_h;        /* height of each grid row */
    int grid_row;           /* grid row whose inputs are open, or -1 */
    uint32_t grid_row_left; /* rows still to deliver from it */
    struct gv_image_in **open;  /* cols inputs of grid_row */
    struct gv_image_in *probed; /* a single image: its probe, kept open
                                 * for the reading (opening a progressive
                                 * JPEG decodes every scan) */
    unsigned char *scratch;
    size_t scratch_size;
    struct gv_image_limits limits;  /* max_pixels below, and the decoder's */
    uint64_t max_pixels;

    /* tone */
    enum gv_tone_rule tone;
    enum gv_sample sample;
    uint8_t *lut;           /* 256 (U8) or 65536 (U16) entries, or NULL */
    float thr[256];         /* SRGB_CLIP: step thresholds, thr[255] = inf */
    double lo, scale;       /* RANGE on float input */

    /* synth */
    uint64_t kx, ky;        /* gradient slopes, see synth_row */
};

/* ---- tone mapping ---- */

static uint8_t round_clamp(double t)
{
    if (!(t > 0.0))         /* also NaN */
        return 0;
    t = floor(t + 0.5);
    return t >= 255.0 ? 255 : (uint8_t)t;
}

static int srgb_code(float x)
{
    double c = x;
    if (!(c > 0.0))
        c = 0.0;
    if (c > 1.0)
        c = 1.0;
    double e = c < 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
    return (int)floor(255.0 * e + 0.5);
}

/* thr[k-1] = the smallest float x with srgb_code(x) >= k, k = 1..255. */
static void srgb_thresholds(float *thr)
{
    for (int k = 1; k <= 255; k++) {
        /* start from the inverse curve, then walk to the exact float */
        double e = (k - 0.5) / 255.0;
        double c = e < 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
        float x = (float)c;
        while (srgb_code(x) < k)
            x = nextafterf(x, 2.0f);
        while (x > 0.0f && srgb_code(nextafterf(x, -1.0f)) >= k)
            x = nextafterf(x, -1.0f);
        thr[k - 1] = x;
    }
    thr[255] = INFINITY;
}

/* Number of thresholds <= v: the SRGB_CLIP code.  NaN compares false
 * everywhere and gives 0. */
static inline uint8_t srgb_lookup(const float *thr, float v)
{
    unsigned k = 0;
    for (unsigned step = 128; step > 0; step >>= 1)
        if (v >= thr[k + step - 1])
            k += step;
    return (uint8_t)k;
}

static int setup_tone(struct gv_source *s, const struct gv_source_opts *o,
                      const struct gv_image_info *info, struct gv_error *err)
{
    int range = o && o->range_hi > o->range_lo;
    size_t n = 0;
    if (range && (!isfinite(o->range_lo) || !isfinite(o->range_hi)))
        return gv_fail(err, GV_EINVAL, "source: range must be finite");
    s->sample = info->sample;
    if (info->sample == GV_SAMPLE_F32) {
        if (range) {
            s->tone = GV_TONE_RANGE;
            s->lo = o->range_lo;
            s->scale = 255.0 / (o->range_hi - o->range_lo);
        } else {
            s->tone = GV_TONE_SRGB_CLIP;
            srgb_thresholds(s->thr);
        }
        return 0;
    }
    if (info->sample == GV_SAMPLE_U8) {
        s->tone = range ? GV_TONE_RANGE : GV_TONE_NONE;
        n = 256;
    } else {
        s->tone = range ? GV_TONE_RANGE : GV_TONE_SCALE;
        n = 65536;
    }
    if (s->tone == GV_TONE_NONE)
        return 0;
    s->lut = malloc(n);
    if (!s->lut)
        return gv_fail(err, GV_ENOMEM, "source: out of memory");
    if (s->tone == GV_TONE_RANGE) {
        double sc = 255.0 / (o->range_hi - o->range_lo);
        for (size_t v = 0; v < n; v++)
            s->lut[v] = round_clamp(((double)v - o->range_lo) * sc);
    } else {
        uint32_t m = (1u << info->bits) - 1;
        for (uint32_t v = 0; v < n; v++)
            s->lut[v] = v > m ? 255 : (uint8_t)((v * 255u + (m - 1) / 2) / m);
    }
    return 0;
}

/* Convert w pixels of `chin` channels to s->channels 8-bit channels. */
static void convert(const struct gv_source *s, const void *raw, int chin,
                    uint32_t w, uint8_t *dst)
{
    int chout = s->channels;
    size_t step = (size_t)chin;
    if (s->native) {
        memcpy(dst, raw, (size_t)w * s->px_bytes);
    } else if (s->sample == GV_SAMPLE_U8) {
        const uint8_t *p = raw;
        if (s->lut) {
            for (uint32_t x = 0; x < w; x++, p += step)
                for (int c = 0; c < chout; c++)
                    *dst++ = s->lut[p[c]];
        } else if (chin == chout) {
            memcpy(dst, p, (size_t)w * (size_t)chout);
        } else {
            for (uint32_t x = 0; x < w; x++, p += step)
                for (int c = 0; c < chout; c++)
                    *dst++ = p[c];
        }
    } else if (s->sample == GV_SAMPLE_U16) {
        const uint16_t *p = raw;
        for (uint32_t x = 0; x < w; x++, p += step)
            for (int c = 0; c < chout; c++)
                *dst++ = s->lut[p[c]];
    } else if (s->tone == GV_TONE_SRGB_CLIP) {
        const float *p = raw;
        for (uint32_t x = 0; x < w; x++, p += step)
            for (int c = 0; c < chout; c++)
                *dst++ = srgb_lookup(s->thr, p[c]);
    } else {
        const float *p = raw;
        for (uint32_t x = 0; x < w; x++, p += step)
            for (int c = 0; c < chout; c++)
                *dst++ = round_clamp(((double)p[c] - s->lo) * s->scale);
    }
}

/* ---- the synthetic pattern ---- */

/* A 32-bit integer mixer (the "lowbias32" constants of Chris Wellons'
 * hash-prospector): cheap, and every input bit affects every output bit. */
/* Same shape as hash2 in encode/height_encode.c and id_final in
 * store/store_read.c: deliberately separate, other constants and outputs. */
static inline uint32_t mix32(uint32_t h)
{
    h ^= h >> 16;
    h *= 0x7feb352dU;
    h ^= h >> 15;
    h *= 0x846ca68bU;
    h ^= h >> 16;
    return h;
}

/*
 * The pattern at (x, y), channel c: two smooth gradients (x for channel 0,
 * y for 1, their mix for 2), 64-pixel checker cells that add sharp edges,
 * 8 x 8 blocks of hash noise (+-24, texture at the scale of a codec block)
 * and fine per-pixel noise (-8..7), so that the image neither compresses
 * to nothing nor is pure noise.  Two mix32 calls per pixel serve all
 * channels: hb for the block noise, hf for the fine noise, each channel
 * taking its own bits.  gx, gy are 0..255.
 */
static inline uint8_t synth_value(uint32_t x, uint32_t y, uint32_t c,
                                  uint32_t gx, uint32_t gy, uint32_t hb,
                                  uint32_t hf)
{
    int v = c == 0 ? (int)gx : c == 1 ? (int)gy : (int)(gx + 255 - gy) / 2;
    v += (((x >> 6) ^ (y >> 6)) & 1) ? 32 : -32;
    v += (int)((((hb >> (8 * c)) & 0xff) * 49) >> 8) - 24;
    v += (int)((hf >> (5 * c)) & 15) - 8;
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
}

static void synth_row(const struct gv_source *s, uint32_t y, uint8_t *dst)
{
    /* gx = x * 255 / (width - 1) without a division per pixel: kx is that
     * slope in 24-bit fixed point; x < 2^31 and kx <= 255 * 2^24 keep the
     * product below 2^63. */
    uint32_t gy = (uint32_t)(((uint64_t)y * s->ky) >> 24);
    /* per-row halves of the two hashes (golden-ratio style odd
     * multipliers spread consecutive coordinates) */
    uint32_t rb = mix32((y >> 3) * 0x85EBCA77U + 0x165667B1U);
    uint32_t rf = mix32(y * 0xC2B2AE3DU + 0x27D4EB2FU);
    for (uint32_t x = 0; x < s->width; x++) {
        uint32_t gx = (uint32_t)(((uint64_t)x * s->kx) >> 24);
        uint32_t hb = mix32((x >> 3) * 0x9E3779B1U ^ rb);
        uint32_t hf = mix32(x * 0x9E3779B1U ^ rf);
        for (int c = 0; c < s->channels; c++)
            *dst++ = synth_value(x, y, (uint32_t)c, gx, gy, hb, hf);
    }
}

/* Parse "synth:WxH[:gray]".  Returns 0 or -1. */
static int parse_synth(const char *spec, uint32_t *w, uint32_t *h, int *gray,
                       struct gv_error *err)
{
    const char *p = spec + 6;  /* after "synth:" */
    char *end;
    unsigned long long a, b;
    if (*p < '0' || *p > '9')
        goto bad;
    errno = 0;
    a = strtoull(p, &end, 10);
    if (errno || *end != 'x' || end[1] < '0' || end[1] > '9')
        goto bad;
    b = strtoull(end + 1, &end, 10);
    if (errno)
        goto bad;
    if (*end == '\0')
        *gray = 0;
    else if (strcmp(end, ":gray") == 0)
        *gray = 1;
    else
        goto bad;
    if (a == 0 || b == 0 || a > 0x7fffffffu || b > 0x7fffffffu)
        return gv_fail(err, GV_EINVAL, "source: %s: sizes must be 1 to "
                       "2147483647", spec);
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return 0;
bad:
    return gv_fail(err, GV_EINVAL, "source: %s: expected "
                   "synth:WIDTHxHEIGHT or synth:WIDTHxHEIGHT:gray", spec);
}

/* ---- opening ---- */

/* A procedural input of w x h pixels within max_pixels: 0, or -1 with *err. */
static int check_pixels(const struct gv_source *s, const char *spec,
                        uint32_t w, uint32_t h, struct gv_error *err)
{
    if ((uint64_t)w * h > s->max_pixels)
        return gv_fail(err, GV_ELIMIT, "source: %s: %" PRIu64 " pixels "
                       "exceed the limit of %" PRIu64, spec,
                       (uint64_t)w * h, s->max_pixels);
    return 0;
}

static int open_synth(struct gv_source *s, const char *spec,
                      struct gv_source_info *info, struct gv_error *err)
{
    uint32_t w = 0, h = 0;
    int gray = 0;
    if (parse_synth(spec, &w, &h, &gray, err) != 0)
        return -1;
    if (check_pixels(s, spec, w, h, err) < 0)
        return -1;
    s->kind = KIND_SYNTH;
    s->width = w;
    s->height = h;
    s->channels = gray ? 1 : 3;
    s->kx = w > 1 ? (255ull << 24) / (w - 1) : 0;
    s->ky = h > 1 ? (255ull << 24) / (h - 1) : 0;
    s->tone = GV_TONE_NONE;
    s->px_bytes = (size_t)s->channels;
    info->src_bits = 8;
    info->src_float = 0;
    info->sample_bytes = 1;
    return 0;
}

static int open_synth_height(struct gv_source *s, const char *spec,
                             struct gv_source_info *info, struct gv_error *err)
{
    uint32_t w = 0, h = 0;
    if (gv_synth_height_parse(spec, &w, &h) < 0)
        return gv_fail(err, GV_EINVAL, "source: bad pattern '%s' (want "
                       "synth-height:WIDTHxHEIGHT)", spec);
    if (check_pixels(s, spec, w, h, err) < 0)
        return -1;
    s->kind = KIND_SYNTH_HEIGHT;
    s->width = w;
    s->height = h;
    s->channels = 1;
    s->px_bytes = 2;
    s->tone = GV_TONE_NONE;
    info->src_bits = 16;
    info->src_float = 0;
    info->sample_bytes = 2;
    return 0;
}

static size_t sample_bytes(enum gv_sample smp)
{
    return smp == GV_SAMPLE_U8 ? 1 : smp == GV_SAMPLE_U16 ? 2 : 4;
}

static const char *sample_name(const struct gv_image_info *i)
{
    return i->sample == GV_SAMPLE_F32 ? "float"
           : i->sample == GV_SAMPLE_U16 ? "16-bit" : "8-bit";
}

/* Probe every tile and check the grid.  Fills tiles, row_h, width,
 * height, channels. */
static int probe_tiles(struct gv_source *s, const char *const *inputs,
                       struct gv_error *err)
{
    int cols = s->cols, rows = s->rows;
    uint64_t total_w = 0, total_h = 0;
    for (int i = 0; i < cols * rows; i++) {
        struct tile *t = &s->tiles[i];
        if (strncmp(inputs[i], "synth:", 6) == 0 ||
            strncmp(inputs[i], "synth-height:", 13) == 0)
            return gv_fail(err, GV_EINVAL, "source: %s: a pattern cannot be "
                           "a mosaic tile", inputs[i]);
        t->path = strdup(inputs[i]);
        if (!t->path)
            return gv_fail(err, GV_ENOMEM, "source: out of memory");
        struct gv_image_in *in = gv_image_open_limits(t->path, &s->limits,
                                                      &t->info, err);
        if (!in)
            return -1;
        if (cols * rows == 1)
            s->probed = in;
        else
            gv_image_close(in);
    }
    const struct gv_image_info *f = &s->tiles[0].info;
    int colour = f->channels >= 3;
    for (int r = 0; r < rows; r++) {
        uint32_t x0 = 0;
        for (int c = 0; c < cols; c++) {
            struct tile *t = &s->tiles[r * cols + c];
            const struct tile *top = &s->tiles[c];
            const struct tile *left = &s->tiles[r * cols];
            if (t->info.width != top->info.width)
                return gv_fail(err, GV_EINVAL, "source: mosaic: %s is %" PRIu32
                               " pixels wide but %s above it in grid column "
                               "%d is %" PRIu32, t->path, t->info.width,
                               top->path, c + 1, top->info.width);
            if (t->info.height != left->info.height)
                return gv_fail(err, GV_EINVAL, "source: mosaic: %s is %" PRIu32
                               " pixels high but %s left of it in grid row "
                               "%d is %" PRIu32, t->path, t->info.height,
                               left->path, r + 1, left->info.height);
            if ((t->info.channels >= 3) != colour)
                return gv_fail(err, GV_EINVAL, "source: mosaic: %s is %s but "
                               "%s is %s", t->path,
                               t->info.channels >= 3 ? "colour" : "gray",
                               s->tiles[0].path, colour ? "colour" : "gray");
            if (s->native && t->info.channels != f->channels)
                return gv_fail(err, GV_EINVAL, "source: mosaic: %s has %d "
                               "channels but %s has %d", t->path,
                               t->info.channels, s->tiles[0].path, f->channels);
            if (t->info.sample != f->sample || t->info.bits != f->bits)
                return gv_fail(err, GV_EINVAL, "source: mosaic: %s has %d-bit "
                               "%s samples but %s has %d-bit %s", t->path,
                               t->info.bits, sample_name(&t->info),
                               s->tiles[0].path, f->bits, sample_name(f));
            t->x0 = x0;
            x0 += t->info.width;
        }
        s->row_h[r] = s->tiles[r * cols].info.height;
        total_h += s->row_h[r];
    }
    for (int c = 0; c < cols; c++)
        total_w += s->tiles[c].info.width;
    if (total_w > 0x7fffffffu || total_h > 0x7fffffffu
        || total_w * total_h > s->max_pixels)
        return gv_fail(err, GV_ELIMIT, "source: mosaic of %" PRIu64 "x%"
                       PRIu64 " pixels exceeds the limit of %" PRIu64
                       " pixels", total_w, total_h, s->max_pixels);
    s->width = (uint32_t)total_w;
    s->height = (uint32_t)total_h;
    s->channels = s->native ? f->channels : colour ? 3 : 1;
    return 0;
}

/* Whether convert() copies tile t's samples unchanged: 8-bit samples,
 * no tone rule, no channel dropped. */
static int unchanged(const struct gv_source *s, const struct tile *t)
{
    return s->native || (t->info.sample == GV_SAMPLE_U8 && !s->lut
                         && t->info.channels == s->channels);
}

/* Whether the rows are one image's samples unchanged, not read yet (its
 * probe's handle still here). */
static int raw_eligible(const struct gv_source *s)
{
    return s->kind == KIND_IMAGES && s->probed && s->cols * s->rows == 1
           && !s->native && unchanged(s, &s->tiles[0]);
}

static int open_images(struct gv_source *s, const char *const *inputs,
                       const struct gv_source_opts *opts,
                       struct gv_source_info *info, struct gv_error *err)
{
    size_t n = (size_t)s->cols * (size_t)s->rows;
    s->kind = KIND_IMAGES;
    s->grid_row = -1;
    s->tiles = calloc(n, sizeof *s->tiles);
    s->row_h = calloc((size_t)s->rows, sizeof *s->row_h);
    s->open = calloc((size_t)s->cols, sizeof *s->open);
    if (!s->tiles || !s->row_h || !s->open)
        return gv_fail(err, GV_ENOMEM, "source: out of memory");
    if (probe_tiles(s, inputs, err) != 0)
        return -1;
    const struct gv_image_info *f = &s->tiles[0].info;
    s->sample = f->sample;
    if (!s->native && setup_tone(s, opts, f, err) != 0)
        return -1;
    info->src_bits = f->bits;
    info->src_float = f->sample == GV_SAMPLE_F32;
    info->sample_bytes = s->native ? (int)sample_bytes(f->sample) : 1;
    s->px_bytes = (size_t)s->channels * (size_t)info->sample_bytes;
    return 0;
}

const char *gv_source_meta(const struct gv_source *s)
{
    if (s->kind != KIND_IMAGES || s->cols * s->rows != 1 || !s->probed)
        return NULL;
    return gv_image_meta(s->probed);
}

struct gv_source *gv_source_open(const char *const *inputs, int n,
                                 const struct gv_source_opts *opts,
                                 struct gv_source_info *info,
                                 struct gv_error *err)
{
    struct gv_source *s = calloc(1, sizeof *s);
    struct gv_source_info tmp;
    memset(&tmp, 0, sizeof tmp);
    if (!s) {
        gv_fail(err, GV_ENOMEM, "source: out of memory");
        return NULL;
    }
    s->max_pixels = opts && opts->max_pixels ? opts->max_pixels
                                             : GV_SOURCE_MAX_PIXELS;
    s->limits.max_pixels = s->max_pixels;
    s->limits.max_decoder_bytes = opts ? opts->max_decoder_bytes : 0;
    if (opts)
        s->limits.plane = opts->plane;
    s->cols = 1;
    s->rows = 1;
    s->native = opts && opts->native;
    if (opts && opts->mosaic_cols > 0) {
        if (opts->mosaic_rows <= 0
            || (int64_t)opts->mosaic_cols * opts->mosaic_rows != n) {
            gv_fail(err, GV_EINVAL, "source: a %dx%d mosaic needs %lld "
                    "inputs, got %d", opts->mosaic_cols, opts->mosaic_rows,
                    (long long)opts->mosaic_cols * opts->mosaic_rows, n);
            goto fail;
        }
        s->cols = opts->mosaic_cols;
        s->rows = opts->mosaic_rows;
    } else if (n != 1) {
        gv_fail(err, GV_EINVAL, "source: expected one input, got %d "
                "(use a mosaic for several)", n);
        goto fail;
    }
    if (s->cols * s->rows == 1 && strncmp(inputs[0], "synth:", 6) == 0) {
        if (open_synth(s, inputs[0], &tmp, err) != 0)
            goto fail;
    } else if (s->cols * s->rows == 1 &&
               strncmp(inputs[0], "synth-height:", 13) == 0) {
        if (!s->native) {
            gv_fail(err, GV_EINVAL, "source: %s is a height field: it "
                    "needs a height store (--height)", inputs[0]);
            goto fail;
        }
        if (open_synth_height(s, inputs[0], &tmp, err) != 0)
            goto fail;
    } else if (open_images(s, inputs, opts, &tmp, err) != 0) {
        goto fail;
    }
    tmp.width = s->width;
    tmp.height = s->height;
    tmp.channels = s->channels;
    tmp.tone = s->tone;
    *info = tmp;
    return s;
fail:
    gv_source_free(s);
    return NULL;
}

/* ---- reading ---- */

static void close_grid_row(struct gv_source *s)
{
    for (int c = 0; c < s->cols; c++) {
        gv_image_close(s->open[c]);
        s->open[c] = NULL;
    }
}

/* Open the inputs of grid row r and check they still match the probe. */
static int open_grid_row(struct gv_source *s, int r, struct gv_error *err)
{
    close_grid_row(s);
    s->grid_row = r;
    s->grid_row_left = s->row_h[r];
    if (s->probed) {
        /* A single image, read from the start by the handle of its probe. */
        s->open[0] = s->probed;
        s->probed = NULL;
        return 0;
    }
    for (int c = 0; c < s->cols; c++) {
        const struct tile *t = &s->tiles[r * s->cols + c];
        struct gv_image_info now;
        s->open[c] = gv_image_open_limits(t->path, &s->limits, &now, err);
        if (!s->open[c])
            return -1;
        if (now.width != t->info.width || now.height != t->info.height
            || now.channels != t->info.channels
            || now.sample != t->info.sample || now.bits != t->info.bits)
            return gv_fail(err, GV_ECORRUPT, "source: %s: file changed "
                           "since it was opened", t->path);
    }
    return 0;
}

/* Deliver `n` rows (n <= grid_row_left) of the open grid row. */
static int read_grid_rows(struct gv_source *s, uint32_t n, uint8_t *out,
                          struct gv_error *err)
{
    size_t out_row = (size_t)s->width * s->px_bytes;
    /* One column of samples kept as they are: read straight into out,
     * without the scratch buffer and convert()'s copy. */
    if (s->cols == 1 && unchanged(s, &s->tiles[s->grid_row]))
        return gv_image_read(s->open[0], n, out, err);
    for (int c = 0; c < s->cols; c++) {
        const struct tile *t = &s->tiles[s->grid_row * s->cols + c];
        size_t raw_row = (size_t)t->info.width * (size_t)t->info.channels
                         * sample_bytes(t->info.sample);
        uint32_t chunk = (uint32_t)(CHUNK_BYTES / raw_row);
        if (chunk == 0)
            chunk = 1;
        if (chunk > n)
            chunk = n;
        size_t need = raw_row * chunk;
        if (need > s->scratch_size) {
            unsigned char *p = realloc(s->scratch, need);
            if (!p)
                return gv_fail(err, GV_ENOMEM, "source: %s: out of memory "
                               "for a row buffer of %zu bytes", t->path,
                               need);
            s->scratch = p;
            s->scratch_size = need;
        }
        for (uint32_t done = 0; done < n;) {
            uint32_t k = n - done < chunk ? n - done : chunk;
            if (gv_image_read(s->open[c], k, s->scratch, err) != 0)
                return -1;
            for (uint32_t i = 0; i < k; i++)
                convert(s, s->scratch + raw_row * i, t->info.channels,
                        t->info.width,
                        out + out_row * (done + i)
                            + (size_t)t->x0 * s->px_bytes);
            done += k;
        }
    }
    return 0;
}

int gv_source_read(struct gv_source *s, uint32_t rows, uint8_t *out,
                   struct gv_error *err)
{
    if (s->failed)
        return gv_fail(err, GV_EINVAL, "source: read after an earlier "
                       "error");
    if (rows > s->height - s->next_row)
        return gv_fail(err, GV_EINVAL, "source: read of %" PRIu32 " rows at "
                       "row %" PRIu32 " passes the last row (height %" PRIu32
                       ")", rows, s->next_row, s->height);
    size_t out_row = (size_t)s->width * s->px_bytes;
    if (s->kind == KIND_SYNTH) {
        for (uint32_t i = 0; i < rows; i++)
            synth_row(s, s->next_row + i, out + out_row * i);
        s->next_row += rows;
        return 0;
    }
    if (s->kind == KIND_SYNTH_HEIGHT) {
        for (uint32_t i = 0; i < rows; i++)
            gv_synth_height_row(s->next_row + i, 0, s->width,
                                (uint16_t *)(void *)(out + out_row * i));
        s->next_row += rows;
        return 0;
    }
    while (rows > 0) {
        if (s->grid_row < 0 || s->grid_row_left == 0) {
            if (open_grid_row(s, s->grid_row + 1, err) != 0)
                goto fail;
        }
        uint32_t n = rows < s->grid_row_left ? rows : s->grid_row_left;
        if (read_grid_rows(s, n, out, err) != 0)
            goto fail;
        out += out_row * n;
        rows -= n;
        s->grid_row_left -= n;
        s->next_row += n;
    }
    if (s->next_row == s->height)
        close_grid_row(s);  /* release files as soon as we are done */
    return 0;
fail:
    s->failed = 1;
    close_grid_row(s);
    return -1;
}

int gv_source_reads_raw(const struct gv_source *s)
{
    return raw_eligible(s) && gv_image_reads_raw(s->probed);
}

struct gv_raw_regions *gv_source_raw_regions(struct gv_source *s,
                                             struct gv_error *err)
{
    gv_error_clear(err);
    return raw_eligible(s) ? gv_image_raw_regions(s->probed, err) : NULL;
}

void gv_source_free(struct gv_source *s)
{
    if (!s)
        return;
    if (s->open)
        close_grid_row(s);
    gv_image_close(s->probed);
    if (s->tiles)
        for (int i = 0; i < s->cols * s->rows; i++)
            free(s->tiles[i].path);
    free(s->tiles);
    free(s->row_h);
    free(s->open);
    free(s->scratch);
    free(s->lut);
    free(s);
}
