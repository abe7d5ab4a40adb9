/*
 * raster_gdal.c - georeferenced rasters through GDAL (raster_gdal.h).
 *
 * Reading: one strip of the full width, as high as the first band's
 * blocks (a COG's 256 or 512, a striped GeoTIFF's RowsPerStrip, a JPEG
 * 2000's tile), halved until a strip is at most STRIP_BYTES, read with
 * one GDALDatasetRasterIO of the bands delivered, pixel-interleaved, in
 * the type delivered.  Each block is decoded once; GDAL's block cache is
 * set to CACHE_BYTES for the process (its default, 5 % of the memory,
 * would grow with the image), so memory is one strip and the cache,
 * whatever the raster's height.
 *
 * Metadata: the driver, the band count, the affine geotransform (6
 * numbers: x0, dx/dcol, dx/drow, y0, dy/dcol, dy/drow, GDAL's order),
 * the CRS as WKT (when under the metadata's string limit) and its EPSG
 * code where GDAL identifies one, and the first band's no-data value.
 *
 * GDAL is opened with dlopen at the first raster (dl_table.h): it loads
 * some 110 libraries (0.14 s measured).  Its error handler is made quiet
 * (messages come back through CPLGetLastErrorMsg in this reader's
 * errors, never on stderr).
 */
#include <jansson.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <gdal.h>
#include <ogr_srs_api.h>
#include <cpl_error.h>

#include "config.h"
#include "imageio/dl_table.h"
#include "imageio/raster_gdal.h"
#include "imageio/size_limit.h"

#define STRIP_BYTES (64u << 20)   /* as slide_openslide.c */
#define MAX_BANDS 16              /* bands delivered at most */
#define CACHE_BYTES (64 << 20)    /* more than a strip's blocks */
#define WKT_MAX 16384             /* store_meta.h GV_META_MAX_STRING */

#define FN(name) __typeof__(&name) name
static struct {
    FN(GDALAllRegister);
    FN(GDALOpenEx);
    FN(GDALClose);
    FN(GDALGetRasterXSize);
    FN(GDALGetRasterYSize);
    FN(GDALGetRasterCount);
    FN(GDALGetRasterBand);
    FN(GDALGetRasterDataType);
    FN(GDALGetBlockSize);
    FN(GDALDatasetRasterIOEx);
    FN(GDALGetGeoTransform);
    FN(GDALGetProjectionRef);
    FN(GDALGetDatasetDriver);
    FN(GDALGetDriverShortName);
    FN(GDALGetRasterNoDataValue);
    FN(GDALGetMetadataItem);
    FN(GDALSetCacheMax64);
    FN(CPLSetErrorHandler);
    FN(CPLQuietErrorHandler);
    FN(CPLGetLastErrorMsg);
    FN(CPLErrorReset);
    FN(OSRNewSpatialReference);
    FN(OSRDestroySpatialReference);
    FN(OSRAutoIdentifyEPSG);
    FN(OSRGetAuthorityName);
    FN(OSRGetAuthorityCode);
} g;
#undef FN
static int g_ok;
static pthread_once_t g_once = PTHREAD_ONCE_INIT;

static void g_load(void)
{
#define SYM(name) {(void **)&g.name, #name}
    const struct gv_dl_sym syms[] = {
        SYM(GDALAllRegister), SYM(GDALOpenEx), SYM(GDALClose),
        SYM(GDALGetRasterXSize), SYM(GDALGetRasterYSize),
        SYM(GDALGetRasterCount), SYM(GDALGetRasterBand),
        SYM(GDALGetRasterDataType), SYM(GDALGetBlockSize),
        SYM(GDALDatasetRasterIOEx), SYM(GDALGetGeoTransform),
        SYM(GDALGetProjectionRef), SYM(GDALGetDatasetDriver),
        SYM(GDALGetDriverShortName), SYM(GDALGetRasterNoDataValue),
        SYM(GDALGetMetadataItem), SYM(GDALSetCacheMax64),
        SYM(CPLSetErrorHandler), SYM(CPLQuietErrorHandler),
        SYM(CPLGetLastErrorMsg), SYM(CPLErrorReset),
        SYM(OSRNewSpatialReference), SYM(OSRDestroySpatialReference),
        SYM(OSRAutoIdentifyEPSG), SYM(OSRGetAuthorityName),
        SYM(OSRGetAuthorityCode),
    };
#undef SYM
    g_ok = gv_dl_table(GV_GDAL_SONAME, syms, sizeof syms / sizeof syms[0]);
    if (!g_ok)
        return;
    g.CPLSetErrorHandler(g.CPLQuietErrorHandler);
    g.GDALAllRegister();
    g.GDALSetCacheMax64(CACHE_BYTES);
}

struct gv_raster {
    GDALDatasetH ds;
    char *path;
    uint32_t width, height, next_row;
    int bands;                 /* delivered: 1 to MAX_BANDS */
    GDALDataType type;         /* delivered */
    size_t sample_bytes;
    uint32_t strip_h, strip_y, strip_n;
    uint8_t *strip;
    int failed;
    char *meta;
};

/* The drivers a file may be opened with (raster_gdal.h). */
static const char *const drivers[] = {"GTiff", "COG", "JP2OpenJPEG",
                                      "JP2KAK", "JP2ECW", "JPEG2000", NULL};

static char *make_meta(GDALDatasetH ds, int count)
{
    json_t *o = json_object();
    if (!o)
        return NULL;
    GDALDriverH drv = g.GDALGetDatasetDriver(ds);
    if (drv)
        json_object_set_new(o, "geo.driver",
                            json_string(g.GDALGetDriverShortName(drv)));
    json_object_set_new(o, "geo.bands", json_integer(count));
    double gt[6];
    if (g.GDALGetGeoTransform(ds, gt) == CE_None) {
        int finite = 1;
        for (int i = 0; i < 6; i++)
            finite &= isfinite(gt[i]) != 0;
        json_t *a = finite ? json_array() : NULL;
        for (int i = 0; a && i < 6; i++)
            json_array_append_new(a, json_real(gt[i]));
        if (a)
            json_object_set_new(o, "geo.transform", a);
    }
    const char *wkt = g.GDALGetProjectionRef(ds);
    if (wkt && *wkt && strlen(wkt) <= WKT_MAX) {
        json_object_set_new(o, "geo.crs_wkt", json_string(wkt));
        OGRSpatialReferenceH srs = g.OSRNewSpatialReference(wkt);
        if (srs) {
            g.OSRAutoIdentifyEPSG(srs);
            const char *auth = g.OSRGetAuthorityName(srs, NULL);
            const char *code = g.OSRGetAuthorityCode(srs, NULL);
            char *end = NULL;
            long epsg = code ? strtol(code, &end, 10) : 0;
            if (auth && strcmp(auth, "EPSG") == 0 && end && *end == '\0' &&
                epsg > 0 && epsg < 1000000000)
                json_object_set_new(o, "geo.epsg", json_integer(epsg));
            g.OSRDestroySpatialReference(srs);
        }
    }
    int has = 0;
    double nodata = g.GDALGetRasterNoDataValue(g.GDALGetRasterBand(ds, 1), &has);
    if (has && isfinite(nodata))
        json_object_set_new(o, "geo.nodata", json_real(nodata));
    g.CPLErrorReset();
    char *text = json_dumps(o, JSON_COMPACT | JSON_SORT_KEYS |
                                   JSON_REAL_PRECISION(15));
    json_decref(o);
    return text;
}

/* What band type t is delivered as; 0 for a type this reader refuses. */
static GDALDataType delivered(GDALDataType t, enum gv_sample *sample,
                              size_t *bytes)
{
    switch (t) {
    case GDT_Byte:
        *sample = GV_SAMPLE_U8;
        *bytes = 1;
        return GDT_Byte;
    case GDT_UInt16:
        *sample = GV_SAMPLE_U16;
        *bytes = 2;
        return GDT_UInt16;
    case GDT_Int16: case GDT_UInt32: case GDT_Int32: case GDT_Float32:
    case GDT_Float64:
        *sample = GV_SAMPLE_F32;
        *bytes = 4;
        return GDT_Float32;
    default:
        return GDT_Unknown;
    }
}

/* The file's significant bits of a UInt16 band: NBITS when 9..16. */
static int uint16_bits(GDALRasterBandH b)
{
    const char *v = g.GDALGetMetadataItem(b, "NBITS", "IMAGE_STRUCTURE");
    int n = v ? atoi(v) : 16;
    return n >= 9 && n <= 16 ? n : 16;
}

struct gv_raster *gv_raster_open(const char *path,
                                 const struct gv_image_limits *lim,
                                 struct gv_image_info *info,
                                 struct gv_error *err)
{
    gv_error_clear(err);
    pthread_once(&g_once, g_load);
    if (!g_ok)
        return NULL;
    g.CPLErrorReset();
    GDALDatasetH ds = g.GDALOpenEx(path, GDAL_OF_RASTER | GDAL_OF_READONLY |
                                   GDAL_OF_VERBOSE_ERROR, drivers, NULL, NULL);
    if (!ds)
        return NULL;   /* declined: the other readers say why */
    struct gv_raster *r = calloc(1, sizeof *r);
    if (!r || !(r->path = strdup(path))) {
        free(r);
        g.GDALClose(ds);
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        return NULL;
    }
    r->ds = ds;
    int w = g.GDALGetRasterXSize(ds), h = g.GDALGetRasterYSize(ds);
    int count = g.GDALGetRasterCount(ds);
    if (w <= 0 || h <= 0 || count <= 0) {
        gv_fail(err, GV_EFORMAT, "imageio: %s: GDAL: no raster bands", path);
        goto fail;
    }
    if (gv_image_size_check(path, (uint64_t)w, (uint64_t)h, lim->max_pixels,
                            err) < 0)
        goto fail;
    r->width = (uint32_t)w;
    r->height = (uint32_t)h;
    /* Every band, up to MAX_BANDS: an 8-bit image keeps the first three
     * (source.h), a sample store all of them (at most 8, so a raster of
     * more than MAX_BANDS is refused there, not cut here). */
    r->bands = count >= MAX_BANDS ? MAX_BANDS : count;
    GDALRasterBandH b1 = g.GDALGetRasterBand(ds, 1);
    GDALDataType t1 = g.GDALGetRasterDataType(b1);
    for (int i = 2; i <= r->bands; i++)
        if (g.GDALGetRasterDataType(g.GDALGetRasterBand(ds, i)) != t1) {
            gv_fail(err, GV_EFORMAT, "imageio: %s: GDAL: bands of different "
                    "types", path);
            goto fail;
        }
    enum gv_sample sample = GV_SAMPLE_U8;
    r->type = delivered(t1, &sample, &r->sample_bytes);
    if (r->type == GDT_Unknown) {
        gv_fail(err, GV_EFORMAT, "imageio: %s: GDAL: complex or unknown band "
                "type", path);
        goto fail;
    }
    int bx = 0, by = 0;
    g.GDALGetBlockSize(b1, &bx, &by);
    r->strip_h = by >= 1 && by <= 4096 ? (uint32_t)by : 256;
    size_t px = (size_t)r->bands * r->sample_bytes;
    while (r->strip_h > 1 && (uint64_t)r->width * r->strip_h * px > STRIP_BYTES)
        r->strip_h /= 2;
    if ((uint64_t)r->width * r->strip_h * px > gv_image_decoder_limit(lim)) {
        gv_fail(err, GV_ELIMIT, "imageio: %s: a strip of %u rows exceeds the "
                "decoder memory limit (--max-decoder-memory)", path, r->strip_h);
        goto fail;
    }
    r->meta = make_meta(ds, count);
    if (!r->meta) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        goto fail;
    }
    memset(info, 0, sizeof *info);
    info->width = r->width;
    info->height = r->height;
    info->channels = r->bands;
    info->sample = sample;
    info->bits = sample == GV_SAMPLE_U8 ? 8 : sample == GV_SAMPLE_U16 ?
                 uint16_bits(b1) : 32;
    snprintf(info->format, sizeof info->format, "gdal-%s",
             g.GDALGetDriverShortName(g.GDALGetDatasetDriver(ds)));
    return r;
fail:
    gv_raster_close(r);
    return NULL;
}

/* Read the strip that starts at row y. */
static int fill(struct gv_raster *r, uint32_t y, struct gv_error *err)
{
    size_t px = (size_t)r->bands * r->sample_bytes;
    if (!r->strip) {
        r->strip = malloc((size_t)r->width * r->strip_h * px);
        if (!r->strip)
            return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory for a "
                           "strip of %u rows", r->path, r->strip_h);
    }
    uint32_t n = r->height - y < r->strip_h ? r->height - y : r->strip_h;
    int map[MAX_BANDS];
    for (int i = 0; i < MAX_BANDS; i++)
        map[i] = i + 1;
    g.CPLErrorReset();
    if (g.GDALDatasetRasterIOEx(r->ds, GF_Read, 0, (int)y, (int)r->width,
                                (int)n, r->strip, (int)r->width, (int)n,
                                r->type, r->bands, map, (GSpacing)px,
                                (GSpacing)(r->width * px),
                                (GSpacing)r->sample_bytes, NULL) != CE_None)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: GDAL: %s", r->path,
                       g.CPLGetLastErrorMsg());
    r->strip_y = y;
    r->strip_n = n;
    return 0;
}

int gv_raster_read(struct gv_raster *r, uint32_t rows, void *out,
                   struct gv_error *err)
{
    if (gv_image_read_check(r->path, r->failed, rows, r->next_row, r->height,
                            err) < 0)
        return -1;
    const size_t row_bytes = (size_t)r->width * r->bands * r->sample_bytes;
    uint8_t *dst = out;
    while (rows > 0) {
        uint32_t y = r->next_row;
        if (!r->strip || y < r->strip_y || y >= r->strip_y + r->strip_n) {
            if (fill(r, y, err) < 0) {
                r->failed = 1;
                return -1;
            }
        }
        uint32_t have = r->strip_y + r->strip_n - y;
        uint32_t k = rows < have ? rows : have;
        memcpy(dst, r->strip + (size_t)(y - r->strip_y) * row_bytes,
               (size_t)k * row_bytes);
        dst += (size_t)k * row_bytes;
        r->next_row += k;
        rows -= k;
    }
    return 0;
}

const char *gv_raster_meta(const struct gv_raster *r)
{
    return r->meta;
}

void gv_raster_close(struct gv_raster *r)
{
    if (!r)
        return;
    if (r->ds)
        g.GDALClose(r->ds);
    free(r->strip);
    free(r->meta);
    free(r->path);
    free(r);
}
