/*
 * native_jpeg.c - JPEG input through libjpeg-turbo, without the
 * OpenImageIO module.
 *
 * Why: the module loads some 260 libraries on first use, about 15 % of
 * the CPU time of `gigaview encode` of an 8-megapixel photograph
 * (bench/README.md, "native JPEG and PNG readers").  JPEG is the common
 * input, and OpenImageIO 2.4's JPEG reader is a thin layer over the same
 * libjpeg-turbo: this file makes the same calls with the same settings,
 * so that every byte it delivers is the module's.
 *
 * What OpenImageIO 2.4's reader (jpeginput.cpp) does, and so this one:
 * jpeg_read_header, then jpeg_start_decompress with libjpeg's default
 * decompression parameters (JDCT_ISLOW, fancy upsampling, output colour
 * space chosen by libjpeg: gray for one component, RGB for YCbCr or RGB),
 * then jpeg_read_scanlines top to bottom, and never
 * jpeg_finish_decompress (a damaged tail after the last row is not read).
 * Every warning libjpeg emits (premature end of file, corrupt data) is an
 * error there, and here.  Messages read as the module's: "imageio: PATH:
 * JPEG error: MESSAGE ("PATH")".
 *
 * Declined, for the module to read (gv_native_jpeg_open returns NULL with
 * no error): anything but 8-bit gray or 3-component YCbCr/RGB - CMYK and
 * YCCK, which OpenImageIO converts to RGB itself, 12-bit, 2 or 4
 * components - and any file on which libjpeg reports an error or warning
 * while opening, so that the module's own message and code describe
 * damaged headers.
 *
 * Memory: one iMCU row of buffers, as libjpeg needs for a sequential
 * file; a progressive or multi-scan file needs its whole coefficient
 * array (2 bytes a sample), as in the module.  Both are allocated only
 * after width * height has been checked against max_pixels.
 */
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <jpeglib.h>

#include "imageio/native_file.h"
#include "imageio/native_jpeg.h"
#include "imageio/size_limit.h"

/* libjpeg reports errors through error_exit, which must not return:
 * it longjmps back to the call that failed. */
struct jerr {
    struct jpeg_error_mgr pub;
    jmp_buf jump;
    int failed;                    /* an error or warning was reported */
    char msg[JMSG_LENGTH_MAX];     /* its text */
};

struct gv_native_jpeg {
    struct jpeg_decompress_struct cinfo;
    struct jerr jerr;
    FILE *f;
    char *path;
    uint32_t width, height, next_row;
    size_t row_bytes;
    int created;                   /* cinfo needs jpeg_destroy_decompress */
    int broken;                    /* a read failed: every later one fails */
};

static int test_fast;

void gv_native_jpeg_test_mode(int fast)
{
    test_fast = fast;
}

int gv_native_jpeg_sniff(const uint8_t *head, size_t n)
{
    /* SOI, then the 0xFF of the next marker. */
    return n >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF;
}

static void on_error(j_common_ptr cinfo)
{
    struct jerr *e = (struct jerr *)cinfo->err;
    if (!e->failed) {
        cinfo->err->format_message(cinfo, e->msg);
        e->failed = 1;
    }
    longjmp(e->jump, 1);
}

/* Warnings (level -1) and level-0 trace messages are what libjpeg's
 * default emit_message would print; OpenImageIO turns them into errors.
 * Nothing is printed. */
static void on_message(j_common_ptr cinfo, int level)
{
    struct jerr *e = (struct jerr *)cinfo->err;
    if (level <= 0 && !e->failed) {
        cinfo->err->format_message(cinfo, e->msg);
        e->failed = 1;
    }
    if (level < 0)
        cinfo->err->num_warnings++;
}

static void on_output(j_common_ptr cinfo)
{
    (void)cinfo;
}

void gv_native_jpeg_close(struct gv_native_jpeg *j)
{
    if (!j)
        return;
    if (j->created)
        jpeg_destroy_decompress(&j->cinfo);
    if (j->f)
        fclose(j->f);
    free(j->path);
    free(j);
}

/* Whether libjpeg's defaults decode this header to what OpenImageIO
 * delivers: 8-bit gray, or YCbCr or RGB to RGB. */
static int supported(const struct jpeg_decompress_struct *c)
{
    if (c->data_precision != 8)
        return 0;
    if (c->num_components == 1)
        return c->jpeg_color_space == JCS_GRAYSCALE
               && c->out_color_space == JCS_GRAYSCALE;
    if (c->num_components == 3)
        return (c->jpeg_color_space == JCS_YCbCr
                || c->jpeg_color_space == JCS_RGB)
               && c->out_color_space == JCS_RGB;
    return 0;
}

struct gv_native_jpeg *gv_native_jpeg_open(const char *path,
                                           uint64_t max_pixels,
                                           struct gv_image_info *info,
                                           struct gv_error *err)
{
    gv_error_clear(err);
    struct gv_native_jpeg *j = calloc(1, sizeof *j);
    if (!j)
        return NULL;   /* declined: the module reports what it can */
    j->path = strdup(path);
    j->f = gv_native_open_regular(path);
    if (!j->path || !j->f)
        goto decline;
    uint8_t head[3];
    if (fread(head, 1, sizeof head, j->f) != sizeof head
        || !gv_native_jpeg_sniff(head, sizeof head)
        || fseek(j->f, 0, SEEK_SET) != 0)
        goto decline;

    j->cinfo.err = jpeg_std_error(&j->jerr.pub);
    j->jerr.pub.error_exit = on_error;
    j->jerr.pub.emit_message = on_message;
    j->jerr.pub.output_message = on_output;
    if (setjmp(j->jerr.jump))
        goto decline;
    jpeg_create_decompress(&j->cinfo);
    j->created = 1;
    jpeg_stdio_src(&j->cinfo, j->f);
    jpeg_read_header(&j->cinfo, TRUE);
    if (j->jerr.failed || !supported(&j->cinfo))
        goto decline;
    uint64_t w = j->cinfo.image_width, h = j->cinfo.image_height;
    /* libjpeg refuses sides above 65500 and zero; the module's limits
     * follow (imageio.cpp check_size), before anything is allocated. */
    if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu)
        goto decline;
    if (gv_image_size_check(path, w, h, max_pixels, err) < 0) {
        gv_native_jpeg_close(j);
        return NULL;
    }
    if (test_fast) {
        j->cinfo.dct_method = JDCT_IFAST;
        j->cinfo.do_fancy_upsampling = FALSE;
    }
    jpeg_start_decompress(&j->cinfo);
    if (j->jerr.failed || j->cinfo.output_width != w
        || j->cinfo.output_height != h
        || (j->cinfo.output_components != 1
            && j->cinfo.output_components != 3))
        goto decline;

    j->width = (uint32_t)w;
    j->height = (uint32_t)h;
    j->row_bytes = (size_t)w * (size_t)j->cinfo.output_components;
    memset(info, 0, sizeof *info);
    info->width = j->width;
    info->height = j->height;
    info->channels = j->cinfo.output_components;
    info->bits = 8;
    info->sample = GV_SAMPLE_U8;
    snprintf(info->format, sizeof info->format, "jpeg");
    return j;

decline:
    gv_native_jpeg_close(j);
    return NULL;
}

static int fail_read(struct gv_native_jpeg *j, struct gv_error *err)
{
    j->broken = 1;
    const char *msg = j->jerr.msg[0] ? j->jerr.msg : "scanline read failed";
    return gv_fail(err, GV_ECORRUPT, "imageio: %s: JPEG error: %s (\"%s\")",
                   j->path, msg, j->path);
}

int gv_native_jpeg_read(struct gv_native_jpeg *j, uint32_t rows, void *out,
                        struct gv_error *err)
{
    if (j->broken)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: read after an error",
                       j->path);
    if (rows > j->height - j->next_row)
        return gv_fail(err, GV_EINVAL,
                       "imageio: %s: read of %u rows from row %u passes the "
                       "last row (%u)", j->path, rows, j->next_row,
                       j->height);
    /* volatile: changed between setjmp and a longjmp back to it */
    volatile uint32_t done = 0;
    if (setjmp(j->jerr.jump))
        return fail_read(j, err);
    while (done < rows) {
        /* Up to 16 rows a call: libjpeg hands out at most an iMCU row's
         * worth (rec_outbuf_height) at once. */
        JSAMPROW ptr[16];
        uint32_t want = rows - done < 16 ? rows - done : 16;
        for (uint32_t k = 0; k < want; k++)
            ptr[k] = (JSAMPROW)out + (size_t)(done + k) * j->row_bytes;
        JDIMENSION got = jpeg_read_scanlines(&j->cinfo, ptr, want);
        if (j->jerr.failed || got == 0)
            return fail_read(j, err);
        done += got;
        j->next_row += got;
    }
    return 0;
}
