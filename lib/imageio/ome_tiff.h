/*
 * ome_tiff.h - OME-TIFF files whose channels are pages: the layout of
 * fluorescence microscopes' exports (Bio-Formats, tifffile), read through
 * native_tiff.c one directory a channel and delivered as one image of C
 * interleaved channels, with the channels' names and colours as metadata.
 *
 * Taken: a first directory whose ImageDescription is OME-XML whose first
 * Pixels element says SizeC = C (2 .. 8), SizeZ = SizeT = 1, and whose
 * Channel elements are one sample each; directories 0 .. C-1 then hold
 * channels 0 .. C-1 (OME-TIFF's default TiffData order when Z and T are
 * 1), each one grey channel of the same size and depth that native_tiff.c
 * accepts.  Anything else is declined, and the file is read as before
 * (its first page).  Metadata (store_meta.h): "ome.channels", the
 * channels' names joined by ';' (a ';' in a name becomes ','), when every
 * channel has one; "display.colours" (render/samples_region.h), from the
 * channels' Color attributes (signed RGBA integers), when every channel
 * has one.  Sub-resolutions (SubIFDs), Z stacks and time series are not
 * read.
 */
#ifndef GV_OME_TIFF_H
#define GV_OME_TIFF_H

#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"
#include "imageio/native_tiff.h"

struct gv_ome;

/*
 * Take `first` (directory 0 of `path`, opened by gv_native_tiff_open,
 * *info its image) when it is such an OME-TIFF: opens the other channels'
 * directories and returns the reader with *info of C channels, `first`
 * now its own.  NULL otherwise, `first` and *info untouched (the caller
 * keeps reading the first page).
 */
struct gv_ome *gv_ome_take(const char *path, struct gv_native_tiff *first,
                           uint64_t max_pixels, struct gv_image_info *info);

/* The next `rows` rows, C interleaved channels a pixel.  0, or -1 with
 * *err (a channel's read error). */
int gv_ome_read(struct gv_ome *o, uint32_t rows, void *out, struct gv_error *err);

/* The metadata JSON described above, or NULL. */
const char *gv_ome_meta(const struct gv_ome *o);

void gv_ome_close(struct gv_ome *o);

#endif
