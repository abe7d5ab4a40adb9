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
 * array (2 bytes a sample, pre-zeroed as it is decoded), as in the module.
 * That array is what a hostile file of a few hundred bytes claiming
 * 30000 x 30000 would make any libjpeg reader allocate and touch (about
 * 2.5 GiB, then fail on the missing data: the "progressive JPEG" attack,
 * LJT-01-004 in libjpeg-turbo's change log for 1.5.2).  So, from the
 * header alone and before anything is allocated for the image, every
 * JPEG this reader opens or the module is to read (check_limits):
 *  - width * height against max_pixels (size_limit.h);
 *  - for a progressive or multi-scan file, the bytes of the arrays
 *    libjpeg will request (coef_bytes, its own rule) against
 *    max_decoder_bytes, GV_ELIMIT above it, naming both;
 *  - and, Huffman-coded, the blocks of its first scan against the file:
 *    a DC or sequential scan codes every block of its components in at
 *    least one bit (a code is 1 to 16 bits long, ITU-T T.81 C and F.1.2,
 *    G.1.2.1; such scans skip no block), so a file with fewer bits than
 *    those blocks is truncated, whatever else it holds: GV_ECORRUPT.
 * libjpeg's memory manager enforces the same limit itself
 * (max_memory_to_use, honoured by jmemnobs.c since libjpeg-turbo 1.5.2:
 * arrays that do not fit need a backing store, which it does not have,
 * and it fails with "Backing store not supported" before allocating
 * them; only arrays no taller than its access window, a few block rows,
 * are always allocated), with a margin for its other buffers: a
 * backstop, reported in the same words (measured: a 65500 x 16
 * progressive file decodes at a limit of exactly its coefficients, and
 * a 12000 x 12000 claim is refused by the backstop alone, test
 * test_native_read.c).  A sequential single-scan file requests no such
 * array, so no file within max_pixels that is not progressive or
 * multi-scan is affected.
 */
#include <limits.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <jpeglib.h>
#include <jerror.h>

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

/* What libjpeg's memory manager may hold besides the coefficient arrays
 * when it realizes them (a few iMCU rows of buffers, under 10 MiB at the
 * widest, 65500 pixels): its own limit is max_decoder_bytes plus this. */
#define BACKSTOP_SLACK (64ull << 20)

static int test_fast, test_backstop_only;

void gv_native_jpeg_test_mode(int fast)
{
    test_fast = fast;
}

void gv_native_jpeg_test_backstop_only(int on)
{
    test_backstop_only = on;
}

/* Whether libjpeg holds the whole coefficient array of this file: a
 * progressive file, or a sequential one whose first scan lacks a
 * component (jdinput.c initial_setup, jdmaster.c: has_multiple_scans). */
static int multi_scan(const struct jpeg_decompress_struct *c)
{
    return c->progressive_mode || c->comps_in_scan < c->num_components;
}

static uint64_t round_up(uint64_t v, uint64_t m)
{
    return m ? (v + m - 1) / m * m : v;
}

/* The bytes of the whole-image arrays libjpeg requests for a multi-scan
 * file (jdcoefct.c jinit_d_coef_controller): per component, its width
 * and height in blocks rounded up to its sampling factors, a JBLOCK (64
 * coefficients of 2 bytes) each - the maximum_space of jmemmgr.c
 * realize_virt_arrays.  Measured with the checks removed: the resident
 * size rose by 2574 MiB for a 30000 x 30000 4:2:0 claim, computed here
 * as 2575 MiB, and by 411 MiB for 12000 x 12000, computed 412. */
static uint64_t coef_bytes(const struct jpeg_decompress_struct *c)
{
    uint64_t sum = 0;
    for (int ci = 0; ci < c->num_components; ci++) {
        const jpeg_component_info *k = &c->comp_info[ci];
        sum += round_up(k->width_in_blocks, (uint64_t)k->h_samp_factor)
               * round_up(k->height_in_blocks, (uint64_t)k->v_samp_factor)
               * sizeof(JBLOCK);
    }
    return sum;
}

/* The blocks the first scan must code in at least one bit each: those of
 * its components, when it is Huffman-coded and a DC or sequential scan
 * (Ss = 0); else 0 (arithmetic coding can take less than a bit). */
static uint64_t first_scan_blocks(const struct jpeg_decompress_struct *c)
{
    if (c->arith_code || c->Ss != 0)
        return 0;
    uint64_t n = 0;
    for (int i = 0; i < c->comps_in_scan; i++)
        n += (uint64_t)c->cur_comp_info[i]->width_in_blocks
             * c->cur_comp_info[i]->height_in_blocks;
    return n;
}

static const char *kind(const struct jpeg_decompress_struct *c)
{
    return c->progressive_mode ? "progressive" : "multi-scan";
}

/* The refusal for more than max_decoder_bytes: -1 with *err filled. */
static int refuse_memory(const struct jpeg_decompress_struct *c,
                         const char *path, uint64_t max,
                         struct gv_error *err)
{
    char need_s[32], max_s[32];
    gv_image_bytes_text(need_s, sizeof need_s, coef_bytes(c));
    gv_image_bytes_text(max_s, sizeof max_s, max);
    return gv_fail(err, GV_ELIMIT, "imageio: %s: a %s JPEG of %u x %u needs "
                   "about %s of decoder memory, more than the limit of %s "
                   "(--max-decoder-memory)", path, kind(c),
                   (unsigned)c->image_width, (unsigned)c->image_height,
                   need_s, max_s);
}

/* The limits, from the header (jpeg_read_header has returned) of a file
 * of file_bytes bytes, before anything is allocated for the image: 0, or
 * -1 with *err filled. */
static int check_limits(const struct jpeg_decompress_struct *c,
                        const char *path, uint64_t file_bytes,
                        const struct gv_image_limits *lim,
                        struct gv_error *err)
{
    if (gv_image_size_check(path, c->image_width, c->image_height,
                            lim->max_pixels, err) < 0)
        return -1;
    if (!multi_scan(c) || test_backstop_only)
        return 0;
    uint64_t max = gv_image_decoder_limit(lim);
    if (coef_bytes(c) > max)
        return refuse_memory(c, path, max, err);
    uint64_t blocks = first_scan_blocks(c);
    if (blocks / 8 > file_bytes)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: a %s JPEG of %u x %u "
                       "is truncated: its first scan codes %llu blocks, at "
                       "least %llu bytes, in a file of %llu bytes", path,
                       kind(c), (unsigned)c->image_width,
                       (unsigned)c->image_height, (unsigned long long)blocks,
                       (unsigned long long)(blocks / 8),
                       (unsigned long long)file_bytes);
    return 0;
}

static uint64_t file_size(FILE *f)
{
    struct stat st;
    return fstat(fileno(f), &st) == 0 ? (uint64_t)st.st_size : UINT64_MAX;
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

/* Errors to jerr (on_error: a longjmp to jerr->jump, which the caller
 * sets), warnings and messages kept, nothing printed; returns the
 * manager for cinfo.err. */
static struct jpeg_error_mgr *quiet_errors(struct jerr *jerr)
{
    struct jpeg_error_mgr *m = jpeg_std_error(&jerr->pub);
    m->error_exit = on_error;
    m->emit_message = on_message;
    m->output_message = on_output;
    return m;
}

/* Free a decompressor of our own (calloc'ed), created or not. */
static void free_decompress(struct jpeg_decompress_struct *c)
{
    if (!c)
        return;
    if (c->mem)
        jpeg_destroy_decompress(c);
    free(c);
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

/* Same shape as gv_native_tiff_open in native_tiff.c: deliberately separate,
 * each opens its own library's reader. */
struct gv_native_jpeg *gv_native_jpeg_open(const char *path,
                                           const struct gv_image_limits *lim,
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
        goto out;
    uint8_t head[3];
    if (fread(head, 1, sizeof head, j->f) != sizeof head
        || !gv_native_jpeg_sniff(head, sizeof head)
        || fseek(j->f, 0, SEEK_SET) != 0)
        goto out;

    j->cinfo.err = quiet_errors(&j->jerr);
    if (setjmp(j->jerr.jump))
        goto jumped;
    jpeg_create_decompress(&j->cinfo);
    j->created = 1;
    jpeg_stdio_src(&j->cinfo, j->f);
    jpeg_read_header(&j->cinfo, TRUE);
    /* The limits apply to a file declined below as well: the module's
     * libjpeg would allocate the same for it. */
    if (check_limits(&j->cinfo, path, file_size(j->f), lim, err) < 0)
        goto out;   /* refused: err says why */
    if (j->jerr.failed || !supported(&j->cinfo))
        goto out;   /* declined: err is clear */
    uint64_t w = j->cinfo.image_width, h = j->cinfo.image_height;
    /* libjpeg refuses sides above 65500 and zero; the module's limits
     * follow (imageio.cpp check_size), before anything is allocated. */
    if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu)
        goto out;
    if (test_fast) {
        j->cinfo.dct_method = JDCT_IFAST;
        j->cinfo.do_fancy_upsampling = FALSE;
    }
    uint64_t cap = gv_image_decoder_limit(lim) + BACKSTOP_SLACK;
    j->cinfo.mem->max_memory_to_use = cap > (uint64_t)LONG_MAX
                                          ? LONG_MAX : (long)cap;
    jpeg_start_decompress(&j->cinfo);
    if (j->jerr.failed || j->cinfo.output_width != w
        || j->cinfo.output_height != h
        || (j->cinfo.output_components != 1
            && j->cinfo.output_components != 3))
        goto out;

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

jumped:
    /* libjpeg's own limit (the backstop) is a refusal, never handed to
     * the module, whose libjpeg has none; any other error a decline. */
    if (j->created && j->jerr.pub.msg_code == JERR_NO_BACKING_STORE)
        refuse_memory(&j->cinfo, path, gv_image_decoder_limit(lim), err);
out:
    gv_native_jpeg_close(j);
    return NULL;
}

int gv_native_jpeg_check_embedded(FILE *f, long at, const char *path,
                                  const char *what,
                                  const struct gv_image_limits *lim,
                                  struct gv_error *err)
{
    gv_error_clear(err);
    if (fseek(f, at, SEEK_SET) != 0)
        return 0;
    struct jpeg_decompress_struct *volatile c = calloc(1, sizeof *c);
    struct jerr *volatile jerr = calloc(1, sizeof *jerr);
    volatile int rc = 0;   /* volatile: read after a longjmp */
    if (!c || !jerr) {
        rc = gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        goto out;
    }
    c->err = quiet_errors(jerr);
    if (setjmp(jerr->jump))
        goto out;   /* no header: OpenImageIO's reader fails on it too */
    jpeg_create_decompress(c);
    jpeg_stdio_src(c, f);
    jpeg_read_header(c, TRUE);
    /* decoded whole: every pixel, and the coefficients of a multi-scan
     * file */
    uint64_t need = (uint64_t)c->image_width * c->image_height
                    * (uint64_t)c->num_components
                    + (multi_scan(c) ? coef_bytes(c) : 0);
    uint64_t max = gv_image_decoder_limit(lim);
    if (need > max) {
        char need_s[32], max_s[32];
        gv_image_bytes_text(need_s, sizeof need_s, need);
        gv_image_bytes_text(max_s, sizeof max_s, max);
        rc = gv_fail(err, GV_ELIMIT, "imageio: %s: %s, a JPEG of %u x %u, "
                     "needs about %s of decoder memory, more than the limit "
                     "of %s (--max-decoder-memory)", path, what,
                     (unsigned)c->image_width, (unsigned)c->image_height,
                     need_s, max_s);
    }
out:
    free_decompress(c);
    free(jerr);
    return rc;
}

/* A libjpeg source over bytes [at, end) of a file, read a buffer at a
 * time, as libtiff's JPEG codec gives libjpeg one strip or tile: at the
 * range's end an EOI, as libtiff's own source inserts. */
struct range_src {
    struct jpeg_source_mgr pub;
    FILE *f;
    uint64_t at, end;
    JOCTET buf[4096];
};

static void range_init(j_decompress_ptr c)
{
    (void)c;
}

static boolean range_fill(j_decompress_ptr c)
{
    struct range_src *s = (struct range_src *)c->src;
    static const JOCTET eoi[2] = {0xFF, JPEG_EOI};
    size_t want = s->end - s->at < sizeof s->buf ? (size_t)(s->end - s->at)
                                                 : sizeof s->buf;
    size_t got = 0;
    if (want > 0 && fseeko(s->f, (off_t)s->at, SEEK_SET) == 0)
        got = fread(s->buf, 1, want, s->f);
    if (got == 0) {
        s->at = s->end;
        s->pub.next_input_byte = eoi;
        s->pub.bytes_in_buffer = sizeof eoi;
        return TRUE;
    }
    s->at += got;
    s->pub.next_input_byte = s->buf;
    s->pub.bytes_in_buffer = got;
    return TRUE;
}

static void range_skip(j_decompress_ptr c, long n)
{
    struct range_src *s = (struct range_src *)c->src;
    if (n <= 0)
        return;
    if ((size_t)n <= s->pub.bytes_in_buffer) {
        s->pub.next_input_byte += n;
        s->pub.bytes_in_buffer -= (size_t)n;
        return;
    }
    uint64_t rest = (uint64_t)n - s->pub.bytes_in_buffer;
    s->at = s->end - s->at < rest ? s->end : s->at + rest;
    s->pub.bytes_in_buffer = 0;
}

static void range_term(j_decompress_ptr c)
{
    (void)c;
}

static void range_set(struct range_src *s, FILE *f, uint64_t at,
                      uint64_t len)
{
    s->f = f;
    s->at = at;
    s->end = len > UINT64_MAX - at ? UINT64_MAX : at + len;
    s->pub.bytes_in_buffer = 0;
    s->pub.next_input_byte = NULL;
}

int gv_native_jpeg_stream_need(FILE *f, uint64_t tables_at,
                               uint64_t tables_len, uint64_t at,
                               uint64_t len, struct gv_jpeg_need *need)
{
    memset(need, 0, sizeof *need);
    struct jpeg_decompress_struct *volatile c = calloc(1, sizeof *c);
    struct jerr *volatile jerr = calloc(1, sizeof *jerr);
    struct range_src *volatile src = calloc(1, sizeof *src);
    volatile int rc = -1;   /* volatile: read after a longjmp */
    if (!c || !jerr || !src)
        goto out;
    c->err = quiet_errors(jerr);
    if (setjmp(jerr->jump))
        goto out;
    jpeg_create_decompress(c);
    src->pub.init_source = range_init;
    src->pub.fill_input_buffer = range_fill;
    src->pub.skip_input_data = range_skip;
    src->pub.resync_to_restart = jpeg_resync_to_restart;
    src->pub.term_source = range_term;
    c->src = &src->pub;
    if (tables_len > 0) {   /* libtiff: JPEGTables first, tables only */
        range_set(src, f, tables_at, tables_len);
        jpeg_read_header(c, FALSE);
    }
    range_set(src, f, at, len);
    if (jpeg_read_header(c, TRUE) != JPEG_HEADER_OK)
        goto out;
    need->width = c->image_width;
    need->height = c->image_height;
    need->progressive = c->progressive_mode != 0;
    need->multi_scan = multi_scan(c);
    need->coef_bytes = need->multi_scan ? coef_bytes(c) : 0;
    rc = 0;
out:
    free_decompress(c);
    free(jerr);
    free(src);
    return rc;
}

int gv_native_jpeg_check(const char *path, const struct gv_image_limits *lim,
                         struct gv_error *err)
{
    gv_error_clear(err);
    volatile int rc = 0;   /* volatile: read after a longjmp */
    struct gv_native_jpeg *j = calloc(1, sizeof *j);
    if (!j)
        return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
    j->f = gv_native_open_regular(path);
    if (!j->f)
        goto out;   /* the module says why */
    j->cinfo.err = quiet_errors(&j->jerr);
    if (setjmp(j->jerr.jump))
        goto out;   /* no header: the module says why */
    jpeg_create_decompress(&j->cinfo);
    j->created = 1;
    jpeg_stdio_src(&j->cinfo, j->f);
    jpeg_read_header(&j->cinfo, TRUE);
    rc = check_limits(&j->cinfo, path, file_size(j->f), lim, err);
out:
    gv_native_jpeg_close(j);
    return rc;
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
    if (gv_image_read_check(j->path, j->broken, rows, j->next_row,
                            j->height, err) < 0)
        return -1;
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
