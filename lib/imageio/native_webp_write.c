/*
 * native_webp_write.c - WebP output through libwebp (see
 * native_webp_write.h).
 *
 * The settings are those of OpenImageIO 2.4's WebP writer
 * (webpoutput.cpp) for an image spec with CompressionQuality: the
 * defaults of WebPConfigInit (lossy, the default preset) with method 6
 * and the quality asked, the pixels imported by WebPPictureImportRGB,
 * and the module's own gray-to-RGB expansion (imageio.cpp's encode_impl:
 * the WebP writer reads three bytes a pixel).  tests/test_native_write.c
 * compares the bytes with the module's.
 */
#include <stdlib.h>
#include <string.h>

#include <webp/encode.h>

#include "imageio/native_webp_write.h"

int gv_native_webp_encodes(uint32_t width, uint32_t height, int channels)
{
    return (channels == 1 || channels == 3) && width >= 1 && height >= 1 &&
           width <= WEBP_MAX_DIMENSION && height <= WEBP_MAX_DIMENSION;
}

int gv_native_webp_encode(uint32_t width, uint32_t height, int channels,
                          const uint8_t *pixels, int quality, uint8_t **out,
                          size_t *len, struct gv_error *err)
{
    if (!gv_native_webp_encodes(width, height, channels))
        return gv_fail(err, GV_EINVAL, "imageio: cannot encode %ux%u pixels "
                       "of %d channels as WebP", width, height, channels);
    const size_t px = (size_t)width * height;
    uint8_t *rgb = NULL;
    if (channels == 1) {
        if (!(rgb = malloc(px * 3)))
            return gv_fail(err, GV_ENOMEM, "imageio: out of memory");
        for (size_t i = 0; i < px; i++)
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = pixels[i];
        pixels = rgb;
    }
    WebPConfig cfg;
    WebPPicture pic;
    WebPMemoryWriter mem;
    int rc = -1;
    if (!WebPConfigInit(&cfg) || !WebPPictureInit(&pic)) {
        free(rgb);
        return gv_fail(err, GV_EIO, "imageio: encoding webp: this libwebp "
                       "does not match its headers");
    }
    cfg.method = 6;
    cfg.quality = (float)(quality < 1 ? 1 : quality > 100 ? 100 : quality);
    pic.width = (int)width;
    pic.height = (int)height;
    WebPMemoryWriterInit(&mem);
    pic.writer = WebPMemoryWrite;
    pic.custom_ptr = &mem;
    if (!WebPPictureImportRGB(&pic, pixels, (int)width * 3)) {
        gv_fail(err, GV_ENOMEM, "imageio: out of memory");
    } else if (!WebPEncode(&cfg, &pic)) {
        gv_fail(err, pic.error_code == VP8_ENC_ERROR_OUT_OF_MEMORY ||
                         pic.error_code == VP8_ENC_ERROR_BITSTREAM_OUT_OF_MEMORY
                     ? GV_ENOMEM : GV_EIO,
                "imageio: encoding webp: libwebp error %d", (int)pic.error_code);
    } else if (mem.size == 0) {
        gv_fail(err, GV_EIO, "imageio: encoding webp produced no bytes");
    } else if (!(*out = malloc(mem.size))) {
        /* a copy: libwebp's buffer is its allocator's to free */
        gv_fail(err, GV_ENOMEM, "imageio: out of memory");
    } else {
        memcpy(*out, mem.mem, mem.size);
        *len = mem.size;
        rc = 0;
    }
    WebPMemoryWriterClear(&mem);
    WebPPictureFree(&pic);
    free(rgb);
    return rc;
}
