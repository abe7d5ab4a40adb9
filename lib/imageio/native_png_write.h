/*
 * native_png_write.h - PNG output through libpng itself, byte for byte
 * what the OpenImageIO module writes for the same samples
 * (native_png_write.c says how), so that gv_image_encode("png") and
 * gv_image_encode_typed("png") need no module: a server's first PNG
 * answer (a region's default format, png16 of a height or sample store,
 * an IIIF .png) no longer waits for OpenImageIO's some 260 libraries to
 * load (0.2 s idle; over 30 s in a sanitizer build on a busy machine).
 * Used by imageio_loader.c; internal to lib/imageio.
 */
#ifndef GV_NATIVE_PNG_WRITE_H
#define GV_NATIVE_PNG_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "imageio/imageio.h"

/* Whether gv_native_png_encode takes this image: what the module writes
 * as PNG but floats, 1 or 3 channels of 8-bit samples (GV_SAMPLE_U8) and
 * 1 to 4 of 16-bit ones (GV_SAMPLE_U16), each side 1 .. 2^31 - 1 (PNG's
 * limit; libpng's default limit of 1000000 applies to reading only).
 * The others go to the module, which refuses them in its own words. */
int gv_native_png_encodes(uint32_t width, uint32_t height, int channels,
                          enum gv_sample sample);

/*
 * Encode width x height pixels of `channels` samples (1 gray, 2 gray and
 * alpha, 3 RGB, 4 RGBA, the alpha written as it is, never associated;
 * rows packed; 16-bit samples in host order) as a
 * PNG, as the module does.  *out is malloc'ed (free it), *len bytes.
 * Thread-safe (nothing shared).  Returns 0, or -1 with *err (GV_EINVAL
 * for an image gv_native_png_encodes declines, GV_ENOMEM, GV_EIO with
 * libpng's message).
 */
int gv_native_png_encode(uint32_t width, uint32_t height, int channels,
                         enum gv_sample sample, const void *pixels,
                         uint8_t **out, size_t *len, struct gv_error *err);

#endif
