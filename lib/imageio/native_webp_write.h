/*
 * native_webp_write.h - WebP output through libwebp itself, byte for
 * byte what the OpenImageIO module writes for the same pixels
 * (native_webp_write.c says how), so that gv_image_encode("webp") needs
 * no module: a server's first WebP answer (an IIIF .webp, a region's
 * format=webp) no longer waits for OpenImageIO's some 260 libraries to
 * load.  Used by imageio_loader.c; internal to lib/imageio.
 */
#ifndef GV_NATIVE_WEBP_WRITE_H
#define GV_NATIVE_WEBP_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* Whether gv_native_webp_encode takes this image: 1 (gray) or 3 (RGB)
 * channels of 8-bit samples, each side 1 .. 16383 (WebP's limit).  The
 * others go to the module, which refuses them in its own words. */
int gv_native_webp_encodes(uint32_t width, uint32_t height, int channels);

/*
 * Encode width x height pixels of 1 or 3 8-bit samples (rows packed) as a
 * lossy WebP at quality 1..100 (clamped), as the module does: gray is
 * written as RGB with equal channels.  *out is malloc'ed (free it), *len
 * bytes.  Thread-safe (nothing shared).  Returns 0, or -1 with *err
 * (GV_EINVAL for an image gv_native_webp_encodes declines, GV_ENOMEM,
 * GV_EIO with libwebp's error code).
 */
int gv_native_webp_encode(uint32_t width, uint32_t height, int channels,
                          const uint8_t *pixels, int quality, uint8_t **out,
                          size_t *len, struct gv_error *err);

#endif
