/*
 * native_tiff.h - TIFF and BigTIFF input through libtiff itself, for the
 * files whose samples it gives exactly as the OpenImageIO module would
 * (native_tiff.c says which).  Used by imageio_loader.c behind
 * gv_image_open / gv_image_read / gv_image_close; internal to lib/imageio.
 */
#ifndef GV_NATIVE_TIFF_H
#define GV_NATIVE_TIFF_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"
#include "imageio/raw_regions.h"

struct gv_native_tiff;

/* Whether the first n bytes of a file (n >= 4 to say yes) start a TIFF
 * or a BigTIFF, either byte order. */
int gv_native_tiff_sniff(const uint8_t *head, size_t n);

/*
 * Open `path` and read its first directory, as gv_image_open does.
 * Returns the reader, or NULL with *err filled (GV_ELIMIT: more than
 * max_pixels), or NULL with err->code == GV_OK when this reader declines
 * the file (not a variant it reads exactly as the module does, or any
 * libtiff error while opening): the caller then hands it to the module.
 * err must not be NULL.  One reader is used by one thread at a time;
 * readers are independent.
 */
struct gv_native_tiff *gv_native_tiff_open(const char *path,
                                           uint64_t max_pixels,
                                           struct gv_image_info *info,
                                           struct gv_error *err);

/* The next `rows` rows, as gv_image_read: 0, or -1 with *err filled
 * (GV_ECORRUPT for damaged or truncated data, after which every read
 * fails; GV_EINVAL for a read past the last row; GV_ENOMEM). */
/* gv_native_tiff_open of directory `dir` (0: the first; an OME-TIFF's
 * channels are directories 0 .. C-1, ome_tiff.h), declined as above and
 * also when there is no such directory. */
struct gv_native_tiff *gv_native_tiff_open_dir(const char *path, uint32_t dir,
                                               uint64_t max_pixels,
                                               struct gv_image_info *info,
                                               struct gv_error *err);

/* The opened directory's ImageDescription (NUL-terminated, until close),
 * or NULL when it has none. */
const char *gv_native_tiff_description(const struct gv_native_tiff *t);

int gv_native_tiff_read(struct gv_native_tiff *t, uint32_t rows, void *out,
                        struct gv_error *err);

/* The file's pixels as rectangles read where they lie (raw_regions.h),
 * for an uncompressed file of 8-bit samples whose tiles or strips lie in
 * it whole; NULL with err->code GV_OK for any other (and for a reader
 * that failed, and always with GIGAVIEW_RAW_REGIONS=0, for tests: the
 * reader then reads every file through libtiff), NULL with *err for
 * GV_ENOMEM.  The reader has its own
 * descriptor: it outlives t.  The samples are those gv_native_tiff_read
 * delivers. */
struct gv_raw_regions *gv_native_tiff_regions(struct gv_native_tiff *t,
                                              struct gv_error *err);

/* Whether t reads its rows where they lie (an uncompressed file of 8-bit
 * samples, raw_regions.h): it then holds no strip or tile buffer, so
 * the size of a strip does not matter. */
int gv_native_tiff_reads_raw(const struct gv_native_tiff *t);

/* Close.  gv_native_tiff_close(NULL) does nothing. */
void gv_native_tiff_close(struct gv_native_tiff *t);

/* For tests only (tests/test_native_read.c, the negative control): 1
 * makes readers opened afterwards leave 16-bit samples byte-swapped,
 * unlike the module; 0 (the default) delivers them in host order.  Not
 * thread-safe. */
void gv_native_tiff_test_mode(int swap16);

#endif
