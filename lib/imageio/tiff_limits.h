/*
 * tiff_limits.h - a TIFF's decoder memory, from its first directory,
 * against the limit, before native_tiff.c or OpenImageIO opens the file
 * (tiff_limits.c says what is counted and why).  Used by
 * imageio_loader.c; internal to lib/imageio.
 */
#ifndef GV_TIFF_LIMITS_H
#define GV_TIFF_LIMITS_H

#include "base/error.h"
#include "imageio/imageio.h"

/* How the reader to open the file reads a TIFF in strips: native_tiff.c
 * decodes a whole strip at a time (TIFFReadEncodedStrip), OpenImageIO's
 * scanline reader a row at a time (TIFFReadScanline), except through
 * libtiff's RGBA interface, which takes a strip at a time. */
enum gv_tiff_reader { GV_TIFF_READ_STRIPS, GV_TIFF_READ_ROWS };

/*
 * Check the TIFF or BigTIFF at `path` against lim: its size against
 * lim->max_pixels (size_limit.h's words), then the memory its decoder
 * will hold - one row of tiles decoded, or one strip where `reader`
 * decodes strips whole, the whole image as RGBA where OpenImageIO reads
 * it through libtiff's RGBA interface (and one strip besides), and
 * the largest coefficient arrays libjpeg requests for a progressive or
 * multi-scan JPEG strip or tile - against lim->max_decoder_bytes.
 * Returns -1 with *err filled (GV_ELIMIT, naming --max-decoder-memory
 * and the size needed), or 0: within the limits, or a file this parser
 * cannot follow (not a TIFF, a damaged directory), which the reader
 * then refuses in its own words.  Reads the header, the first
 * directory and the headers of JPEG strips or tiles only, with a few KB
 * of buffers, whatever the file claims.  err must not be NULL.
 */
int gv_tiff_limits_check(const char *path, const struct gv_image_limits *lim,
                         enum gv_tiff_reader reader, struct gv_error *err);

#endif
