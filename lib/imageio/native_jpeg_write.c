/*
 * native_jpeg_write.c - JPEG output through libjpeg-turbo (see
 * native_jpeg_write.h).
 *
 * The settings are those of OpenImageIO 2.4's JPEG writer for an image
 * spec with no metadata but CompressionQuality (imageio.cpp's
 * encode_impl): JFIF 1.01 with density unit 0 and density 1:1,
 * jpeg_set_defaults then jpeg_set_quality(q, TRUE) (4:2:0 for colour,
 * islow DCT, standard Huffman tables, no optimisation), and an APP1 Exif
 * block holding an empty little-endian TIFF directory, written right
 * after the start of compression.  tests/test_native_write.c compares the
 * bytes with the module's over sizes, channel counts and qualities.
 *
 * The output buffer starts at a guess of the encoded size (libjpeg's
 * jpeg_mem_dest grows it by doubling when short), and the rows go to
 * libjpeg straight from the caller's pixels.
 */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>

#include "imageio/native_jpeg_write.h"

/* OpenImageIO's Exif block when the spec holds no Exif data: "Exif\0\0",
 * then a TIFF header ("II", 42, first directory at 8) and a directory of
 * no entries whose next-directory offset is 0. */
static const JOCTET empty_exif[20] = {
    'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0,
    0, 0, 0, 0, 0, 0};

/* libjpeg reports errors through error_exit, which must not return: it
 * longjmps back to gv_native_jpeg_encode with the message kept. */
struct failer {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
    char msg[JMSG_LENGTH_MAX];
};

static void on_error(j_common_ptr c)
{
    struct failer *f = (struct failer *)(void *)c->err;
    c->err->format_message(c, f->msg);
    longjmp(f->jump, 1);
}

/* Warnings (corrupt input cannot happen here) are not printed. */
static void on_message(j_common_ptr c)
{
    (void)c;
}

int gv_native_jpeg_encodes(uint32_t width, uint32_t height, int channels)
{
    return (channels == 1 || channels == 3) && width >= 1 && height >= 1 &&
           width <= JPEG_MAX_DIMENSION && height <= JPEG_MAX_DIMENSION;
}

/* gv_native_jpeg_encode of a checked image at quality 1..100. */
static int compress(uint32_t width, uint32_t height, int channels,
                    const uint8_t *pixels, int quality, uint8_t **out,
                    size_t *len, struct gv_error *err)
{
    struct jpeg_compress_struct c;
    struct failer f;
    /* A guess of the size (a tenth of the pixels' bytes and the headers);
     * volatile: it is read after a longjmp. */
    size_t guess = (size_t)width * height * (size_t)channels / 10 + 1024;
    unsigned char *volatile start = malloc(guess);
    unsigned char *buf = start;
    unsigned long size = start ? (unsigned long)guess : 0;
    memset(&c, 0, sizeof c);
    c.err = jpeg_std_error(&f.mgr);
    f.mgr.error_exit = on_error;
    f.mgr.output_message = on_message;
    if (setjmp(f.jump)) {
        jpeg_destroy_compress(&c);
        /* jpeg_mem_dest frees the buffers it grew into, not ours */
        free(start);
        return gv_fail(err, GV_EIO, "imageio: encoding jpg: %s", f.msg);
    }
    jpeg_create_compress(&c);
    jpeg_mem_dest(&c, &buf, &size);
    c.image_width = width;
    c.image_height = height;
    c.input_components = channels;
    c.in_color_space = channels == 3 ? JCS_RGB : JCS_GRAYSCALE;
    jpeg_set_defaults(&c);
    c.write_JFIF_header = TRUE;
    c.density_unit = 0;
    c.X_density = 1;
    c.Y_density = 1;
    jpeg_set_quality(&c, quality, TRUE);
    jpeg_start_compress(&c, TRUE);
    jpeg_write_marker(&c, JPEG_APP0 + 1, empty_exif, sizeof empty_exif);
    const size_t row = (size_t)width * (size_t)channels;
    while (c.next_scanline < c.image_height) {
        JSAMPROW rows[16];
        JDIMENSION n = 0;
        while (n < 16 && c.next_scanline + n < c.image_height) {
            rows[n] = (JSAMPROW)(pixels + (size_t)(c.next_scanline + n) * row);
            n++;
        }
        jpeg_write_scanlines(&c, rows, n);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    if (buf != start)
        free(start);   /* it grew into a buffer of libjpeg's (malloc'ed) */
    *out = buf;
    *len = size;
    return 0;
}

int gv_native_jpeg_encode(uint32_t width, uint32_t height, int channels,
                          const uint8_t *pixels, int quality, uint8_t **out,
                          size_t *len, struct gv_error *err)
{
    if (!gv_native_jpeg_encodes(width, height, channels))
        return gv_fail(err, GV_EINVAL, "imageio: cannot encode %ux%u pixels "
                       "of %d channels as JPEG", width, height, channels);
    return compress(width, height, channels, pixels,
                    quality < 1 ? 1 : quality > 100 ? 100 : quality, out, len,
                    err);
}
