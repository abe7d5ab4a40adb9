/*
 * native_png.h - PNG input through libpng itself, for the files whose
 * samples it gives exactly as the OpenImageIO module would (native_png.c
 * says which).  Used by imageio_loader.c behind gv_image_open /
 * gv_image_read / gv_image_close; internal to lib/imageio.
 */
#ifndef GV_NATIVE_PNG_H
#define GV_NATIVE_PNG_H

/* Same shape as native_jpeg.h: deliberately parallel, one native reader a
 * format behind the same four calls. */
#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

struct gv_native_png;

/* Whether the first n bytes of a file (n >= 8 to say yes) are the PNG
 * signature. */
int gv_native_png_sniff(const uint8_t *head, size_t n);

/*
 * Open `path` and read its header, as gv_image_open_limits does.  Returns
 * the reader, or NULL with *err filled (GV_ELIMIT: more than
 * lim->max_pixels, or an interlaced PNG, held whole while it is read,
 * needing more than lim->max_decoder_bytes; GV_ENOMEM), or NULL with
 * err->code == GV_OK when this reader declines the file (an oFFs origin
 * past INT_MAX, or any libpng error while opening): the caller then
 * hands it to the module.  The limits are applied before such a
 * decline.  err must not be NULL.  One reader is used by one thread at a
 * time; readers are independent.
 */
struct gv_native_png *gv_native_png_open(const char *path,
                                         const struct gv_image_limits *lim,
                                         struct gv_image_info *info,
                                         struct gv_error *err);

/*
 * The limits of gv_native_png_open alone, for a PNG the module is to read
 * (GIGAVIEW_NATIVE_READERS=0, or one the native reader declined): reads
 * the header only, with the module's libpng calls.  Returns -1 with *err
 * filled (the codes and words of gv_native_png_open), or 0 when within
 * the limits or when libpng cannot read the header (the module then
 * fails on it too, before allocating, and says why).  err must not be
 * NULL.
 */
int gv_native_png_check(const char *path, const struct gv_image_limits *lim,
                        struct gv_error *err);

/* The next `rows` rows, as gv_image_read: 0, or -1 with *err filled
 * (GV_ECORRUPT for damaged or truncated data, after which every read
 * fails; GV_EINVAL for a read past the last row; GV_ENOMEM).  An
 * interlaced image is decoded whole at the first read. */
int gv_native_png_read(struct gv_native_png *p, uint32_t rows, void *out,
                       struct gv_error *err);

/* Close.  gv_native_png_close(NULL) does nothing. */
void gv_native_png_close(struct gv_native_png *p);

/* For tests only (tests/test_native_read.c, the negative control): 1
 * makes readers opened afterwards leave 16-bit samples in the file's
 * big-endian order, unlike the module; 0 (the default) delivers them in
 * host order.  Not thread-safe. */
void gv_native_png_test_mode(int raw16);

#endif
