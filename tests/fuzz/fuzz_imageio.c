/*
 * fuzz_imageio.c - libFuzzer target for the encoder's image input: the
 * native JPEG and PNG readers (lib/imageio/native_jpeg.c, native_png.c)
 * and the OpenImageIO bridge (lib/imageio/imageio.cpp) behind the source
 * (lib/encode/source.c), with a pixel cap.  A JPEG or PNG goes to a
 * native reader whatever its extension, unless that reader declines it.
 *
 * Byte 0 picks a file name extension (modulo the table's size;
 * its top bit also chooses an OME-TIFF stack's plane, as --plane does;
 * OpenImageIO chooses its reader by the extension first, then by trying
 * the others); the rest is the file.  It is written to a private temporary file (the bridge takes a path, as
 * `gigaview encode` does), opened with gv_source_open with max_pixels =
 * MAX_PIXELS, and, if it opens, read to the end a few rows at a time, as
 * the encoder reads it.  Checked:
 *  - the cap: an image that opens has width * height <= MAX_PIXELS, and
 *    channels 1 or 3; what it allocates is bounded by that (the
 *    fuzzer's -rss_limit_mb and malloc limit catch an allocation sized
 *    by a header before the cap is checked);
 *  - every failure fills the error message;
 *  - reading stops at the first error, and a read after it fails too;
 *  - where the file stores its pixels uncompressed (gv_source_raw_regions:
 *    an uncompressed 8-bit TIFF), three rectangles read from it where
 *    they lie equal the rows read in order.
 * Anything else (a crash, a sanitizer report, a hang) is a bug.  Only
 * gigaview's own code is instrumented, for coverage and for AddressSanitizer:
 * the readers inside OpenImageIO and its libraries are Debian's builds, so
 * mutations are guided by the seeds and the dictionary rather than by their
 * branches, and a stray write inside them is only seen when it crashes.
 * campaign.sh therefore replays the corpus a campaign grew through the
 * plain build under valgrind as well (VALGRIND_REPLAY).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz.h"
#include "store/store_meta.h"
#include "encode/source.h"
#include "imageio/raw_regions.h"

#define MAX_INPUT (1u << 20)   /* bigger files add time, not coverage */
#define MAX_PIXELS (1u << 20)  /* the cap under test: 1 MP */
#define READ_BYTES (256u << 10) /* rows per read: about this many bytes */

/* Readers the encoder meets in practice, then the odd ones OpenImageIO
 * also has; "bin" has no reader of its own, so every one is tried. */
static const char *const ext[] = {
    "png", "jpg", "tif", "exr", "webp", "gif", "bmp", "ppm",
    "hdr", "tga", "psd", "dpx", "sgi", "ico", "rla", "bin", "jp2", "fits",
    /* dpx, sgi, ico and rla are refused (lib/imageio/imageio.cpp
     * accepted_formats), bin has no reader: the refusal and the search
     * among the accepted readers are fuzzed too. */
};

/* OpenImageIO's own leak on truncated PNGs, ignored by the campaign.
 * (For the same reason no truncated PNG is in the replayed corpus: make
 * check VALGRIND=1 would count the leak.) */
#include "../oiio_lsan.h"

static char dir[64];

static void cleanup(void)
{
    if (dir[0])
        rmdir(dir);
}

static int write_file(const char *path, const uint8_t *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    int rc = fwrite(p, 1, n, f) == n ? 0 : -1;
    if (fclose(f) != 0)
        rc = -1;
    return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > MAX_INPUT)
        return 0;
    if (!dir[0]) {
        const char *tmp = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/gvfuzzimg.XXXXXX",
                 tmp && strlen(tmp) < 40 ? tmp : "/tmp");
        if (!mkdtemp(dir)) {
            perror("mkdtemp");
            abort();
        }
        atexit(cleanup);
    }
    char path[96];
    snprintf(path, sizeof path, "%s/in.%s", dir,
             ext[data[0] % (sizeof ext / sizeof ext[0])]);
    if (write_file(path, data + 1, size - 1) < 0) {
        perror(path);
        abort();
    }

    const char *inputs[1] = {path};
    struct gv_source_opts opts;
    memset(&opts, 0, sizeof opts);
    opts.max_pixels = MAX_PIXELS;
    /* Byte 0's top bit sets an OME-TIFF stack's plane (--plane), Z from
     * its bit 5. */
    if (data[0] & 0x80)
        opts.plane = (struct gv_image_plane){.set = 1, .z = (uint32_t)(data[0] >> 5 & 1)};
    struct gv_source_info info;
    struct gv_error err = {0};
    gv_error_clear(&err);
    struct gv_source *s = gv_source_open(inputs, 1, &opts, &info, &err);
    if (!s) {
        /* A missing OpenImageIO module would refuse every input and fuzz
         * nothing: stop loudly instead. */
        if (!err.text[0] || strstr(err.text, "cannot load the OpenImageIO module")) {
            fprintf(stderr, "fuzz_imageio: %s\n", err.text);
            abort();
        }
        unlink(path);
        return 0;
    }
    if ((uint64_t)info.width * info.height > MAX_PIXELS || info.width == 0 ||
        info.height == 0 || (info.channels != 1 && info.channels != 3))
        abort();
    /* What a reader says of the pixels (a slide's, a raster's, an
     * OME-TIFF's channels) must be metadata the encoder can keep. */
    const char *meta = gv_source_meta(s);
    if (meta && gv_meta_check(meta, strlen(meta), &err) < 0) {
        fprintf(stderr, "fuzz_imageio: reader metadata refused: %s\n", err.text);
        abort();
    }
    size_t row = (size_t)info.width * (size_t)info.channels;
    uint32_t step = (uint32_t)(READ_BYTES / row);
    if (step == 0)
        step = 1;
    struct gv_raw_regions *raw = gv_source_raw_regions(s, &err);
    if (!raw && err.code != GV_OK)
        abort();   /* only GV_ENOMEM, which the caps rule out */
    /* The whole image (at most MAX_PIXELS x 3 bytes), for the regions. */
    uint8_t *img = malloc((size_t)info.height * row);
    if (!img)
        abort();
    uint32_t y = 0;
    while (y < info.height) {
        uint32_t n = info.height - y < step ? info.height - y : step;
        uint8_t *buf = img + (size_t)y * row;
        gv_error_clear(&err);
        if (gv_source_read(s, n, buf, &err) < 0) {
            if (!err.text[0])
                abort();
            gv_error_clear(&err);
            if (gv_source_read(s, 1, buf, &err) == 0 || !err.text[0])
                abort(); /* no reads after an error */
            break;
        }
        y += n;
    }
    if (raw && y == info.height) {
        /* The whole image, its middle third, its last pixel. */
        const uint32_t w = info.width, h = info.height, c = (uint32_t)info.channels;
        const uint32_t r[3][4] = {{0, 0, w, h},
                                  {w / 3, h / 3, w - 2 * (w / 3), h - 2 * (h / 3)},
                                  {w - 1, h - 1, 1, 1}};
        uint8_t *got = malloc((size_t)h * row);
        if (!got)
            abort();
        for (int k = 0; k < 3; k++) {
            if (gv_raw_regions_read(raw, r[k][0], r[k][1], r[k][2], r[k][3],
                                    got, row, &err) < 0)
                abort();   /* the rows were read from the same blocks */
            for (uint32_t v = 0; v < r[k][3]; v++)
                if (memcmp(got + (size_t)v * row,
                           img + (size_t)(r[k][1] + v) * row + (size_t)r[k][0] * c,
                           (size_t)r[k][2] * c))
                    abort();
        }
        free(got);
    }
    gv_raw_regions_free(raw);
    free(img);
    gv_source_free(s);
    unlink(path);
    return 0;
}
