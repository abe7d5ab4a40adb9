/*
 * native_jpeg_write.h - JPEG output through libjpeg-turbo itself, byte for
 * byte what the OpenImageIO module writes for the same pixels and quality
 * (native_jpeg_write.c says how), so that gv_image_encode("jpg") needs no
 * module: no 0.2-0.7 s load of OpenImageIO's libraries on a server's first
 * JPEG answer, and no ImageOutput per image.  Used by imageio_loader.c
 * behind gv_image_encode; internal to lib/imageio.
 */
#ifndef GV_NATIVE_JPEG_WRITE_H
#define GV_NATIVE_JPEG_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* Whether gv_native_jpeg_encode takes an image of this size and channel
 * count (1 or 3 channels, each side 1..65500, libjpeg's limit); the
 * others go to the module, which refuses them in its own words. */
int gv_native_jpeg_encodes(uint32_t width, uint32_t height, int channels);

/*
 * Encode width x height pixels of `channels` (1: gray, 3: RGB; rows
 * packed) as a baseline JPEG of quality 1..100 (clamped), as the module
 * does.  *out is malloc'ed (free it), *len bytes.  Thread-safe (nothing
 * shared).  Returns 0, or -1 with *err (GV_EINVAL for an image
 * gv_native_jpeg_encodes declines, GV_ENOMEM, GV_EIO with libjpeg's
 * message).
 */
int gv_native_jpeg_encode(uint32_t width, uint32_t height, int channels,
                          const uint8_t *pixels, int quality, uint8_t **out,
                          size_t *len, struct gv_error *err);

#endif
