/*
 * native_png.c - PNG input through libpng, without the OpenImageIO
 * module.
 *
 * Why: as for native_jpeg.c, the module's some 260 libraries cost more
 * to load than a photograph takes to read; OpenImageIO 2.4's PNG reader
 * is a thin layer over the same libpng, and this file makes the same
 * calls, so that every byte it delivers is the module's.
 *
 * What OpenImageIO 2.4's reader (pnginput.cpp, png_pvt.h read_info) does,
 * and so this one: png_read_info, png_set_expand (1, 2 and 4-bit samples
 * to 8 bits, palette to RGB, tRNS to an alpha channel: gray + tRNS becomes
 * gray + alpha), png_set_swap on a little-endian host (16-bit samples in
 * host order), png_read_update_info, then one png_read_row per row, top
 * to bottom.  Channels are png_get_channels after the expansion; samples
 * are 8 or 16 bits (sBIT is ignored: OpenImageIO reports no other depth).
 * Alpha stays unassociated (the module asks for "oiio:UnassociatedAlpha"),
 * and gAMA, sRGB and iCCP only become metadata there: no pixel changes.
 * libpng's own checks and defaults (CRC, zlib, benign errors, its width
 * and height limits of 1000000) are the same library's.  Warnings are
 * ignored, as there; errors fail the read with the module's words: "PNG
 * read error: MESSAGE", or "Read error: hit end of file" for a file that
 * ends early.  Nothing is printed.  The end of the file after the last
 * row (IEND, trailing chunks) is never read, as there.
 *
 * Interlaced (Adam7) files are decoded whole at the first read, as
 * there: png_read_image, then png_read_end.
 *
 * Declined, for the module to read (gv_native_png_open returns NULL with
 * no error): an oFFs origin so far out that the module's row numbers
 * would pass INT_MAX (it only shifts them otherwise), and any file on
 * which libpng reports an error while opening, so that the module's own
 * message and code describe damaged headers.  The limits (below) are
 * applied before the oFFs decline.
 *
 * Memory: libpng's row buffers, allocated by png_read_update_info only
 * after width * height has been checked against max_pixels; for an
 * interlaced file, the whole image and its row pointers, as in the
 * module (OpenImageIO 2.4 png_pvt.h read_into_buffer: image_bytes of the
 * expanded samples, zeroed, and a pointer a row).  A file of 1 KB whose
 * IHDR claims 12000 x 12000 made the module allocate and touch 549 MiB
 * before failing on its missing data.  So, before anything is allocated
 * for the image, an interlaced file's need, height * (width * channels *
 * bytes a sample + a pointer), with the channels and bytes as libpng
 * will deliver them (after png_set_expand: a tRNS chunk adds an alpha
 * channel), is checked against max_decoder_bytes: GV_ELIMIT above it,
 * naming both, in the words of native_jpeg.c.  The same check, with the
 * pixel limit, runs before the module is handed any PNG
 * (gv_native_png_check).  A non-interlaced file is read a row at a time
 * and needs no such buffer: the limit does not apply to it.
 */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <png.h>

#include "imageio/native_file.h"
#include "imageio/native_png.h"
#include "imageio/size_limit.h"

struct gv_native_png {
    png_structp png;
    png_infop info;
    FILE *f;
    char *path;
    uint32_t width, height, next_row;
    size_t row_bytes;
    int interlaced;                /* Adam7: read whole at the first read */
    uint8_t *whole;                /* then the whole image, row_bytes * height */
    int broken;                    /* a read failed: every later one fails */
    char msg[256];                 /* the first error's text */
};

/* Same shape as the test mode of imageio/native_tiff.c: deliberately separate,
 * each format has its own test switch. */
static int test_raw16;

void gv_native_png_test_mode(int raw16)
{
    test_raw16 = raw16;
}

int gv_native_png_sniff(const uint8_t *head, size_t n)
{
    return n >= 8 && png_sig_cmp((png_const_bytep)head, 0, 8) == 0;
}

/* libpng's error callback must not return: it longjmps back to the
 * setjmp of the call that failed. */
static void on_error(png_structp png, png_const_charp msg)
{
    struct gv_native_png *p = png_get_error_ptr(png);
    if (!p->msg[0])
        snprintf(p->msg, sizeof p->msg, "PNG read error: %s", msg);
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* stdio through our own callback, for OpenImageIO's message on a file
 * that ends early. */
static void on_read(png_structp png, png_bytep data, size_t n)
{
    struct gv_native_png *p = png_get_io_ptr(png);
    if (fread(data, 1, n, p->f) != n) {
        if (!p->msg[0])
            snprintf(p->msg, sizeof p->msg, "Read error: hit end of file");
        png_error(png, "Read error: hit end of file");
    }
}

void gv_native_png_close(struct gv_native_png *p)
{
    if (!p)
        return;
    if (p->png)
        png_destroy_read_struct(&p->png, p->info ? &p->info : NULL, NULL);
    if (p->f)
        fclose(p->f);
    free(p->whole);
    free(p->path);
    free(p);
}

static int little_endian(void)
{
    const uint16_t one = 1;
    return *(const uint8_t *)&one == 1;
}

/* What an interlaced image of h rows of row_bytes is held in while it is
 * read, here and in the module: the rows and a pointer to each
 * (UINT64_MAX past 64 bits). */
static uint64_t whole_bytes(uint64_t row_bytes, uint64_t h)
{
    const uint64_t per_row = row_bytes + sizeof(png_bytep);
    return h > UINT64_MAX / per_row ? UINT64_MAX : h * per_row;
}

/* Open `path`, read its header and apply the limits (see "Memory"):
 * returns the reader with p->width, height, row_bytes and interlaced set
 * and *channels_out, *depth_out, or NULL with *err filled (refused), or
 * NULL with err->code == GV_OK (declined: not a PNG, or a libpng error).
 * `reader`: 0 for gv_native_png_check, which takes any PNG libpng
 * reads; 1 also declines what this reader leaves to the module. */
static struct gv_native_png *start(const char *path,
                                   const struct gv_image_limits *lim,
                                   int reader, int *channels_out,
                                   int *depth_out, struct gv_error *err)
{
    gv_error_clear(err);
    struct gv_native_png *p = calloc(1, sizeof *p);
    if (!p) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        return NULL;
    }
    p->path = strdup(path);
    if (!p->path) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        goto out;
    }
    p->f = gv_native_open_regular(path);
    if (!p->f)
        goto out;   /* the module says why */
    uint8_t head[8];
    if (fread(head, 1, sizeof head, p->f) != sizeof head
        || !gv_native_png_sniff(head, sizeof head))
        goto out;
    p->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, p, on_error,
                                    on_warning);
    if (p->png)
        p->info = png_create_info_struct(p->png);
    if (!p->info) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        goto out;
    }
    if (setjmp(png_jmpbuf(p->png)))
        goto out;
    png_set_read_fn(p->png, p, on_read);
    png_set_sig_bytes(p->png, 8);
    png_read_info(p->png, p->info);
    png_uint_32 w, h;
    int depth, color, interlace;
    png_get_IHDR(p->png, p->info, &w, &h, &depth, &color, &interlace, NULL,
                 NULL);
    if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu)
        goto out;   /* libpng's own check refuses these first */
    if (gv_image_size_check(path, w, h, lim->max_pixels, err) < 0)
        goto out;
    /* The row buffers (png_read_update_info) are allocated only now. */
    png_set_expand(p->png);
    if (little_endian() && !test_raw16)
        png_set_swap(p->png);
    png_read_update_info(p->png, p->info);
    int channels = png_get_channels(p->png, p->info);
    depth = png_get_bit_depth(p->png, p->info);
    const size_t row_bytes = png_get_rowbytes(p->png, p->info);
    if (p->msg[0])
        goto out;
    p->interlaced = interlace != PNG_INTERLACE_NONE;
    const uint64_t max = gv_image_decoder_limit(lim);
    if (p->interlaced && whole_bytes(row_bytes, h) > max) {
        char need_s[32], max_s[32];
        gv_image_bytes_text(need_s, sizeof need_s, whole_bytes(row_bytes, h));
        gv_image_bytes_text(max_s, sizeof max_s, max);
        gv_fail(err, GV_ELIMIT, "imageio: %s: an interlaced PNG of %u x %u "
                "needs about %s of decoder memory, more than the limit of "
                "%s (--max-decoder-memory)", path, (unsigned)w, (unsigned)h,
                need_s, max_s);
        goto out;
    }
    if (reader) {
        size_t bytes = depth == 16 ? 2 : 1;
        /* The module reads rows by their number from the oFFs origin, in
         * an int: one whose last row would pass INT_MAX is left to it. */
        if ((int64_t)png_get_x_offset_pixels(p->png, p->info) + w
                > 0x7fffffff
            || (int64_t)png_get_y_offset_pixels(p->png, p->info) + h
                > 0x7fffffff)
            goto out;
        if (channels < 1 || channels > 4 || (depth != 8 && depth != 16)
            || row_bytes != (size_t)w * channels * bytes)
            goto out;
        /* An interlaced image is held whole, within max_decoder_bytes;
         * refused here if that does not fit a size_t. */
        if (p->interlaced && (size_t)h > SIZE_MAX / 2 / row_bytes)
            goto out;
    }
    p->width = w;
    p->height = h;
    p->row_bytes = row_bytes;
    *channels_out = channels;
    *depth_out = depth;
    return p;

out:   /* refused with *err filled, or declined with it clear */
    gv_native_png_close(p);
    return NULL;
}

struct gv_native_png *gv_native_png_open(const char *path,
                                         const struct gv_image_limits *lim,
                                         struct gv_image_info *info,
                                         struct gv_error *err)
{
    int channels = 0, depth = 0;
    struct gv_native_png *p = start(path, lim, 1, &channels, &depth, err);
    if (!p)
        return NULL;
    memset(info, 0, sizeof *info);
    info->width = p->width;
    info->height = p->height;
    info->channels = channels;
    info->bits = depth;
    info->sample = depth == 16 ? GV_SAMPLE_U16 : GV_SAMPLE_U8;
    snprintf(info->format, sizeof info->format, "png");
    return p;
}

int gv_native_png_check(const char *path, const struct gv_image_limits *lim,
                        struct gv_error *err)
{
    int channels, depth;
    struct gv_native_png *p = start(path, lim, 0, &channels, &depth, err);
    gv_native_png_close(p);
    return err->code == GV_OK ? 0 : -1;
}

/* An interlaced image: decoded whole at the first read, as OpenImageIO
 * does (png_read_image without png_set_interlace_handling first, then
 * png_read_end, so that a damaged or missing IEND fails it), then handed
 * out from memory. */
static int read_whole(struct gv_native_png *p, uint32_t rows, void *out,
                      struct gv_error *err)
{
    if (!p->whole) {
        png_bytep *ptr = malloc((size_t)p->height * sizeof *ptr);
        p->whole = malloc(p->row_bytes * p->height);
        if (!ptr || !p->whole) {
            free(ptr);
            p->broken = 1;
            return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory",
                           p->path);
        }
        for (uint32_t y = 0; y < p->height; y++)
            ptr[y] = p->whole + (size_t)y * p->row_bytes;
        /* ptr is freed on both ways out: kept in a volatile across the
         * setjmp. */
        png_bytep *volatile rows_ptr = ptr;
        if (setjmp(png_jmpbuf(p->png))) {
            free(rows_ptr);
            p->broken = 1;
            return gv_fail(err, GV_ECORRUPT, "imageio: %s: %s", p->path,
                           p->msg[0] ? p->msg : "PNG read error");
        }
        png_read_image(p->png, rows_ptr);
        png_read_end(p->png, NULL);
        free(rows_ptr);
    }
    memcpy(out, p->whole + (size_t)p->next_row * p->row_bytes,
           (size_t)rows * p->row_bytes);
    p->next_row += rows;
    return 0;
}

int gv_native_png_read(struct gv_native_png *p, uint32_t rows, void *out,
                       struct gv_error *err)
{
    if (gv_image_read_check(p->path, p->broken, rows, p->next_row,
                            p->height, err) < 0)
        return -1;
    if (rows == 0)
        return 0;
    if (p->interlaced)
        return read_whole(p, rows, out, err);
    if (setjmp(png_jmpbuf(p->png))) {
        p->broken = 1;
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: %s", p->path,
                       p->msg[0] ? p->msg : "PNG read error");
    }
    for (uint32_t k = 0; k < rows; k++) {
        png_read_row(p->png, (png_bytep)out + (size_t)k * p->row_bytes, NULL);
        p->next_row++;
    }
    return 0;
}
