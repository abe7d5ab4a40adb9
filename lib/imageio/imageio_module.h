/*
 * imageio_module.h - what the OpenImageIO module (gigaview-oiio.so, built
 * from imageio.cpp) exports to the loader (imageio_loader.c): one table of
 * the functions of imageio.h, under the symbol GV_IMAGEIO_MODULE_SYMBOL.
 * Internal to lib/imageio.
 *
 * The module's reading handle is a struct gv_oiio_in (imageio.cpp defines
 * it under that name); the struct gv_image_in callers hold is the
 * loader's, which wraps either it or a native reader (imageio_loader.c).
 */
#ifndef GV_IMAGEIO_MODULE_H
#define GV_IMAGEIO_MODULE_H

#include "imageio/imageio.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Changed whenever the table or imageio.h's types change, so that a stale
 * module is refused rather than called. */
#define GV_IMAGEIO_MODULE_ABI 1
#define GV_IMAGEIO_MODULE_SYMBOL "gv_imageio_module"
#define GV_IMAGEIO_MODULE_FILE "gigaview-oiio.so"

struct gv_oiio_in;

struct gv_imageio_module {
    int abi;   /* GV_IMAGEIO_MODULE_ABI */
    struct gv_oiio_in *(*open)(const char *path, uint64_t max_pixels,
                               struct gv_image_info *info,
                               struct gv_error *err);
    int (*read)(struct gv_oiio_in *in, uint32_t rows, void *out,
                struct gv_error *err);
    void (*close)(struct gv_oiio_in *in);
    int (*write)(const char *path, uint32_t width, uint32_t height,
                 int channels, const uint8_t *pixels, struct gv_error *err);
    int (*encode)(const char *format, uint32_t width, uint32_t height,
                  int channels, const uint8_t *pixels, int quality,
                  uint8_t **out, size_t *len, struct gv_error *err);
    gv_image_write_typed_fn *write_typed;
    gv_image_encode_typed_fn *encode_typed;
};

#ifdef __cplusplus
}
#endif

#endif
