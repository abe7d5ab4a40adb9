/*
 * imageio.h - the C face of the OpenImageIO bridge (imageio.cpp, the only
 * C++ in gigaview), and of the native JPEG and PNG readers that stand in
 * for it on input (native_jpeg.c, native_png.c, with the same results;
 * imageio_loader.c chooses).
 *
 * Reading is split into a cheap probe (open: format and size from the
 * header) and sequential scanline reads in the file's own sample type
 * widened to one of three types, so that the caller applies the documented
 * 8-bit rule itself.  Writing takes a whole 8-bit image, encodes it in
 * memory and publishes it atomically (base/atomic_file.h).
 */
#ifndef GV_IMAGEIO_H
#define GV_IMAGEIO_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#ifdef __cplusplus
extern "C" {
#endif

enum gv_sample { GV_SAMPLE_U8, GV_SAMPLE_U16, GV_SAMPLE_F32 };

struct gv_image_info {
    uint32_t width, height;
    int channels;            /* channels in the file */
    int bits;                /* bits per sample in the file */
    enum gv_sample sample;   /* what gv_image_read delivers */
    char format[32];         /* OpenImageIO format name, e.g. "jpeg" */
};

struct gv_image_in;

/* The plane of an OME-TIFF stack to read (ome_tiff.h), from 0: `set` 0
 * reads a file of one plane and refuses a stack; set, it refuses any file
 * that is not an OME-TIFF (`gigaview encode --plane Z[,T]`). */
struct gv_image_plane {
    int set;
    uint32_t z, t;
};

/* What a reader may take for one image. */
struct gv_image_limits {
    uint64_t max_pixels;          /* width * height */
    uint64_t max_decoder_bytes;   /* memory a decoder may hold for the whole
                                   * image: a progressive or multi-scan
                                   * JPEG's coefficients, a Photoshop
                                   * file's JPEG thumbnail, an interlaced
                                   * PNG's pixels (0: the default,
                                   * GV_IMAGE_MAX_DECODER_BYTES) */
    struct gv_image_plane plane;
};

/* The default max_decoder_bytes: 1 GiB, the coefficients of a 350 MP
 * progressive JPEG in 4:2:0 or a 175 MP one in 4:4:4. */
#define GV_IMAGE_MAX_DECODER_BYTES (1ull << 30)

/* Open and probe `path`.  Rejects, with GV_ELIMIT and before allocating
 * anything for the image, images whose width*height exceeds
 * lim->max_pixels or whose sizes do not fit in 31 bits, and JPEGs whose
 * decoding would hold more than lim->max_decoder_bytes (a progressive or
 * multi-scan JPEG is held whole as coefficients, 2 bytes a sample, by
 * every reader), interlaced PNGs whose pixels would (held whole by every
 * reader), or Photoshop files whose JPEG thumbnail would (the
 * module decodes it whole); such a JPEG that claims more blocks than its
 * file can code is refused with GV_ECORRUPT.  Returns NULL and fills *err
 * on failure. */
struct gv_image_in *gv_image_open_limits(const char *path,
                                         const struct gv_image_limits *lim,
                                         struct gv_image_info *info,
                                         struct gv_error *err);

/* gv_image_open_limits with max_pixels and the default decoder memory. */
struct gv_image_in *gv_image_open(const char *path, uint64_t max_pixels,
                                  struct gv_image_info *info,
                                  struct gv_error *err);

/* Read the next `rows` scanlines, all channels, as info->sample values
 * (1, 2 or 4 bytes each) into out.  Returns 0, or -1 on a decode error or a
 * truncated file. */
int gv_image_read(struct gv_image_in *in, uint32_t rows, void *out,
                  struct gv_error *err);

/* Close.  gv_image_close(NULL) does nothing. */
void gv_image_close(struct gv_image_in *in);

/* What the file says of its pixels, as a JSON object of store metadata
 * (store/store_meta.h), valid until close; NULL for files without any.
 * A whole-slide image read through OpenSlide gives the scanner's
 * (slide.*: vendor, microns per pixel, objective power), a raster read
 * through GDAL its georeference (geo.*: geotransform, CRS, EPSG code). */
const char *gv_image_meta(const struct gv_image_in *in);

/* Where the file stores its pixels uncompressed, as gv_image_read
 * delivers them (today: an uncompressed TIFF of 8-bit samples read by
 * the native reader), a reader of any rectangle of them that outlives in
 * (raw_regions.h); else NULL with err->code GV_OK (always with
 * GIGAVIEW_RAW_REGIONS=0, for tests), or NULL with *err for
 * GV_ENOMEM. */
struct gv_raw_regions;
struct gv_raw_regions *gv_image_raw_regions(struct gv_image_in *in,
                                            struct gv_error *err);

/* Whether gv_image_read reads in's rows where they lie in the file, with
 * no decoder (the file gv_image_raw_regions answers for). */
int gv_image_reads_raw(const struct gv_image_in *in);

/* Write an 8-bit image (channels 1 or 3, rows packed) to `path`, format by
 * extension (.png, .tif/.tiff, .jpg/.jpeg, .webp).  The file appears under
 * its final name only when complete, replacing any file there, and is
 * fsynced (gv_atomic_file_write).  Returns 0, or -1 with *err filled:
 * GV_EINVAL / GV_EFORMAT for a name or an image it cannot write, the codes
 * of atomic_file.h for the file system. */
int gv_image_write(const char *path, uint32_t width, uint32_t height,
                   int channels, const uint8_t *pixels, struct gv_error *err);

/*
 * Encode an 8-bit image (channels 1 or 3) in memory as `format`: "png",
 * "jpg", "webp" or "tif".  quality (1..100) applies to jpg and webp.  *out is
 * malloc'ed (caller frees with free()).  Thread-safe.  Returns 0, or -1
 * (GV_EFORMAT for a format this build cannot write).
 */
int gv_image_encode(const char *format, uint32_t width, uint32_t height,
                    int channels, const uint8_t *pixels, int quality,
                    uint8_t **out, size_t *len, struct gv_error *err);

/* gv_image_write and gv_image_encode for 16-bit (png, tif) and float (tif)
 * samples as well: `sample` says what pixels holds (host order), in 1 to 4
 * channels for png and 1 to 8 for tif (written as samples, no alpha).  The
 * height and sample store routes use them (docs/API.md).  Same returns. */
typedef int gv_image_write_typed_fn(const char *path, uint32_t width,
                                    uint32_t height, int channels,
                                    enum gv_sample sample, const void *pixels,
                                    struct gv_error *err);
typedef int gv_image_encode_typed_fn(const char *format, uint32_t width,
                                     uint32_t height, int channels,
                                     enum gv_sample sample,
                                     const void *pixels, uint8_t **out,
                                     size_t *len, struct gv_error *err);
/* Declared through their types, which the module's table
 * (imageio_module.h) uses too. */
gv_image_write_typed_fn gv_image_write_typed;
gv_image_encode_typed_fn gv_image_encode_typed;

#ifdef __cplusplus
}
#endif

#endif
