/*
 * native_tiff.c - TIFF and BigTIFF input through libtiff, without the
 * OpenImageIO module.
 *
 * Why: as for native_jpeg.c, loading the module's some 260 libraries
 * costs about 0.2 s a process, and on a gigapixel tiled BigTIFF the
 * module's read (OIIO's read_tiles, converting through its own buffers)
 * took 5.6 s of a 19 s `gigaview encode`.  OpenImageIO 2.4's TIFF reader
 * is a layer over the same libtiff; for the variants accepted here it
 * hands on libtiff's decoded samples unchanged, so this file delivers the
 * module's bytes by decoding with the same library (tests/
 * test_native_read.c compares them on every TIFF in tests/data).
 *
 * Accepted (everything else is declined at open, before a pixel is read,
 * and the module reads it as before): the first directory of a classic
 * TIFF or a BigTIFF, either byte order; unsigned integer samples of 8 or
 * 16 bits (delivered as U8 or U16, 16-bit ones in host order, as libtiff
 * gives them and the module delivers them: bits 8 or 16, never narrowed);
 * contiguous (chunky) samples; grey (MINISBLACK, 1 sample) or RGB (3
 * samples), no extra samples; compression none, LZW, deflate (both tag
 * values) or PackBits, with predictor none or horizontal; fill order
 * MSB-to-LSB; no XPosition/YPosition (the module would shift its data
 * window by them); one plane deep; tiled or in strips.  Declined besides:
 * palette, MINISWHITE, YCbCr, CMYK, alpha, float, signed and odd-depth
 * samples, JPEG-in-TIFF and every other codec, and any file on which
 * libtiff reports an error while opening, so that the module's own
 * message and code describe damaged headers.
 *
 * Memory: a tiled file keeps one row of tiles, each decoded straight
 * into its own slot (TIFFReadEncodedTile) of a buffer of tiles-across
 * tiles, from which rows are copied out once; a file in strips keeps one
 * strip (TIFFReadEncodedStrip).  Both are allocated at the first read,
 * and a file whose tile or strip would need much more than the rows it
 * covers (a hostile header claiming huge tiles) is declined at open,
 * before anything is allocated.  Never the whole image.  An uncompressed
 * file of 8-bit samples keeps neither: its rows are read where they lie
 * (raw_regions.c, the same bytes), so no strip's size matters, and the
 * loader's decoder memory check (tiff_limits.c) does not decline it.  The strip or
 * row of tiles is also held to the decoder memory limit: after this
 * open, imageio_loader.c declines a file whose strip passes it to the
 * module and refuses one whose row of tiles does (tiff_limits.c).
 *
 * libtiff is opened with dlopen at the first TIFF a process reads, not
 * linked: it brings libLerc and with it libstdc++, whose loading added
 * about 2 ms to the start of every gigaview process (`gigaview --help`
 * 15.7 against 13.5 ms, best of 20).  If it cannot be loaded, every TIFF
 * is declined to the module.
 *
 * Errors: libtiff's messages go to this reader's own handlers (libtiff
 * 4.5's per-file TIFFOpenExt handlers), never to stderr; any error while
 * reading fails that read with GV_ECORRUPT, "imageio: PATH: MESSAGE", and
 * every later read, as in the module.  Warnings are ignored, as there.
 */
#include <dlfcn.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <tiffio.h>

#include "imageio/native_file.h"
#include "imageio/native_tiff.h"
#include "imageio/raw_regions.h"
#include "imageio/size_limit.h"

/* libtiff's functions, from dlopen (see the top of the file). */
#define LIBTIFF_SONAME "libtiff.so.6"   /* libtiff 4.5 and later */
static struct {
    TIFFOpenOptions *(*OpenOptionsAlloc)(void);
    void (*OpenOptionsFree)(TIFFOpenOptions *);
    void (*OpenOptionsSetErrorHandlerExtR)(TIFFOpenOptions *,
                                           TIFFErrorHandlerExtR, void *);
    void (*OpenOptionsSetWarningHandlerExtR)(TIFFOpenOptions *,
                                             TIFFErrorHandlerExtR, void *);
    TIFF *(*FdOpenExt)(int, const char *, const char *, TIFFOpenOptions *);
    void (*Close)(TIFF *);
    int (*GetField)(TIFF *, uint32_t, ...);
    int (*GetFieldDefaulted)(TIFF *, uint32_t, ...);
    int (*IsTiled)(TIFF *);
    uint64_t (*TileSize64)(TIFF *);
    uint64_t (*StripSize64)(TIFF *);
    uint32_t (*ComputeTile)(TIFF *, uint32_t, uint32_t, uint32_t, uint16_t);
    uint32_t (*ComputeStrip)(TIFF *, uint32_t, uint16_t);
    tmsize_t (*ReadEncodedTile)(TIFF *, uint32_t, void *, tmsize_t);
    tmsize_t (*ReadEncodedStrip)(TIFF *, uint32_t, void *, tmsize_t);
    uint32_t (*NumberOfTiles)(TIFF *);
    uint32_t (*NumberOfStrips)(TIFF *);
    int (*SetDirectory)(TIFF *, tdir_t);
} lt;
static int lt_ok;
static pthread_once_t lt_once = PTHREAD_ONCE_INIT;

static void lt_load(void)
{
    void *h = dlopen(LIBTIFF_SONAME, RTLD_NOW | RTLD_LOCAL);
    if (!h)
        return;
    struct {
        void **slot;
        const char *name;
    } const f[] = {
        /* One libtiff symbol a row: the same shape on purpose (a table). */
        {(void **)&lt.OpenOptionsAlloc, "TIFFOpenOptionsAlloc"},
        {(void **)&lt.OpenOptionsFree, "TIFFOpenOptionsFree"},
        {(void **)&lt.OpenOptionsSetErrorHandlerExtR,
         "TIFFOpenOptionsSetErrorHandlerExtR"},
        {(void **)&lt.OpenOptionsSetWarningHandlerExtR,
         "TIFFOpenOptionsSetWarningHandlerExtR"},
        {(void **)&lt.FdOpenExt, "TIFFFdOpenExt"},
        {(void **)&lt.Close, "TIFFClose"},
        {(void **)&lt.GetField, "TIFFGetField"},
        {(void **)&lt.GetFieldDefaulted, "TIFFGetFieldDefaulted"},
        {(void **)&lt.IsTiled, "TIFFIsTiled"},
        {(void **)&lt.TileSize64, "TIFFTileSize64"},
        {(void **)&lt.StripSize64, "TIFFStripSize64"},
        {(void **)&lt.ComputeTile, "TIFFComputeTile"},
        {(void **)&lt.ComputeStrip, "TIFFComputeStrip"},
        {(void **)&lt.ReadEncodedTile, "TIFFReadEncodedTile"},
        {(void **)&lt.ReadEncodedStrip, "TIFFReadEncodedStrip"},
        {(void **)&lt.NumberOfTiles, "TIFFNumberOfTiles"},
        {(void **)&lt.NumberOfStrips, "TIFFNumberOfStrips"},
        {(void **)&lt.SetDirectory, "TIFFSetDirectory"},
    };
    for (size_t i = 0; i < sizeof f / sizeof f[0]; i++) {
        /* POSIX: a function pointer may be stored through void *. */
        *f[i].slot = dlsym(h, f[i].name);
        if (!*f[i].slot) {
            dlclose(h);
            return;
        }
    }
    lt_ok = 1;   /* h stays open for the life of the process */
}

struct gv_native_tiff {
    TIFF *tif;
    int fd;                        /* until libtiff owns it */
    char *path;
    uint32_t width, height, next_row;
    size_t pixel_bytes, row_bytes;
    int bits;
    /* tiled: one row of tiles, tile k at buf + k * tile_bytes;
     * striped: one strip of full rows */
    int tiled;
    uint32_t tile_w, tile_h;       /* tiled: tile size; striped: 0, rows per strip */
    uint32_t across;               /* tiles across (tiled) */
    size_t tile_bytes;             /* one tile, or one strip */
    uint8_t *buf;
    size_t buf_size;
    uint32_t buf_first, buf_rows;  /* rows held in buf */
    int swap16;                    /* test mode */
    struct gv_raw_regions *raw;    /* uncompressed 8-bit: rows read where
                                    * they lie, no strip or tile buffer */
    int broken;                    /* a read failed: every later one fails */
    char *desc;                    /* the directory's ImageDescription */
    char msg[256];                 /* the first error's text */
};

/* Same shape as the test mode of imageio/native_png.c: deliberately separate,
 * each format has its own test switch. */
static int test_swap16;

void gv_native_tiff_test_mode(int swap16)
{
    test_swap16 = swap16;
}

int gv_native_tiff_sniff(const uint8_t *head, size_t n)
{
    if (n < 4)
        return 0;
    return (head[0] == 'I' && head[1] == 'I' && (head[2] == 42 || head[2] == 43)
            && head[3] == 0)
           || (head[0] == 'M' && head[1] == 'M' && head[2] == 0
               && (head[3] == 42 || head[3] == 43));
}

/* libtiff's per-file handlers: the first error is kept, nothing printed;
 * returning 1 keeps the process-wide handlers (stderr) out of it. */
static int on_error(TIFF *tif, void *user, const char *module,
                    const char *fmt, va_list ap)
{
    (void)tif;
    (void)module;
    struct gv_native_tiff *t = user;
    if (t && !t->msg[0])
        vsnprintf(t->msg, sizeof t->msg, fmt, ap);
    return 1;
}

static int on_warning(TIFF *tif, void *user, const char *module,
                      const char *fmt, va_list ap)
{
    (void)tif;
    (void)user;
    (void)module;
    (void)fmt;
    (void)ap;
    return 1;
}

void gv_native_tiff_close(struct gv_native_tiff *t)
{
    if (!t)
        return;
    free(t->desc);
    if (t->tif)
        lt.Close(t->tif);   /* closes fd */
    else if (t->fd >= 0)
        close(t->fd);
    gv_raw_regions_free(t->raw);
    free(t->buf);
    free(t->path);
    free(t);
}

/* Whether the open directory is a variant read exactly as the module
 * reads it (see the top of the file); fills the sample layout. */
static int accepted(struct gv_native_tiff *t)
{
    TIFF *tif = t->tif;
    uint16_t bps = 0, spp = 0, fmt = 0, planar = 0, photo = 0, comp = 0;
    uint16_t fill = 0, nextra = 0, *extra = NULL;
    uint32_t depth = 1;
    float pos;
    if (!lt.GetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bps)
        || !lt.GetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &spp)
        || !lt.GetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &fmt)
        || !lt.GetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &planar)
        || !lt.GetField(tif, TIFFTAG_PHOTOMETRIC, &photo)
        || !lt.GetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &comp)
        || !lt.GetFieldDefaulted(tif, TIFFTAG_FILLORDER, &fill))
        return 0;
    if ((bps != 8 && bps != 16) || fmt != SAMPLEFORMAT_UINT
        || planar != PLANARCONFIG_CONTIG || fill != FILLORDER_MSB2LSB)
        return 0;
    if (!((photo == PHOTOMETRIC_MINISBLACK && spp == 1)
          || (photo == PHOTOMETRIC_RGB && spp == 3)))
        return 0;
    if (lt.GetField(tif, TIFFTAG_EXTRASAMPLES, &nextra, &extra) && nextra)
        return 0;
    if (lt.GetField(tif, TIFFTAG_IMAGEDEPTH, &depth) && depth != 1)
        return 0;
    if (lt.GetField(tif, TIFFTAG_XPOSITION, &pos)
        || lt.GetField(tif, TIFFTAG_YPOSITION, &pos))
        return 0;
    switch (comp) {
    case COMPRESSION_NONE:
    case COMPRESSION_PACKBITS:
        break;
    case COMPRESSION_LZW:
    case COMPRESSION_ADOBE_DEFLATE:
    case COMPRESSION_DEFLATE: {
        uint16_t pred = PREDICTOR_NONE;
        if (lt.GetField(tif, TIFFTAG_PREDICTOR, &pred)
            && pred != PREDICTOR_NONE && pred != PREDICTOR_HORIZONTAL)
            return 0;
        break;
    }
    default:
        return 0;
    }
    t->bits = bps;
    t->pixel_bytes = (size_t)spp * (bps / 8);
    return 1;
}

/* The tile or strip layout, checked against the rows it covers: 0, or
 * -1 to decline. */
static int layout(struct gv_native_tiff *t)
{
    TIFF *tif = t->tif;
    uint32_t cover;   /* rows one tile row or strip holds */
    uint64_t need, rows_bytes;
    if (lt.IsTiled(tif)) {
        uint32_t tw = 0, th = 0;
        if (!lt.GetField(tif, TIFFTAG_TILEWIDTH, &tw)
            || !lt.GetField(tif, TIFFTAG_TILELENGTH, &th) || tw == 0
            || th == 0 || tw > 65536 || th > 65536)
            return -1;
        uint64_t tile = (uint64_t)tw * th * t->pixel_bytes;
        if (lt.TileSize64(tif) != tile)
            return -1;
        t->tiled = 1;
        t->tile_w = tw;
        t->tile_h = th;
        t->across = (uint32_t)(((uint64_t)t->width + tw - 1) / tw);
        t->tile_bytes = (size_t)tile;
        need = tile * t->across;
        cover = th < t->height ? th : t->height;
        rows_bytes = (uint64_t)t->row_bytes * cover;
    } else {
        uint32_t rps = 0;
        if (!lt.GetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rps)
            || rps == 0)
            return -1;
        cover = rps < t->height ? rps : t->height;
        need = (uint64_t)t->row_bytes * cover;
        if (lt.StripSize64(tif) != need)
            return -1;
        t->tile_h = rps;
        t->tile_bytes = (size_t)need;
        rows_bytes = need;
    }
    /* At most 64 MiB, or twice the rows it covers (tiles overhanging the
     * image's right or bottom edge hold padding). */
    if ((need > ((uint64_t)64 << 20) && need > 2 * rows_bytes)
        || need > SIZE_MAX / 4)
        return -1;
    t->buf_size = (size_t)need;
    return 0;
}

/* Same shape as gv_native_jpeg_open in native_jpeg.c: deliberately separate,
 * each opens its own library's reader. */
struct gv_native_tiff *gv_native_tiff_open(const char *path,
                                           uint64_t max_pixels,
                                           struct gv_image_info *info,
                                           struct gv_error *err)
{
    return gv_native_tiff_open_dir(path, 0, max_pixels, info, err);
}

const char *gv_native_tiff_description(const struct gv_native_tiff *t)
{
    return t->desc;
}

struct gv_native_tiff *gv_native_tiff_open_dir(const char *path, uint32_t dir,
                                               uint64_t max_pixels,
                                               struct gv_image_info *info,
                                               struct gv_error *err)
{
    gv_error_clear(err);
    struct gv_native_tiff *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;   /* declined: the module reports what it can */
    t->fd = -1;
    t->path = strdup(path);
    FILE *f = gv_native_open_regular(path);
    if (f) {
        t->fd = dup(fileno(f));
        fclose(f);
    }
    pthread_once(&lt_once, lt_load);
    if (!t->path || t->fd < 0 || !lt_ok)
        goto decline;
    uint8_t head[4];
    if (pread(t->fd, head, sizeof head, 0) != (ssize_t)sizeof head
        || !gv_native_tiff_sniff(head, sizeof head))
        goto decline;
    TIFFOpenOptions *opts = lt.OpenOptionsAlloc();
    if (!opts)
        goto decline;
    lt.OpenOptionsSetErrorHandlerExtR(opts, on_error, t);
    lt.OpenOptionsSetWarningHandlerExtR(opts, on_warning, t);
    /* "m": read(), not mmap: a file cut short while being read must give
     * an error, not SIGBUS. */
    t->tif = lt.FdOpenExt(t->fd, path, "rm", opts);
    lt.OpenOptionsFree(opts);
    if (!t->tif || t->msg[0] || (dir && !lt.SetDirectory(t->tif, dir)) || t->msg[0])
        goto decline;
    uint32_t w = 0, h = 0;
    if (!lt.GetField(t->tif, TIFFTAG_IMAGEWIDTH, &w)
        || !lt.GetField(t->tif, TIFFTAG_IMAGELENGTH, &h) || w == 0 || h == 0
        || !accepted(t))
        goto decline;
    if (gv_image_size_check(path, w, h, max_pixels, err) < 0) {
        gv_native_tiff_close(t);
        return NULL;
    }
    t->width = w;
    t->height = h;
    t->row_bytes = (size_t)w * t->pixel_bytes;   /* < 2^31 * 6 */
    char *desc = NULL;
    if (lt.GetField(t->tif, TIFFTAG_IMAGEDESCRIPTION, &desc) && desc &&
        !(t->desc = strdup(desc)))
        goto decline;
    if (layout(t) != 0 || t->msg[0])
        goto decline;
    t->swap16 = test_swap16 && t->bits == 16;
    /* An uncompressed file of 8-bit samples is read where its rows lie
     * (raw_regions.h): the same bytes as libtiff's, without a buffer of
     * a strip or a row of tiles (a strip can be the whole image). */
    struct gv_error re = {0};
    t->raw = gv_native_tiff_regions(t, &re);
    if (!t->raw && re.code != GV_OK)
        goto decline;
    memset(info, 0, sizeof *info);
    info->width = w;
    info->height = h;
    info->channels = (int)(t->pixel_bytes / (t->bits / 8));
    info->bits = t->bits;
    info->sample = t->bits == 16 ? GV_SAMPLE_U16 : GV_SAMPLE_U8;
    snprintf(info->format, sizeof info->format, "tiff");
    return t;

decline:
    gv_native_tiff_close(t);
    return NULL;
}

static int fail_read(struct gv_native_tiff *t, struct gv_error *err,
                     const char *what)
{
    t->broken = 1;
    return gv_fail(err, GV_ECORRUPT, "imageio: %s: %s", t->path,
                   t->msg[0] ? t->msg : what);
}

/* Decode the row of tiles, or the strip, that holds row `row` into buf. */
static int load(struct gv_native_tiff *t, uint32_t row, struct gv_error *err)
{
    if (!t->buf) {
        t->buf = malloc(t->buf_size);
        if (!t->buf) {
            t->broken = 1;
            return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory",
                           t->path);
        }
    }
    uint32_t first = row - row % t->tile_h;
    uint32_t n = t->height - first < t->tile_h ? t->height - first
                                               : t->tile_h;
    if (t->tiled) {
        for (uint32_t c = 0; c < t->across; c++) {
            uint32_t tile = lt.ComputeTile(t->tif, c * t->tile_w, first, 0, 0);
            tmsize_t got = lt.ReadEncodedTile(t->tif, tile,
                                               t->buf + (size_t)c * t->tile_bytes,
                                               (tmsize_t)t->tile_bytes);
            if (got != (tmsize_t)t->tile_bytes || t->msg[0])
                return fail_read(t, err, "tile read failed");
        }
    } else {
        uint32_t strip = lt.ComputeStrip(t->tif, first, 0);
        tmsize_t want = (tmsize_t)((size_t)n * t->row_bytes);
        tmsize_t got = lt.ReadEncodedStrip(t->tif, strip, t->buf, want);
        if (got != want || t->msg[0])
            return fail_read(t, err, "strip read failed");
    }
    t->buf_first = first;
    t->buf_rows = n;
    return 0;
}

static void swap16(uint8_t *p, size_t n)
{
    for (size_t i = 0; i + 1 < n; i += 2) {
        uint8_t b = p[i];
        p[i] = p[i + 1];
        p[i + 1] = b;
    }
}

int gv_native_tiff_read(struct gv_native_tiff *t, uint32_t rows, void *out,
                        struct gv_error *err)
{
    if (gv_image_read_check(t->path, t->broken, rows, t->next_row,
                            t->height, err) < 0)
        return -1;
    uint8_t *dst = out;
    if (t->raw && rows > 0) {
        if (gv_raw_regions_read(t->raw, 0, t->next_row, t->width, rows, dst,
                                t->row_bytes, err) < 0) {
            t->broken = 1;
            return -1;
        }
        t->next_row += rows;
        return 0;
    }
    /* Same shape as the row loop in imageio.cpp: deliberately separate, that
     * one is in the OpenImageIO module, a binary of its own. */
    while (rows > 0) {
        uint32_t r = t->next_row;
        if (t->buf_rows == 0 || r < t->buf_first
            || r >= t->buf_first + t->buf_rows) {
            if (load(t, r, err) != 0)
                return -1;
        }
        uint32_t avail = t->buf_first + t->buf_rows - r;
        uint32_t take = rows < avail ? rows : avail;
        for (uint32_t k = 0; k < take; k++) {
            size_t y = r + k - t->buf_first;
            if (t->tiled) {
                size_t tile_row = (size_t)t->tile_w * t->pixel_bytes;
                for (uint32_t c = 0; c < t->across; c++) {
                    size_t x = (size_t)c * tile_row;
                    size_t len = t->row_bytes - x < tile_row
                                     ? t->row_bytes - x : tile_row;
                    memcpy(dst + x, t->buf + (size_t)c * t->tile_bytes
                                        + y * tile_row, len);
                }
            } else {
                memcpy(dst, t->buf + y * t->row_bytes, t->row_bytes);
            }
            if (t->swap16)
                swap16(dst, t->row_bytes);
            dst += t->row_bytes;
        }
        t->next_row += take;
        rows -= take;
    }
    return 0;
}

int gv_native_tiff_reads_raw(const struct gv_native_tiff *t)
{
    return t->raw != NULL;
}

struct gv_raw_regions *gv_native_tiff_regions(struct gv_native_tiff *t,
                                              struct gv_error *err)
{
    gv_error_clear(err);
    TIFF *tif = t->tif;
    uint16_t comp = 0;
    uint64_t *offsets = NULL, *counts = NULL;
    const char *v = getenv("GIGAVIEW_RAW_REGIONS");   /* tests: libtiff */
    if ((v && !strcmp(v, "0")) || t->broken || t->swap16 || t->bits != 8
        || !lt.GetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &comp)
        || comp != COMPRESSION_NONE)
        return NULL;
    struct gv_raw_layout l = {
        .width = t->width,
        .height = t->height,
        .pixel_bytes = (int)t->pixel_bytes,
        .block_w = t->tiled ? t->tile_w : t->width,
        .block_h = t->tile_h,
    };
    l.across = (t->width - 1) / l.block_w + 1;
    l.down = (t->height - 1) / l.block_h + 1;
    l.short_last_row = !t->tiled;
    const uint32_t blocks = t->tiled ? lt.NumberOfTiles(tif)
                                     : lt.NumberOfStrips(tif);
    if ((uint64_t)l.across * l.down != blocks
        || !lt.GetField(tif, t->tiled ? TIFFTAG_TILEOFFSETS
                                      : TIFFTAG_STRIPOFFSETS, &offsets)
        || !lt.GetField(tif, t->tiled ? TIFFTAG_TILEBYTECOUNTS
                                      : TIFFTAG_STRIPBYTECOUNTS, &counts)
        || !offsets || !counts || t->msg[0])
        return NULL;
    l.offsets = offsets;
    l.byte_counts = counts;
    return gv_raw_regions_new(t->fd, t->path, &l, err);
}
