/*
 * test_native_read.c - the native JPEG, PNG and TIFF readers (lib/imageio/
 * native_jpeg.c, native_png.c, native_tiff.c) against the OpenImageIO
 * module, which they must equal byte for byte.
 *
 * Every JPEG, PNG and TIFF in tests/data and tests/data/native (variants
 * of every colour type, depth, subsampling, coding and TIFF layout;
 * make-variants.sh there) is read three ways, in uneven row counts (1, 7, then the rest):
 * by the module (GIGAVIEW_NATIVE_READERS=0), by the native reader called
 * directly, and through gv_image_open with native readers allowed.  The
 * image info and every delivered byte must be equal, and each file must
 * be taken natively or declined as expected (the CMYK JPEG, the 12-bit,
 * alpha, palette, MINISWHITE and JPEG-compressed TIFFs).
 * Negative controls: with a test-only decode setting (fast DCT and no
 * fancy upsampling; 16-bit samples left big-endian or byte-swapped) the
 * same comparison finds differences, so it can fail.  Hostile files: truncated at several
 * cut points, damaged headers, a header claiming more than max_pixels,
 * progressive and multi-scan JPEGs claiming more than the decoder memory
 * limit or more blocks than their bytes can code (refused every way,
 * with the resident size measured), interlaced PNGs claiming more
 * than it (the same; the limit exact, non-interlaced PNGs unaffected), a
 * Photoshop file whose JPEG thumbnail claims the same, TIFF tiles claimed enormous, tile
 * offsets past the end of the file -
 * the native path must fail (or decline) exactly where the module does,
 * with GV_ECORRUPT and an "imageio: PATH: " message, never crash.  A
 * forked child without the module checks that JPEG and PNG input needs
 * none, and that declined files (CMYK, a damaged header) do go to it.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_env.h"
#include "util.h"
#include "base/crc32.h"
#include "imageio/imageio.h"
#include "imageio/native_jpeg.h"
#include "imageio/native_png.h"
#include "imageio/native_tiff.h"

/* The module side of the comparisons of damaged PNGs leaks in
 * OpenImageIO; the sanitizer build ignores exactly that. */
#include "oiio_lsan.h"

static const char *datadir;
static char tmpdir[2048];

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcmp(s + n - m, suffix) == 0;
}

static int starts_with(const char *s, const char *prefix)
{
    return strncmp(s, prefix, strlen(prefix)) == 0;
}

enum how { MODULE, NATIVE, LOADER };

/* What one way of reading a file gave. */
struct result {
    int opened;              /* open succeeded */
    int read_ok;             /* every read succeeded */
    struct gv_image_info info;
    uint8_t *pix;            /* all rows (NULL unless opened) */
    size_t size;
    struct gv_error open_err, read_err;
};

static void result_free(struct result *r)
{
    free(r->pix);
    memset(r, 0, sizeof *r);
}

/* A reader opened one of the three ways, behind one set of calls. */
struct any {
    enum how how;
    struct gv_image_in *in;
    struct gv_native_jpeg *jpeg;
    struct gv_native_png *png;
    struct gv_native_tiff *tiff;
};

/* The decoder memory limit every open uses (0: the default). */
static uint64_t decoder_bytes;

static int any_open(struct any *a, enum how how, const char *path,
                    uint64_t max_pixels, struct gv_image_info *info,
                    struct gv_error *err)
{
    memset(a, 0, sizeof *a);
    a->how = how;
    gv_error_clear(err);
    const struct gv_image_limits lim = {.max_pixels = max_pixels,
                                        .max_decoder_bytes = decoder_bytes};
    if (how == NATIVE) {
        if (ends_with(path, ".jpg"))
            a->jpeg = gv_native_jpeg_open(path, &lim, info, err);
        else if (ends_with(path, ".tif"))
            a->tiff = gv_native_tiff_open(path, max_pixels, info, err);
        else
            a->png = gv_native_png_open(path, &lim, info, err);
        return a->jpeg || a->png || a->tiff ? 0 : -1;
    }
    if (how == MODULE)
        setenv("GIGAVIEW_NATIVE_READERS", "0", 1);
    else
        unsetenv("GIGAVIEW_NATIVE_READERS");
    a->in = decoder_bytes ? gv_image_open_limits(path, &lim, info, err)
                          : gv_image_open(path, max_pixels, info, err);
    unsetenv("GIGAVIEW_NATIVE_READERS");
    return a->in ? 0 : -1;
}

static int any_read(struct any *a, uint32_t rows, void *out,
                    struct gv_error *err)
{
    if (a->jpeg)
        return gv_native_jpeg_read(a->jpeg, rows, out, err);
    if (a->png)
        return gv_native_png_read(a->png, rows, out, err);
    if (a->tiff)
        return gv_native_tiff_read(a->tiff, rows, out, err);
    return gv_image_read(a->in, rows, out, err);
}

static void any_close(struct any *a)
{
    gv_native_jpeg_close(a->jpeg);
    gv_native_png_close(a->png);
    gv_native_tiff_close(a->tiff);
    gv_image_close(a->in);
}

static size_t sample_bytes(enum gv_sample s)
{
    return s == GV_SAMPLE_U8 ? 1 : s == GV_SAMPLE_U16 ? 2 : 4;
}

/* Read `path` one way: 1 row, 7 rows, then the rest. */
static struct result read_file(enum how how, const char *path,
                               uint64_t max_pixels)
{
    struct result r;
    memset(&r, 0, sizeof r);
    struct any a;
    if (any_open(&a, how, path, max_pixels, &r.info, &r.open_err) != 0)
        return r;
    r.opened = 1;
    size_t row = (size_t)r.info.width * r.info.channels
                 * sample_bytes(r.info.sample);
    r.size = row * r.info.height;
    r.pix = calloc(1, r.size ? r.size : 1);
    if (!r.pix)
        fail("out of memory");
    uint32_t y = 0, h = r.info.height;
    uint32_t steps[3] = {1, 7, 0};
    r.read_ok = 1;
    for (int k = 0; k < 3 && y < h; k++) {
        uint32_t n = k < 2 ? steps[k] : h - y;
        if (n > h - y)
            n = h - y;
        if (any_read(&a, n, r.pix + row * y, &r.read_err) != 0) {
            r.read_ok = 0;
            break;
        }
        y += n;
    }
    any_close(&a);
    return r;
}

static int same_info(const struct gv_image_info *a,
                     const struct gv_image_info *b)
{
    return a->width == b->width && a->height == b->height
           && a->channels == b->channels && a->bits == b->bits
           && a->sample == b->sample && strcmp(a->format, b->format) == 0;
}

/* Files the native readers must decline (the module reads them). */
static int expect_declined(const char *name)
{
    return strcmp(name, "cmyk.jpg") == 0
           || strcmp(name, "gradient-64x4-u12.tif") == 0
           || ends_with(name, "-declined.tif");
}

static void compare_file(const char *dir, const char *name)
{
    const char *path = test_path_in(dir, name);
    struct result m = read_file(MODULE, path, 1ull << 32);
    struct result n = read_file(NATIVE, path, 1ull << 32);
    struct result l = read_file(LOADER, path, 1ull << 32);
    check(m.opened && m.read_ok, "%s: the module reads it (%s%s)", name,
          m.open_err.text, m.read_err.text);
    if (expect_declined(name)) {
        check(!n.opened && n.open_err.code == GV_OK,
              "%s: declined by the native reader, without an error", name);
    } else {
        check(n.opened && n.read_ok, "%s: the native reader reads it (%s%s)",
              name, n.open_err.text, n.read_err.text);
        check(n.opened && same_info(&n.info, &m.info),
              "%s: native info = the module's (%ux%u c%d b%d s%d %s vs "
              "%ux%u c%d b%d s%d %s)", name, n.info.width, n.info.height,
              n.info.channels, n.info.bits, (int)n.info.sample,
              n.info.format, m.info.width, m.info.height, m.info.channels,
              m.info.bits, (int)m.info.sample, m.info.format);
        check(n.read_ok && m.read_ok && n.size == m.size
                  && memcmp(n.pix, m.pix, m.size) == 0,
              "%s: native bytes = the module's (%zu bytes)", name, m.size);
    }
    check(l.opened && l.read_ok && same_info(&l.info, &m.info)
              && l.size == m.size && memcmp(l.pix, m.pix, m.size) == 0,
          "%s: gv_image_open with native readers = the module", name);
    result_free(&m);
    result_free(&n);
    result_free(&l);
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every .jpg, .png and .tif in dir, in name order. */
static void compare_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        fail("opendir %s: %s", dir, strerror(errno));
    char *names[256];
    size_t count = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL && count < 256)
        if (ends_with(e->d_name, ".jpg") || ends_with(e->d_name, ".png")
            || ends_with(e->d_name, ".tif"))
            names[count++] = strdup(e->d_name);
    closedir(d);
    qsort(names, count, sizeof names[0], by_name);
    check(count >= 2, "%s: %zu JPEG, PNG and TIFF files to compare", dir,
          count);
    for (size_t i = 0; i < count; i++) {
        compare_file(dir, names[i]);
        free(names[i]);
    }
}

/* The comparison can fail: test-only decode settings give other bytes. */
static void test_negative_controls(const char *dir)
{
    const char *files[] = {"s420.jpg", "rgb16.png", "rgb16-zip.tif"};
    for (int k = 0; k < 3; k++) {
        const char *path = test_path_in(dir, files[k]);
        struct result m = read_file(MODULE, path, 1ull << 32);
        if (k == 0)
            gv_native_jpeg_test_mode(1);
        else if (k == 1)
            gv_native_png_test_mode(1);
        else
            gv_native_tiff_test_mode(1);
        struct result n = read_file(NATIVE, path, 1ull << 32);
        gv_native_jpeg_test_mode(0);
        gv_native_png_test_mode(0);
        gv_native_tiff_test_mode(0);
        check(m.read_ok && n.read_ok && n.size == m.size
                  && memcmp(n.pix, m.pix, m.size) != 0,
              "%s: a different decode setting (%s) gives different bytes",
              files[k], k == 0   ? "fast DCT, no fancy upsampling"
                        : k == 1 ? "16-bit samples big-endian"
                                 : "16-bit samples byte-swapped");
        result_free(&m);
        result_free(&n);
    }
}

/* A damaged file must fail (or open and read) exactly as in the module:
 * the same open result, the same read result, and a failure's code and
 * "imageio: PATH: " prefix. */
static int under_valgrind;

static void compare_damaged(const char *path, const char *what)
{
    if (under_valgrind && ends_with(path, ".png")) {
        /* OpenImageIO 2.4.7's PNG reader leaks a string on a file that
         * ends early (tests/fuzz/fuzz_imageio.c), which valgrind counts:
         * the native reader alone, which must fail cleanly or read. */
        struct result n = read_file(NATIVE, path, 1ull << 32);
        check(!n.opened ? n.open_err.code == GV_OK
                        : n.read_ok || (n.read_err.code == GV_ECORRUPT
                                        && starts_with(n.read_err.text,
                                                       "imageio: ")),
              "%s: the native reader declines, reads or fails cleanly "
              "(under valgrind, without the module)", what);
        result_free(&n);
        return;
    }
    struct result m = read_file(MODULE, path, 1ull << 32);
    struct result l = read_file(LOADER, path, 1ull << 32);
    int same = m.opened == l.opened && m.read_ok == l.read_ok;
    if (same && !m.opened)
        same = l.open_err.code == m.open_err.code
               && strcmp(l.open_err.text, m.open_err.text) == 0;
    else if (same && !m.read_ok)
        same = l.read_err.code == m.read_err.code
               && l.read_err.code == GV_ECORRUPT
               && starts_with(l.read_err.text, "imageio: ")
               && strstr(l.read_err.text, path) != NULL;
    else if (same)
        same = same_info(&l.info, &m.info)
               && memcmp(l.pix, m.pix, m.size) == 0;
    check(same, "%s: as the module: open %d/%d read %d/%d (%s | %s%s)", what,
          l.opened, m.opened, l.read_ok, m.read_ok,
          l.opened ? l.read_err.text : l.open_err.text,
          m.open_err.text, m.read_err.text);
    result_free(&m);
    result_free(&l);
}

static void test_truncated(const char *dir)
{
    const char *files[] = {"s420.jpg", "progressive.jpg", "gray.jpg",
                           "restart.jpg", "rgb8.png", "rgb16.png",
                           "palette4.png", "graya8.png",
                           "rgb8-interlaced.png", "gray4-interlaced.png",
                           "rgb8-lzw-tiled.tif", "rgb8-none-strips.tif",
                           "rgb16-zip.tif", "rgb8-bigtiff-be-tiled.tif",
                           "gray8-packbits-tiled.tif", "rgb8-zip-pred.tif"};
    /* Cut points in per mille of the length, and the last bytes. */
    const int cuts[] = {5, 30, 200, 500, 800, 990};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        size_t len;
        uint8_t *p = test_read_file_found(test_path_in(dir, files[f]), &len);
        for (size_t c = 0; c <= sizeof cuts / sizeof cuts[0]; c++) {
            size_t n = c < sizeof cuts / sizeof cuts[0]
                           ? len * (size_t)cuts[c] / 1000 : len - 1;
            char name[64];
            snprintf(name, sizeof name, "cut-%zu-%s", n, files[f]);
            const char *path = test_path_in(tmpdir, name);
            test_write_file(path, p, n);
            char what[128];
            snprintf(what, sizeof what, "%s cut to %zu of %zu bytes",
                     files[f], n, len);
            compare_damaged(path, what);
            unlink(path);
        }
        free(p);
    }
}

/* Bytes of the header flipped, and entropy-coded data overwritten. */
static void test_corrupt(const char *dir)
{
    const char *files[] = {"s420.jpg", "progressive.jpg", "rgb8.png",
                           "palette8-trns.png", "rgb8-interlaced.png",
                           "rgb8-lzw-tiled.tif", "rgb16-zip.tif"};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        size_t len;
        uint8_t *p = test_read_file_found(test_path_in(dir, files[f]), &len);
        uint64_t seed = 0x9e3779b97f4a7c15ull + f;
        for (int k = 0; k < 12; k++) {
            uint8_t *q = malloc(len);
            memcpy(q, p, len);
            /* the first 8 damage the header (after the magic), the rest
             * the data */
            size_t at = k < 8 ? 8 + test_rand(&seed) % 120
                              : len / 3 + test_rand(&seed) % (len / 2);
            size_t span = k < 8 ? 1 : 16;
            for (size_t i = at; i < at + span && i < len; i++)
                q[i] ^= (uint8_t)(1 + test_rand(&seed) % 255);
            char name[64], what[128];
            snprintf(name, sizeof name, "bad-%d-%s", k, files[f]);
            const char *path = test_path_in(tmpdir, name);
            test_write_file(path, q, len);
            snprintf(what, sizeof what, "%s with bytes %zu..%zu flipped",
                     files[f], at, at + span - 1);
            compare_damaged(path, what);
            unlink(path);
            free(q);
        }
        free(p);
    }
}

/* A header claiming more than max_pixels: refused at open with the
 * module's code and words, before any pixel buffer is allocated (the
 * sizes here would need gigabytes). */
static void test_huge(const char *dir)
{
    size_t len;
    uint8_t *p = test_read_file_found(test_path_in(dir, "s420.jpg"), &len);
    /* SOF0: FF C0, length, precision, height, width */
    for (size_t i = 0; i + 9 < len; i++)
        if (p[i] == 0xFF && p[i + 1] == 0xC0) {
            p[i + 5] = 0xFF, p[i + 6] = 0x00;   /* height 65280 */
            p[i + 7] = 0xFF, p[i + 8] = 0x00;   /* width 65280 */
            break;
        }
    const char *jpg = test_path_in(tmpdir, "huge.jpg");
    test_write_file(jpg, p, len);
    free(p);
    p = test_read_file_found(test_path_in(dir, "rgb8.png"), &len);
    /* IHDR's width and height at 16..23; its CRC at 29..32 */
    const uint8_t wh[8] = {0, 0x0F, 0x42, 0x40, 0, 0x0F, 0x42, 0x40};
    memcpy(p + 16, wh, 8);
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 12; i < 29; i++) {
        crc ^= p[i];
        for (int b = 0; b < 8; b++)
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1)));
    }
    crc ^= 0xFFFFFFFFu;
    p[29] = (uint8_t)(crc >> 24), p[30] = (uint8_t)(crc >> 16);
    p[31] = (uint8_t)(crc >> 8), p[32] = (uint8_t)crc;
    const char *png = test_path_in(tmpdir, "huge.png");
    test_write_file(png, p, len);
    free(p);
    const char *files[2] = {jpg, png};
    for (int k = 0; k < 2; k++) {
        struct result m = read_file(MODULE, files[k], 1u << 20);
        struct result n = read_file(NATIVE, files[k], 1u << 20);
        char want[4200];
        snprintf(want, sizeof want, "imageio: %s: image of %s pixels exceeds "
                 "the limit of 1048576 pixels", files[k],
                 k == 0 ? "65280x65280" : "1000000x1000000");
        check(!n.opened && n.open_err.code == GV_ELIMIT
                  && !m.opened && m.open_err.code == GV_ELIMIT,
              "%s claiming more than max_pixels: GV_ELIMIT, as the module",
              k == 0 ? "JPEG" : "PNG");
        check_str(n.open_err.text, want, "%s claiming more than max_pixels: "
                  "the module's message", k == 0 ? "JPEG" : "PNG");
        check_str(m.open_err.text, want, "%s claiming more than max_pixels: "
                  "the module's own message", k == 0 ? "JPEG" : "PNG");
        result_free(&m);
        result_free(&n);
        unlink(files[k]);
    }
}

/* tmpdir/out: a copy of the JPEG dir/name whose frame header (SOF0, 1 or
 * 2) claims w x h. */
static const char *jpeg_claiming(const char *dir, const char *name,
                                 const char *out, unsigned w, unsigned h)
{
    size_t len;
    uint8_t *p = test_read_file_found(test_path_in(dir, name), &len);
    size_t i = 2;
    while (i + 9 < len && p[i] == 0xFF && !(p[i + 1] >= 0xC0
                                            && p[i + 1] <= 0xC2))
        i += 2 + (size_t)(p[i + 2] << 8 | p[i + 3]);
    if (i + 9 >= len || p[i] != 0xFF)
        fail("%s: no frame header", name);
    p[i + 5] = (uint8_t)(h >> 8), p[i + 6] = (uint8_t)h;
    p[i + 7] = (uint8_t)(w >> 8), p[i + 8] = (uint8_t)w;
    const char *path = test_path_in(tmpdir, out);
    test_write_file(path, p, len);
    free(p);
    return path;
}

/* What reading `path` one way gave, and by how many MiB the resident
 * size rose to its peak meanwhile (-1: not measured). */
static struct result read_measured(enum how how, const char *path,
                                   uint64_t max_pixels, long long *peak_mib)
{
    *peak_mib = -1;
    long long before = test_peak_reset() ? test_status_kb("VmRSS") : -1;
    struct result r = read_file(how, path, max_pixels);
    long long hwm = test_status_kb("VmHWM");
    if (before >= 0 && hwm >= 0)
        *peak_mib = (hwm - before) / 1024;
    return r;
}

static const char *const how_name[] = {"the module", "native", "loader"};

/* Open `path` each way in ways (bits 1 << MODULE, NATIVE, LOADER): refused
 * at open with `code` and exactly `want` (with "PATH" for the path),
 * while the resident size rises by less than 48 MiB (hostile files here
 * would need hundreds, and the unprotected readers touch what they
 * need). */
static void expect_refused(const char *path, unsigned ways, enum gv_code code,
                           const char *want, const char *what)
{
    char full[4400];
    const char *at = strstr(want, "PATH");
    snprintf(full, sizeof full, "%.*s%s%s", (int)(at - want), want, path,
             at + 4);
    for (int how = MODULE; how <= LOADER; how++) {
        if (!(ways & 1u << how))
            continue;
        long long mib;
        struct result r = read_measured((enum how)how, path, 1ull << 32,
                                        &mib);
        check(!r.opened && r.open_err.code == code, "%s, %s: refused at open "
              "with code %d (%d: %s)", what, how_name[how], (int)code,
              (int)r.open_err.code, r.opened ? "opened" : r.open_err.text);
        check_str(r.open_err.text, full, "%s, %s: the message", what,
                  how_name[how]);
        if (mib >= 0 && !under_valgrind)
            check(mib < 48, "%s, %s: the resident size rose by %lld MiB "
                  "(< 48)", what, how_name[how], mib);
        result_free(&r);
    }
}

/* NAME in DIR read each way with a decoder memory limit of exactly BYTES,
 * its need; leaves the limit at BYTES. */
static void expect_read_at_limit(const char *dir, const char *name, unsigned bytes)
{
    decoder_bytes = bytes;
    for (int how = MODULE; how <= LOADER; how++) {
        struct result r = read_file((enum how)how, test_path_in(dir, name), 1ull << 32);
        check(r.opened && r.read_ok, "%s, %s: read with a limit of exactly its %u bytes "
              "(%s%s)", name, how_name[how], bytes, r.open_err.text, r.read_err.text);
        result_free(&r);
    }
}

/* The three files NAMES in DIR, each read each way with a decoder memory
 * limit of 1 byte: a reader that holds a row or a scan at a time needs
 * none.  Leaves the limit off. */
static void expect_read_in_one_byte(const char *dir, const char *const names[3])
{
    decoder_bytes = 1;
    for (int k = 0; k < 3; k++)
        for (int how = MODULE; how <= LOADER; how++) {
            struct result r = read_file((enum how)how, test_path_in(dir, names[k]), 1ull << 32);
            check(r.opened && r.read_ok, "%s, %s: read with a decoder "
                  "memory limit of 1 byte (%s%s)", names[k], how_name[how],
                  r.open_err.text, r.read_err.text);
            result_free(&r);
        }
    decoder_bytes = 0;
}

/* The decoder memory limit (native_jpeg.c, "Memory"): a progressive or
 * multi-scan JPEG claiming a size it cannot hold is refused from its
 * header, whichever reader would read it, before libjpeg allocates its
 * coefficients; the limit is exact and leaves other JPEGs alone. */
static void test_decoder_memory(const char *dir)
{
    const unsigned all = 1u << MODULE | 1u << NATIVE | 1u << LOADER;
    const char *const srcs[3] = {"progressive.jpg", "multiscan.jpg",
                                 "gray-progressive.jpg"};
    /* 30000 x 30000 under the default limit, 1 GiB: 4:2:0, 2.5 GiB; gray,
     * 1.7 GiB. */
    const char *const huge_want[3] = {
        "imageio: PATH: a progressive JPEG of 30000 x 30000 needs about "
        "2.5 GiB of decoder memory, more than the limit of 1.0 GiB "
        "(--max-decoder-memory)",
        "imageio: PATH: a multi-scan JPEG of 30000 x 30000 needs about "
        "2.5 GiB of decoder memory, more than the limit of 1.0 GiB "
        "(--max-decoder-memory)",
        "imageio: PATH: a progressive JPEG of 30000 x 30000 needs about "
        "1.7 GiB of decoder memory, more than the limit of 1.0 GiB "
        "(--max-decoder-memory)"};
    for (int k = 0; k < 3; k++) {
        const char *path = jpeg_claiming(dir, srcs[k], "claims-huge.jpg",
                                         30000, 30000);
        char what[96];
        snprintf(what, sizeof what, "%s claiming 30000 x 30000", srcs[k]);
        expect_refused(path, all, GV_ELIMIT, huge_want[k], what);
        unlink(path);
    }
    /* A byte between the start of image and the next marker: the native
     * reader does not take it, libjpeg (and so the module) skips it with
     * a warning; the loader checks its header all the same. */
    {
        size_t len;
        const char *src = jpeg_claiming(dir, "progressive.jpg",
                                        "claims-huge.jpg", 30000, 30000);
        uint8_t *p = test_read_file_found(src, &len);
        uint8_t *q = malloc(len + 1);
        memcpy(q, p, 2);
        q[2] = 0x00;
        memcpy(q + 3, p + 2, len - 2);
        const char *path = test_path_in(tmpdir, "stray-byte.jpg");
        test_write_file(path, q, len + 1);
        free(p);
        free(q);
        unlink(src);
        expect_refused(path, 1u << MODULE | 1u << LOADER, GV_ELIMIT,
                       huge_want[0], "progressive.jpg claiming 30000 x 30000 "
                       "with a stray byte after SOI");
        unlink(path);
    }
    /* 12000 x 12000 (412 MiB) under a 64 MiB limit; then the same
     * refusal by libjpeg's own limit alone (not the module: its libjpeg
     * has none). */
    const char *mid = jpeg_claiming(dir, "progressive.jpg", "claims-mid.jpg",
                                    12000, 12000);
    const char *mid_want = "imageio: PATH: a progressive JPEG of 12000 x "
                           "12000 needs about 412.0 MiB of decoder memory, "
                           "more than the limit of 64.0 MiB "
                           "(--max-decoder-memory)";
    decoder_bytes = 64u << 20;
    expect_refused(mid, all, GV_ELIMIT, mid_want, "12000 x 12000, 64 MiB");
    gv_native_jpeg_test_backstop_only(1);
    expect_refused(mid, 1u << NATIVE | 1u << LOADER, GV_ELIMIT, mid_want,
                   "12000 x 12000, 64 MiB, libjpeg's limit alone");
    gv_native_jpeg_test_backstop_only(0);
    decoder_bytes = 0;
    /* Within the default limit, but 863 bytes cannot code the first
     * scan's 3375000 blocks. */
    expect_refused(mid, all, GV_ECORRUPT, "imageio: PATH: a progressive JPEG "
                   "of 12000 x 12000 is truncated: its first scan codes "
                   "3375000 blocks, at least 421875 bytes, in a file of 863 "
                   "bytes", "12000 x 12000 in 863 bytes");
    unlink(mid);
    /* progressive.jpg: 72 blocks of 128 bytes (8 x 6 of Y, 4 x 3 of Cb
     * and of Cr).  Read at exactly that limit, refused one byte under;
     * a sequential single-scan file needs none. */
    expect_read_at_limit(dir, "progressive.jpg", 9216);
    const char *prog = test_path_in(dir, "progressive.jpg");
    decoder_bytes = 9215;
    expect_refused(prog, all, GV_ELIMIT, "imageio: PATH: a progressive JPEG "
                   "of 61 x 45 needs about 9.0 KiB of decoder memory, more "
                   "than the limit of 9.0 KiB (--max-decoder-memory)",
                   "progressive.jpg, 1 byte under its need");
    const char *const seq[3] = {"s420.jpg", "restart.jpg", "arithmetic.jpg"};
    expect_read_in_one_byte(dir, seq);
}

static void put_be(uint8_t *p, uint32_t v, int bytes)
{
    for (int i = 0; i < bytes; i++)
        p[i] = (uint8_t)(v >> 8 * (bytes - 1 - i));
}

/* tmpdir/out: a 4 x 4 RGB Photoshop file (raw, zero) whose thumbnail
 * resource (1036) holds the JPEG file `jpg` (psd_thumbnail.c gives the
 * layout). */
static const char *psd_with_thumbnail(const char *jpg, const char *out)
{
    size_t n;
    uint8_t *j = test_read_file_found(jpg, &n);
    size_t data = 28 + n + (n & 1), size = 26 + 4 + 4 + 12 + data + 4
                                           + 2 + 48;
    uint8_t *p = calloc(1, size), *q = p;
    memcpy(q, "8BPS", 4);
    put_be(q + 4, 1, 2);        /* version */
    put_be(q + 12, 3, 2);       /* channels */
    put_be(q + 14, 4, 4);       /* height */
    put_be(q + 18, 4, 4);       /* width */
    put_be(q + 22, 8, 2);       /* depth */
    put_be(q + 24, 3, 2);       /* RGB */
    q += 26 + 4;                /* no colour mode data */
    put_be(q, (uint32_t)(12 + data), 4);
    memcpy(q + 4, "8BIM", 4);
    put_be(q + 8, 1036, 2);     /* then an empty name, 2 bytes */
    put_be(q + 12, (uint32_t)(28 + n), 4);
    q += 16;
    put_be(q, 1, 4);            /* JPEG RGB, 61 x 45 (the header's claim) */
    put_be(q + 4, 61, 4);
    put_be(q + 8, 45, 4);
    put_be(q + 12, 184, 4);     /* row bytes, padded to 4 */
    put_be(q + 16, 184 * 45, 4);
    put_be(q + 20, (uint32_t)n, 4);
    put_be(q + 24, 24, 2);
    put_be(q + 26, 1, 2);
    memcpy(q + 28, j, n);
    /* then no layers (4 zero bytes), raw image data (2 zero bytes), and
     * 48 zero bytes of pixels */
    const char *path = test_path_in(tmpdir, out);
    test_write_file(path, p, size);
    free(p);
    free(j);
    return path;
}

/* tmpdir/out: a copy of the PNG dir/name whose IHDR (the first chunk,
 * its data at 16..28, its CRC at 29..32) claims w x h of `depth` bits in
 * colour type `color`, interlaced or not, with the CRC recomputed. */
static const char *png_claiming(const char *dir, const char *name,
                                const char *out, uint32_t w, uint32_t h,
                                int depth, int color, int interlaced)
{
    size_t len;
    uint8_t *p = test_read_file_found(test_path_in(dir, name), &len);
    if (len < 33 || memcmp(p + 12, "IHDR", 4) != 0)
        fail("%s: no IHDR first", name);
    const uint8_t wh[8] = {w >> 24, w >> 16, w >> 8, w, h >> 24, h >> 16,
                           h >> 8, h};
    memcpy(p + 16, wh, 8);
    p[24] = (uint8_t)depth;
    p[25] = (uint8_t)color;
    p[28] = (uint8_t)interlaced;
    uint32_t crc = gv_crc32(0, p + 12, 17);
    const uint8_t c[4] = {crc >> 24, crc >> 16, crc >> 8, crc};
    memcpy(p + 29, c, 4);
    const char *path = test_path_in(tmpdir, out);
    test_write_file(path, p, len);
    free(p);
    return path;
}

/* The decoder memory limit for interlaced PNGs (native_png.c, "Memory"):
 * every reader holds one whole while it is read, so one claiming a size
 * it cannot hold is refused from its header, whichever reader would read
 * it, before that buffer is allocated (the module zeroes it: 549 MiB for
 * the 12000 x 12000 claim below); the need counts the channels libpng
 * delivers (a tRNS chunk's alpha), the limit is exact, and PNGs read a
 * row at a time are not affected. */
static void test_png_decoder_memory(const char *dir)
{
    const unsigned all = 1u << MODULE | 1u << NATIVE | 1u << LOADER;
    /* 12000 x 12000 RGBA of 16 bits under the default limit, 1 GiB:
     * 12000 rows of 96000 bytes and a pointer. */
    const char *huge = png_claiming(dir, "rgb8-interlaced.png",
                                    "claims-huge.png", 12000, 12000, 16, 6,
                                    1);
    expect_refused(huge, all, GV_ELIMIT, "imageio: PATH: an interlaced PNG "
                   "of 12000 x 12000 needs about 1.1 GiB of decoder memory, "
                   "more than the limit of 1.0 GiB (--max-decoder-memory)",
                   "an interlaced RGBA16 PNG claiming 12000 x 12000");
    unlink(huge);
    /* A palette with a tRNS chunk claiming 12000 x 12000 is read as RGBA:
     * 549.4 MiB (as RGB it would be 412.1) under a 500 MiB limit. */
    const char *trns = png_claiming(dir, "palette8-trns.png",
                                    "claims-trns.png", 12000, 12000, 8, 3,
                                    1);
    decoder_bytes = 500u << 20;
    expect_refused(trns, all, GV_ELIMIT, "imageio: PATH: an interlaced PNG "
                   "of 12000 x 12000 needs about 549.4 MiB of decoder "
                   "memory, more than the limit of 500.0 MiB "
                   "(--max-decoder-memory)", "an interlaced palette PNG "
                   "with tRNS claiming 12000 x 12000, 500 MiB");
    unlink(trns);
    /* Not interlaced, the same claim is not held whole: it opens, and
     * its first row fails on the missing data. */
    const char *flat = png_claiming(dir, "palette8-trns.png",
                                    "claims-flat.png", 12000, 12000, 8, 3,
                                    0);
    decoder_bytes = 1;
    uint8_t *row = malloc(12000 * 4);
    if (!row)
        fail("out of memory");
    for (int how = MODULE; how <= LOADER; how++) {
        struct any a;
        struct gv_image_info info;
        struct gv_error e = {0}, re = {0};
        gv_error_clear(&re);
        int opened = any_open(&a, (enum how)how, flat, 1ull << 32, &info,
                              &e) == 0;
        int failed = opened && info.width == 12000 && info.channels == 4
                     && any_read(&a, 1, row, &re) != 0
                     && re.code == GV_ECORRUPT;
        if (opened)
            any_close(&a);
        check(failed, "a non-interlaced PNG claiming 12000 x 12000, %s: "
              "opens under a limit of 1 byte, then fails on its data (%s%s)",
              how_name[how], opened ? "" : e.text, re.text);
    }
    free(row);
    unlink(flat);
    /* rgb8-interlaced.png: 23 rows of 37 x 3 bytes and a pointer, 2737
     * bytes.  Read at exactly that limit, refused one byte under. */
    const unsigned need = 23 * (37 * 3 + (unsigned)sizeof(void *));
    expect_read_at_limit(dir, "rgb8-interlaced.png", need);
    const char *il = test_path_in(dir, "rgb8-interlaced.png");
    decoder_bytes = need - 1;
    expect_refused(il, all, GV_ELIMIT, "imageio: PATH: an interlaced PNG of "
                   "37 x 23 needs about 2.7 KiB of decoder memory, more than "
                   "the limit of 2.7 KiB (--max-decoder-memory)",
                   "rgb8-interlaced.png, 1 byte under its need");
    /* Read a row at a time: no limit applies. */
    const char *const rows[3] = {"rgb8.png", "rgba16.png",
                                 "palette8-trns.png"};
    expect_read_in_one_byte(dir, rows);
}

/* A Photoshop file's JPEG thumbnail, which OpenImageIO decodes whole
 * while it opens the file (psd_thumbnail.c): one claiming 30000 x 30000
 * is refused before the module opens the file; a real one is read. */
static void test_psd_thumbnail(const char *dir)
{
    const char *jpg = jpeg_claiming(dir, "progressive.jpg",
                                    "claims-huge.jpg", 30000, 30000);
    const char *bad = psd_with_thumbnail(jpg, "thumb-huge.psd");
    unlink(jpg);
    expect_refused(bad, 1u << MODULE | 1u << LOADER, GV_ELIMIT,
                   "imageio: PATH: its thumbnail, a JPEG of 30000 x 30000, "
                   "needs about 5.0 GiB of decoder memory, more than the "
                   "limit of 1.0 GiB (--max-decoder-memory)",
                   "PSD whose thumbnail claims 30000 x 30000");
    unlink(bad);
    const char *good = psd_with_thumbnail(test_path_in(dir, "progressive.jpg"),
                                          "thumb.psd");
    struct result r = read_file(LOADER, good, 1ull << 32);
    check(r.opened && r.read_ok && r.info.width == 4 && r.info.height == 4,
          "PSD with a 61 x 45 thumbnail: read (%s%s)", r.open_err.text,
          r.read_err.text);
    result_free(&r);
    /* 61 x 45 x 3 bytes of pixels and 9216 of coefficients */
    decoder_bytes = 17450;
    expect_refused(good, 1u << LOADER, GV_ELIMIT, "imageio: PATH: its "
                   "thumbnail, a JPEG of 61 x 45, needs about 17.0 KiB of "
                   "decoder memory, more than the limit of 17.0 KiB "
                   "(--max-decoder-memory)", "PSD, 1 byte under its "
                   "thumbnail's need");
    decoder_bytes = 17451;
    r = read_file(LOADER, good, 1ull << 32);
    check(r.opened && r.read_ok, "PSD, at exactly its thumbnail's need: "
          "read (%s%s)", r.open_err.text, r.read_err.text);
    result_free(&r);
    decoder_bytes = 0;
    unlink(good);
}

/* Little-endian classic TIFF: the first directory's entry for `tag`, or
 * NULL. */
static uint8_t *tiff_entry(uint8_t *p, size_t len, uint16_t tag)
{
    if (len < 8 || p[0] != 'I')
        return NULL;
    size_t ifd = p[4] | p[5] << 8 | p[6] << 16 | (size_t)p[7] << 24;
    if (ifd + 2 > len)
        return NULL;
    size_t n = p[ifd] | p[ifd + 1] << 8;
    for (size_t i = 0; i < n && ifd + 2 + 12 * (i + 1) <= len; i++) {
        uint8_t *e = p + ifd + 2 + 12 * i;
        if ((e[0] | e[1] << 8) == tag)
            return e;
    }
    return NULL;
}

/* Make an entry a LONG of one value. */
static void tiff_set_long(uint8_t *e, uint32_t v)
{
    e[2] = 4, e[3] = 0;                        /* LONG */
    e[4] = 1, e[5] = e[6] = e[7] = 0;          /* count 1 */
    e[8] = (uint8_t)v, e[9] = (uint8_t)(v >> 8);
    e[10] = (uint8_t)(v >> 16), e[11] = (uint8_t)(v >> 24);
}

/* Hostile TIFF headers: more pixels than max_pixels (refused as the
 * module refuses it), tiles claimed enormous (declined before anything is
 * allocated: the module says what it says), tile offsets past the end of
 * the file (the same failure as the module). */
static void test_tiff_hostile(const char *dir)
{
    size_t len;
    uint8_t *p = test_read_file_found(test_path_in(dir, "rgb8-lzw-tiled.tif"), &len);
    uint8_t *q = malloc(len);
    /* width and height 1000000 */
    memcpy(q, p, len);
    uint8_t *ew = tiff_entry(q, len, 256), *eh = tiff_entry(q, len, 257);
    if (!ew || !eh)
        fail("rgb8-lzw-tiled.tif: no width or height entry");
    tiff_set_long(ew, 1000000);
    tiff_set_long(eh, 1000000);
    const char *huge = test_path_in(tmpdir, "huge.tif");
    test_write_file(huge, q, len);
    struct result m = read_file(MODULE, huge, 1u << 20);
    struct result n = read_file(NATIVE, huge, 1u << 20);
    struct result l = read_file(LOADER, huge, 1u << 20);
    check(!m.opened && !l.opened && l.open_err.code == m.open_err.code
              && strcmp(l.open_err.text, m.open_err.text) == 0,
          "TIFF claiming 1000000x1000000: refused as by the module (%s | %s)",
          l.open_err.text, m.open_err.text);
    check(!n.opened && (n.open_err.code == GV_OK
                        || n.open_err.code == GV_ELIMIT),
          "TIFF claiming 1000000x1000000: the native reader declines or "
          "refuses (%s)", n.open_err.text);
    result_free(&m);
    result_free(&n);
    result_free(&l);
    unlink(huge);
    /* In strips, 100000 x 100000 in one strip: a header libtiff reads
     * without complaint, refused by the pixel cap, with the module's code
     * and words. */
    free(p);
    p = test_read_file_found(test_path_in(dir, "gray8-none.tif"), &len);
    q = realloc(q, len);
    memcpy(q, p, len);
    ew = tiff_entry(q, len, 256), eh = tiff_entry(q, len, 257);
    uint8_t *er = tiff_entry(q, len, 278);
    if (!ew || !eh || !er)
        fail("gray8-none.tif: no width, height or rows per strip entry");
    tiff_set_long(ew, 100000);
    tiff_set_long(eh, 100000);
    tiff_set_long(er, 0xFFFFFFFFu);
    test_write_file(huge, q, len);
    m = read_file(MODULE, huge, 1u << 20);
    n = read_file(NATIVE, huge, 1u << 20);
    char want[4200];
    snprintf(want, sizeof want, "imageio: %s: image of 100000x100000 pixels "
             "exceeds the limit of 1048576 pixels", huge);
    check(!n.opened && n.open_err.code == GV_ELIMIT && !m.opened
              && m.open_err.code == GV_ELIMIT,
          "TIFF claiming 100000x100000 in one strip: GV_ELIMIT, as the "
          "module");
    check_str(n.open_err.text, want, "TIFF claiming 100000x100000: the "
              "module's message");
    check_str(m.open_err.text, want, "TIFF claiming 100000x100000: the "
              "module's own message");
    result_free(&m);
    result_free(&n);
    unlink(huge);
    free(p);
    p = test_read_file_found(test_path_in(dir, "rgb8-lzw-tiled.tif"), &len);
    q = realloc(q, len);
    /* tiles of 65536 x 65536, and of 65536 x 512 (a row of tiles would
     * take 96 MiB, thousands of times the rows it covers) */
    const uint32_t tiles[2][2] = {{65536, 65536}, {65536, 512}};
    for (int k = 0; k < 2; k++) {
        memcpy(q, p, len);
        uint8_t *tw = tiff_entry(q, len, 322), *th = tiff_entry(q, len, 323);
        if (!tw || !th)
            fail("rgb8-lzw-tiled.tif: no tile size entries");
        tiff_set_long(tw, tiles[k][0]);
        tiff_set_long(th, tiles[k][1]);
        const char *path = test_path_in(tmpdir, "bigtile.tif");
        test_write_file(path, q, len);
        n = read_file(NATIVE, path, 1ull << 32);
        check(!n.opened && n.open_err.code == GV_OK,
              "TIFF with %ux%u tiles: declined by the native reader",
              tiles[k][0], tiles[k][1]);
        result_free(&n);
        /* The module itself is not asked about the first: OpenImageIO
         * would allocate the 12 GiB tile. */
        char what[64];
        snprintf(what, sizeof what, "TIFF with %ux%u tiles", tiles[k][0],
                 tiles[k][1]);
        if (k > 0)
            compare_damaged(path, what);
        unlink(path);
    }
    /* tile offsets past the end: the first, then the last tile's */
    for (int k = 0; k < 2; k++) {
        memcpy(q, p, len);
        uint8_t *e = tiff_entry(q, len, 324);
        if (!e)
            fail("rgb8-lzw-tiled.tif: no tile offsets");
        size_t count = e[4] | e[5] << 8, at = e[8] | e[9] << 8
                                              | (size_t)e[10] << 16;
        size_t slot = at + 4 * (k == 0 ? 0 : count - 1);
        if (count < 2 || slot + 4 > len)
            fail("rgb8-lzw-tiled.tif: tile offsets not where expected");
        q[slot] = 0xF0, q[slot + 1] = 0xFF, q[slot + 2] = 0xFF;
        q[slot + 3] = 0x7F;
        const char *path = test_path_in(tmpdir, "faroff.tif");
        test_write_file(path, q, len);
        n = read_file(NATIVE, path, 1ull << 32);
        check(!n.opened ? n.open_err.code == GV_OK
                        : !n.read_ok && n.read_err.code == GV_ECORRUPT,
              "TIFF with the %s tile past the end: declined or GV_ECORRUPT "
              "(%s%s)", k == 0 ? "first" : "last", n.open_err.text,
              n.read_err.text);
        result_free(&n);
        compare_damaged(path, k == 0 ? "TIFF, first tile past the end"
                                     : "TIFF, last tile past the end");
        unlink(path);
    }
    free(q);
    free(p);
}

/* Reads past the last row, and after an error, fail as in the module. */
static void test_misuse(const char *dir)
{
    const char *files[] = {"s444.jpg", "gray16.png", "rgb8-lzw-tiled.tif"};
    for (int k = 0; k < 3; k++) {
        const char *path = test_path_in(dir, files[k]);
        char got[2][2][400];
        int rc[2][2];
        for (int how = 0; how < 2; how++) {
            struct any a;
            struct gv_image_info info;
            struct gv_error err = {0};
            if (any_open(&a, how == 0 ? MODULE : NATIVE, path, 1ull << 32,
                         &info, &err) != 0)
                fail("%s: %s", path, err.text);
            size_t row = (size_t)info.width * info.channels
                         * sample_bytes(info.sample);
            uint8_t *buf = malloc(row * (info.height + 1));
            rc[how][0] = any_read(&a, info.height + 1, buf, &err);
            snprintf(got[how][0], sizeof got[how][0], "%d %s", (int)err.code,
                     err.text);
            rc[how][1] = any_read(&a, info.height, buf, &err);
            any_close(&a);
            free(buf);
        }
        check(rc[0][0] == -1 && rc[1][0] == -1
                  && strcmp(got[0][0], got[1][0]) == 0,
              "%s: a read past the last row fails as in the module (%s)",
              files[k], got[1][0]);
        check(rc[0][1] == 0 && rc[1][1] == 0,
              "%s: after a refused read, the whole image still reads",
              files[k]);
    }
}

/* A FIFO named like a JPEG or PNG: refused as the module refuses it,
 * without waiting for a writer (the test would hang). */
static void test_fifo(void)
{
    const char *names[] = {"fifo.jpg", "fifo.png", "fifo.tif"};
    for (int k = 0; k < 3; k++) {
        const char *path = test_path_in(tmpdir, names[k]);
        if (mkfifo(path, 0600) != 0)
            fail("mkfifo %s: %s", path, strerror(errno));
        struct result l = read_file(LOADER, path, 1u << 20);
        char want[4200];
        snprintf(want, sizeof want, "imageio: %s: not a regular file", path);
        check(!l.opened && l.open_err.code == GV_EINVAL,
              "%s: refused with GV_EINVAL", names[k]);
        check_str(l.open_err.text, want, "%s: the module's message",
                  names[k]);
        result_free(&l);
        unlink(path);
    }
}

/* In a child without the module: JPEG and PNG read, declined files fail
 * with the module's "cannot load" message.  Run before the parent loads
 * the module. */
static void test_without_module(const char *dir)
{
    pid_t pid = fork();
    if (pid < 0)
        fail("fork: %s", strerror(errno));
    if (pid == 0) {
        setenv("GV_OIIO_MODULE", "/nonexistent/gigaview-oiio.so", 1);
        unsetenv("GIGAVIEW_NATIVE_READERS");
        int bits = 0;
        struct result r = read_file(LOADER, test_path_in(dir, "s420.jpg"), 1u << 20);
        bits |= r.opened && r.read_ok ? 1 : 0;
        result_free(&r);
        r = read_file(LOADER, test_path_in(dir, "rgba16.png"), 1u << 20);
        bits |= r.opened && r.read_ok ? 2 : 0;
        result_free(&r);
        r = read_file(LOADER, test_path_in(dir, "cmyk.jpg"), 1u << 20);
        bits |= !r.opened && strstr(r.open_err.text, "cannot load the "
                                    "OpenImageIO module") ? 4 : 0;
        result_free(&r);
        r = read_file(LOADER, test_path_in(dir, "rgb8-interlaced.png"), 1u << 20);
        bits |= r.opened && r.read_ok ? 8 : 0;
        result_free(&r);
        r = read_file(LOADER, test_path_in(dir, "rgb16-be-lzw-tiled.tif"), 1u << 20);
        bits |= r.opened && r.read_ok ? 32 : 0;
        result_free(&r);
        r = read_file(LOADER, test_path_in(dir, "palette8-declined.tif"), 1u << 20);
        bits |= !r.opened && strstr(r.open_err.text, "cannot load the "
                                    "OpenImageIO module") ? 64 : 0;
        result_free(&r);
        /* a damaged header: IHDR's CRC */
        size_t len;
        uint8_t *p = test_read_file_found(test_path_in(dir, "rgb8.png"), &len);
        p[30] ^= 0x55;
        const char *bad = test_path_in(tmpdir, "bad-ihdr.png");
        test_write_file(bad, p, len);
        free(p);
        r = read_file(LOADER, bad, 1u << 20);
        bits |= !r.opened && strstr(r.open_err.text, "cannot load the "
                                    "OpenImageIO module") ? 16 : 0;
        result_free(&r);
        unlink(bad);
        _exit(bits);
    }
    int st = 0;
    if (waitpid(pid, &st, 0) != pid)
        fail("waitpid: %s", strerror(errno));
    int bits = WIFEXITED(st) ? WEXITSTATUS(st) : 0;
    check(bits & 1, "without the module: a JPEG opens and reads");
    check(bits & 2, "without the module: a PNG opens and reads");
    check(bits & 4, "without the module: a CMYK JPEG is declined to it");
    check(bits & 8, "without the module: an interlaced PNG opens and reads");
    check(bits & 16, "without the module: a PNG with a damaged header is "
          "declined to it");
    check(bits & 32, "without the module: a tiled 16-bit TIFF opens and "
          "reads");
    check(bits & 64, "without the module: a palette TIFF is declined to it");
}

int main(void)
{
    /* Under valgrind (make check VALGRIND=1), libjpeg-turbo's C code
     * instead of its SIMD code: valgrind takes some SIMD lanes of the
     * 1x2-subsampled file's last column for undefined (the padding they
     * share a vector with), though its bytes are the C code's and do not
     * change with MALLOC_PERTURB_.  Both sides of every comparison use the
     * same libjpeg, so they stay comparable. */
    const char *vg = getenv("VALGRIND");
    under_valgrind = vg && *vg && strcmp(vg, "0") != 0;
    if (under_valgrind)
        setenv("JSIMD_FORCENONE", "1", 1);
    datadir = test_data_dir_found();
    test_tmpdir_new(tmpdir, sizeof tmpdir, "gv-test-native");
    char native[4096];
    snprintf(native, sizeof native, "%s/native", datadir);

    test_without_module(native);
    /* libtiff opened by the native reader before the module brings it in
     * as one of OpenImageIO's libraries, as in `gigaview encode`: dlopen
     * of a library another dlopen loaded as a dependency leaves glibc
     * 2.36 with an l_initfini block valgrind calls definitely lost. */
    struct result first = read_file(NATIVE, test_path_in(native, "gray8-none.tif"),
                                    1u << 20);
    check(first.opened && first.read_ok, "a TIFF read natively before the "
          "module is loaded");
    result_free(&first);
    compare_dir(datadir);
    compare_dir(native);
    test_negative_controls(native);
    test_truncated(native);
    test_corrupt(native);
    test_huge(native);
    test_decoder_memory(native);
    test_png_decoder_memory(native);
    test_psd_thumbnail(native);
    test_tiff_hostile(native);
    test_misuse(native);
    test_fifo();

    test_tmpdir_free(tmpdir);
    return tap_done();
}
