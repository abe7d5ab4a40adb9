/*
 * native_jpeg.h - JPEG input through libjpeg-turbo itself, for the files
 * whose pixels it gives exactly as the OpenImageIO module would
 * (native_jpeg.c says which).  Used by imageio_loader.c behind
 * gv_image_open / gv_image_read / gv_image_close; internal to lib/imageio.
 */
#ifndef GV_NATIVE_JPEG_H
#define GV_NATIVE_JPEG_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

struct gv_native_jpeg;

/* Whether the first n bytes of a file (n >= 3 to say yes) are a JPEG's
 * start of image. */
int gv_native_jpeg_sniff(const uint8_t *head, size_t n);

/*
 * Open `path` and read its header, as gv_image_open does.  Returns the
 * reader, or NULL with *err filled (GV_ELIMIT: more than max_pixels), or
 * NULL with err->code == GV_OK when this reader declines the file (not a
 * JPEG it reads exactly as the module does, or any error or warning of
 * libjpeg while opening): the caller then hands it to the module, which
 * reads it or reports the failure in its own words.  err must not be
 * NULL.  One reader is used by one thread at a time; readers are
 * independent.
 */
struct gv_native_jpeg *gv_native_jpeg_open(const char *path,
                                           uint64_t max_pixels,
                                           struct gv_image_info *info,
                                           struct gv_error *err);

/* The next `rows` rows, as gv_image_read: 0, or -1 with *err filled
 * (GV_ECORRUPT for damaged or truncated data, after which every read
 * fails; GV_EINVAL for a read past the last row). */
int gv_native_jpeg_read(struct gv_native_jpeg *j, uint32_t rows, void *out,
                        struct gv_error *err);

/* Close.  gv_native_jpeg_close(NULL) does nothing. */
void gv_native_jpeg_close(struct gv_native_jpeg *j);

/* For tests only (tests/test_native_read.c, the negative control): 1
 * makes readers opened afterwards decode with the fast integer DCT and
 * without fancy upsampling, which gives other pixels than the module;
 * 0 (the default) restores libjpeg's defaults.  Not thread-safe. */
void gv_native_jpeg_test_mode(int fast);

#endif
