/*
 * native_jpeg.h - JPEG input through libjpeg-turbo itself, for the files
 * whose pixels it gives exactly as the OpenImageIO module would
 * (native_jpeg.c says which).  Used by imageio_loader.c behind
 * gv_image_open / gv_image_read / gv_image_close; internal to lib/imageio.
 */
#ifndef GV_NATIVE_JPEG_H
#define GV_NATIVE_JPEG_H

/* Same shape as native_png.h: deliberately parallel, one native reader a format
 * behind the same four calls. */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "base/error.h"
#include "imageio/imageio.h"

struct gv_native_jpeg;

/* Whether the first n bytes of a file (n >= 3 to say yes) are a JPEG's
 * start of image. */
int gv_native_jpeg_sniff(const uint8_t *head, size_t n);

/*
 * Open `path` and read its header, as gv_image_open_limits does.  Returns
 * the reader, or NULL with *err filled (GV_ELIMIT: more than
 * lim->max_pixels, or a progressive or multi-scan JPEG needing more than
 * lim->max_decoder_bytes; GV_ECORRUPT: such a JPEG claiming more blocks
 * than the file can code), or NULL with err->code == GV_OK when this
 * reader declines the file (not a JPEG it reads exactly as the module
 * does, or any error or warning of libjpeg while opening): the caller
 * then hands it to the module, which reads it or reports the failure in
 * its own words.  The limits are applied to declined files too, so that
 * the module is never handed one its libjpeg would allocate too much for.
 * err must not be NULL.  One reader is used by one thread at a time;
 * readers are independent.
 */
struct gv_native_jpeg *gv_native_jpeg_open(const char *path,
                                           const struct gv_image_limits *lim,
                                           struct gv_image_info *info,
                                           struct gv_error *err);

/*
 * The limits of gv_native_jpeg_open alone, for a JPEG the module is to
 * read (GIGAVIEW_NATIVE_READERS=0): reads the header only.  Returns -1
 * with *err filled (the codes and words of gv_native_jpeg_open), or 0
 * when within the limits or when libjpeg cannot read the header (the
 * module then says why).  err must not be NULL.
 */
int gv_native_jpeg_check(const char *path, const struct gv_image_limits *lim,
                         struct gv_error *err);

/*
 * The decoder memory of a JPEG inside another file, at byte `at` of f,
 * which OpenImageIO decodes whole (a Photoshop file's thumbnail,
 * psd_thumbnail.c): its pixels (width * height * components) and, for a
 * progressive or multi-scan one, its coefficients.  Returns -1 with *err
 * filled (GV_ELIMIT, naming `what`) when they exceed
 * lim->max_decoder_bytes, else 0 (also when libjpeg cannot read its
 * header).  err must not be NULL.
 */
int gv_native_jpeg_check_embedded(FILE *f, long at, const char *path,
                                  const char *what,
                                  const struct gv_image_limits *lim,
                                  struct gv_error *err);

/* What libjpeg will hold to decode one JPEG stream inside another file
 * (gv_native_jpeg_stream_need). */
struct gv_jpeg_need {
    uint32_t width, height;        /* the frame header's */
    int multi_scan;                /* progressive or multi-scan: held whole */
    int progressive;
    uint64_t coef_bytes;           /* the whole-image coefficient arrays
                                    * libjpeg requests, 0 when not multi_scan */
};

/*
 * The header of the JPEG stream in bytes [at, at + len) of f, read as
 * libtiff's JPEG codec hands it to libjpeg (a strip or tile of a
 * JPEG-compressed TIFF): after the tables-only stream in [tables_at,
 * tables_at + tables_len) when tables_len > 0 (the TIFF's JPEGTables),
 * and never past either range (libjpeg sees an EOI there).  Reads the
 * header only, in a few KB of buffer whatever the ranges claim.  Returns
 * 0 with *need filled (coef_bytes by native_jpeg.c's own rule, the one
 * its limit applies), or -1 when libjpeg cannot read a header there (the
 * decoder then fails on it too).
 */
int gv_native_jpeg_stream_need(FILE *f, uint64_t tables_at,
                               uint64_t tables_len, uint64_t at,
                               uint64_t len, struct gv_jpeg_need *need);

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

/* For tests only: 1 skips the decoder memory check made from the header,
 * leaving the limit libjpeg's memory manager applies itself
 * (max_memory_to_use) to refuse; 0 (the default) restores it.  Not
 * thread-safe. */
void gv_native_jpeg_test_backstop_only(int on);

#endif
