/*
 * tiff_sniff.h - a look at a TIFF's first directory for the tags that say
 * which reader it wants: a slide scanner's (OpenSlide) or a georeferenced
 * raster's (GDAL), before either library is loaded (imageio_loader.c).
 * Internal to lib/imageio.
 */
#ifndef GV_TIFF_SNIFF_H
#define GV_TIFF_SNIFF_H

#include <stdio.h>

struct gv_tiff_sniff {
    int geo;          /* GeoTIFF tags: ModelPixelScale, ModelTiepoint,
                       * ModelTransformation or GeoKeyDirectory */
    int slide;        /* a scanner's mark: Hamamatsu's NDPI tag, an
                       * ImageDescription of Aperio, Leica or Philips,
                       * Trestle's Software, or an XMP packet (Ventana) */
};

/*
 * Parse the first directory of the TIFF or BigTIFF open in f (either byte
 * order; every offset checked against the file's size, at most 4096
 * entries, at most 1 KB of a string read).  Fills *out (zeros for
 * anything it cannot follow).  Reads a few KB whatever the file claims.
 */
void gv_tiff_sniff(FILE *f, struct gv_tiff_sniff *out);

#endif
