/*
 * ome_tiff.h - OME-TIFF files whose channels are pages: the layout of
 * fluorescence microscopes' exports (Bio-Formats, tifffile), read through
 * native_tiff.c one directory a channel and delivered as one image of C
 * interleaved channels of one plane, with the channels' names and colours
 * as metadata.
 *
 * Taken: a first directory whose ImageDescription is OME-XML whose first
 * Pixels element says SizeC = C (1 .. 8), SizeZ and SizeT, and whose
 * Channel elements are one sample each; the directories of the chosen
 * plane's channels then follow OME-TIFF's default TiffData order, the
 * DimensionOrder (XYZCT when absent) with the first letter after XY
 * varying fastest, each one grey channel of the same size and depth that
 * native_tiff.c accepts.  A file of one plane (SizeZ = SizeT = 1) of one
 * channel, or one that breaks these rules, is declined and read as before
 * (its first page).  A stack (SizeZ or SizeT above 1) is read only with a
 * plane chosen (gv_image_limits.plane: z, t from 0); without one, or
 * with one outside it, or when a directory of its plane cannot be read,
 * it is refused, since no page of it is the image.  Metadata
 * (store_meta.h): "ome.channels", the channels' names joined by ';' (a
 * ';' in a name becomes ','), when every channel has one;
 * "display.colours" (render/samples_region.h), from the channels' Color
 * attributes (signed RGBA integers), when every channel has one; for a
 * stack "ome.plane_z", "ome.plane_t", "ome.size_z" and "ome.size_t".
 * Sub-resolutions (SubIFDs) are not read: gigaview builds its own
 * pyramid from the full resolution, which the main directories hold.
 * Planes stored in other files (TiffData with a UUID FileName) are not
 * followed.
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
 * *info its image) when it is such an OME-TIFF, with lim's max_pixels and
 * plane: opens the plane's channels' directories and returns the reader
 * with *info of C channels, `first` now its own (closed when the plane
 * does not use it).  NULL with err untouched: declined, `first` and *info
 * untouched (the caller keeps reading the first page).  NULL with *err
 * (GV_EINVAL: a stack without a plane or with one outside it; a
 * directory's error): refused, `first` still the caller's.
 */
struct gv_ome *gv_ome_take(const char *path, struct gv_native_tiff *first,
                           const struct gv_image_limits *lim, struct gv_image_info *info,
                           struct gv_error *err);

/* The next `rows` rows, C interleaved channels a pixel.  0, or -1 with
 * *err (a channel's read error). */
int gv_ome_read(struct gv_ome *o, uint32_t rows, void *out, struct gv_error *err);

/* The metadata JSON described above, or NULL. */
const char *gv_ome_meta(const struct gv_ome *o);

void gv_ome_close(struct gv_ome *o);

#endif
