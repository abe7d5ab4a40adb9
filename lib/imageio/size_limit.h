/*
 * size_limit.h - the size rules every reader behind imageio.h applies
 * before it allocates anything for an image: sides within 31 bits and the
 * area within the caller's max_pixels, else GV_ELIMIT with one message;
 * the decoder memory limit with the wording of its messages; and the
 * bounds of every read.
 * The OpenImageIO module (imageio.cpp) and the native readers
 * (native_jpeg.c, native_png.c, native_tiff.c) say the same words, which
 * tests/test_native_read.c checks.  Internal to lib/imageio.
 */
#ifndef GV_SIZE_LIMIT_H
#define GV_SIZE_LIMIT_H

#include <stdint.h>
#include <stdio.h>

#include "base/error.h"
#include "imageio/imageio.h"

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

/* 0 when a read of `rows` rows from row next_row of an image `height`
 * rows tall may go ahead, else -1 with *err filled, in the words every
 * reader uses: GV_ECORRUPT after a failed read (broken), GV_EINVAL past
 * the last row. */
static inline int gv_image_read_check(const char *path, int broken,
                                      uint32_t rows, uint32_t next_row,
                                      uint32_t height, struct gv_error *err)
{
    if (broken)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: read after an error",
                       path);
    if (rows > height - next_row)
        return gv_fail(err, GV_EINVAL,
                       "imageio: %s: read of %u rows from row %u passes the "
                       "last row (%u)", path, rows, next_row, height);
    return 0;
}

/* The caller's decoder memory limit, 0 meaning the default. */
static inline uint64_t gv_image_decoder_limit(const struct gv_image_limits *lim)
{
    return lim->max_decoder_bytes ? lim->max_decoder_bytes
                                  : GV_IMAGE_MAX_DECODER_BYTES;
}

/* b bytes for a limit's message, as every reader words them: "2.5 GiB",
 * "192.0 MiB", "4.0 KiB", "100 bytes". */
static inline void gv_image_bytes_text(char *buf, size_t n, uint64_t b)
{
    if (b >= 1ull << 30)
        snprintf(buf, n, "%.1f GiB", (double)b / (1ull << 30));
    else if (b >= 1ull << 20)
        snprintf(buf, n, "%.1f MiB", (double)b / (1ull << 20));
    else if (b >= 1ull << 10)
        snprintf(buf, n, "%.1f KiB", (double)b / (1ull << 10));
    else
        snprintf(buf, n, "%llu bytes", (unsigned long long)b);
}

#endif
