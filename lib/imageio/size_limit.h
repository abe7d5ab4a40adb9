/*
 * size_limit.h - the size rule every reader behind imageio.h applies
 * before it allocates anything for an image: sides within 31 bits and the
 * area within the caller's max_pixels, else GV_ELIMIT with one message.
 * The OpenImageIO module (imageio.cpp) and the native readers
 * (native_jpeg.c, native_png.c, native_tiff.c) say the same words, which
 * tests/test_native_read.c checks.  Internal to lib/imageio.
 */
#ifndef GV_SIZE_LIMIT_H
#define GV_SIZE_LIMIT_H

#include <stdint.h>

#include "base/error.h"

/* 0 when a w x h image of `path` may be read under max_pixels, else -1
 * with *err filled (GV_ELIMIT). */
static inline int gv_image_size_check(const char *path, uint64_t w,
                                      uint64_t h, uint64_t max_pixels,
                                      struct gv_error *err)
{
    /* Sides checked first, so that the product cannot overflow. */
    if (w <= 0x7fffffffu && h <= 0x7fffffffu && w * h <= max_pixels)
        return 0;
    return gv_fail(err, GV_ELIMIT, "imageio: %s: image of %llux%llu pixels "
                   "exceeds the limit of %llu pixels", path,
                   (unsigned long long)w, (unsigned long long)h,
                   (unsigned long long)max_pixels);
}

#endif
