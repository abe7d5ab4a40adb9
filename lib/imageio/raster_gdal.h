/*
 * raster_gdal.h - georeferenced rasters through GDAL: GeoTIFF and
 * Cloud-Optimized GeoTIFF, JPEG 2000; 8- and 16-bit, signed and float
 * bands, one to many; read in strips of the file's blocks, with the
 * georeference.  Used by imageio_loader.c behind gv_image_open /
 * gv_image_read / gv_image_close; internal to lib/imageio.  Built when
 * configure found GDAL (GV_HAVE_GDAL).
 */
#ifndef GV_RASTER_GDAL_H
#define GV_RASTER_GDAL_H

#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

struct gv_raster;

/*
 * Open `path` with GDAL's GeoTIFF (GTiff, COG) or JPEG 2000 driver (no
 * other: GDAL's other drivers open other files by name, a VRT any file).
 * Delivers bands 1 to 3 (one or two bands: the first one or two; three or
 * more: the first three) as U8 for Byte bands, U16 for UInt16 ones (bits:
 * the file's NBITS when 9 to 16, else 16), F32 for any other real type.
 * Returns the reader; NULL with err->code GV_OK when GDAL cannot be
 * loaded or declines the file; NULL with *err filled when it is refused
 * (GV_ELIMIT past lim, GV_EFORMAT for complex or mixed band types).
 * err must not be NULL.
 */
struct gv_raster *gv_raster_open(const char *path,
                                 const struct gv_image_limits *lim,
                                 struct gv_image_info *info,
                                 struct gv_error *err);

/* The next `rows` rows, as gv_image_read. */
int gv_raster_read(struct gv_raster *r, uint32_t rows, void *out,
                   struct gv_error *err);

/* The georeference as store metadata JSON (store/store_meta.h:
 * geo.driver, geo.bands, geo.transform, geo.crs_wkt, geo.epsg,
 * geo.nodata, each where the file has it), valid until close; never NULL
 * for an open raster. */
const char *gv_raster_meta(const struct gv_raster *r);

/* Close.  NULL does nothing. */
void gv_raster_close(struct gv_raster *r);

#endif
