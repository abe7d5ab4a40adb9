/*
 * test_tiff_limits.c - a TIFF's decoder memory against the limit
 * (lib/imageio/tiff_limits.c), through gv_image_open_limits with the
 * native readers allowed (LOADER) and with every file sent to the
 * OpenImageIO module (MODULE, GIGAVIEW_NATIVE_READERS=0).
 *
 * The files are tests/data/native/limits (make-tiff-limits.py there) and
 * two of tests/data/native.  Checked:
 *  - real JPEG-compressed TIFFs (progressive in one strip, in a tile,
 *    with JPEGTables, in a big-endian BigTIFF; RGB progressive; a
 *    baseline one from tiffcp) read at exactly the bytes the top of
 *    tiff_limits.c counts for them and refused one byte under, in its
 *    words; the count written out here from the files' sizes and
 *    libjpeg's coefficient rule, not taken from the code under test;
 *  - a native TIFF in strips whose strip passes the limit is declined to
 *    the module (a child without the module sees it asked for), and read
 *    natively at its strip's size; a tiled one is refused by either
 *    reader one byte under its row of tiles;
 *  - headers of 1 to 2 KB claiming 15000 to 65536 pixels a side in one
 *    strip or tile (JPEG progressive and baseline, YCbCr, grey; a tile
 *    behind a duplicate tag, under StripOffsets, past a broken entry,
 *    behind offsets claiming more than the file, as libtiff reads them;
 *    a 1-bit tile, small stored, large delivered; RowsPerStrip far past
 *    the height) refused
 *    under the default limit in words naming --max-decoder-memory, and
 *    above max_pixels in its words; every cut of one of them fails to
 *    open, none crashes.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "test_env.h"
#include "util.h"
#include "imageio/imageio.h"

enum how { MODULE, LOADER };
static const char *const how_name[] = {"module", "loader"};

static char tmpdir[4096];

/* Open `path` one way under the limits, and read every row, one at a
 * time: 0 when opened and read, else -1 with *err filled. */
static int read_all(enum how how, const char *path, uint64_t max_pixels,
                    uint64_t decoder_bytes, struct gv_error *err)
{
    if (how == MODULE)
        setenv("GIGAVIEW_NATIVE_READERS", "0", 1);
    const struct gv_image_limits lim = {.max_pixels = max_pixels,
                                        .max_decoder_bytes = decoder_bytes};
    struct gv_image_info info;
    gv_error_clear(err);
    struct gv_image_in *in = gv_image_open_limits(path, &lim, &info, err);
    unsetenv("GIGAVIEW_NATIVE_READERS");
    if (!in)
        return -1;
    size_t row = (size_t)info.width * (size_t)info.channels
                 * (info.sample == GV_SAMPLE_U8 ? 1u : 2u);
    uint8_t *buf = malloc(row);   /* a row at a time: some claim 15000 */
    if (!buf)
        fail("out of memory");
    int rc = 0;
    for (uint32_t y = 0; y < info.height && rc == 0; y++)
        rc = gv_image_read(in, 1, buf, err);
    free(buf);
    gv_image_close(in);
    return rc;
}

/* `msg` with every "PATH" replaced by path. */
static const char *with_path(const char *msg, const char *path)
{
    static char out[1024];
    size_t n = 0;
    for (const char *p = msg; *p && n + 1 < sizeof out;) {
        if (strncmp(p, "PATH", 4) == 0) {
            n += (size_t)snprintf(out + n, sizeof out - n, "%s", path);
            p += 4;
        } else {
            out[n++] = *p++;
        }
        if (n >= sizeof out)
            n = sizeof out - 1;
    }
    out[n] = '\0';
    return out;
}

/* `path` refused both ways with GV_ELIMIT and exactly `msg`, while the
 * resident size rises by less than 48 MiB (the hostile files here took
 * 1.4 to 8.9 GB unprotected). */
static void expect_refused(const char *path, uint64_t max_pixels,
                           uint64_t decoder_bytes, const char *msg,
                           const char *what)
{
    for (int how = MODULE; how <= LOADER; how++) {
        struct gv_error e = {0};
        long long before = test_peak_reset() ? test_status_kb("VmRSS") : -1;
        int rc = read_all((enum how)how, path, max_pixels, decoder_bytes, &e);
        long long hwm = test_status_kb("VmHWM");
        const char *want = with_path(msg, path);
        check(rc < 0 && e.code == GV_ELIMIT && strcmp(e.text, want) == 0,
              "%s, %s: refused (got \"%s\")", what, how_name[how], e.text);
        if (before >= 0 && hwm >= 0)
            check((hwm - before) / 1024 < 48, "%s, %s: the resident size "
                  "rose by %lld MiB (< 48)", what, how_name[how],
                  (hwm - before) / 1024);
    }
}

/* `name` read both ways at exactly `need` bytes, refused one byte under
 * with `msg`. */
static void expect_exact(const char *dir, const char *name, uint64_t need,
                         const char *msg)
{
    const char *path = test_path_in(dir, name);
    for (int how = MODULE; how <= LOADER; how++) {
        struct gv_error e = {0};
        int rc = read_all((enum how)how, path, 1ull << 32, need, &e);
        check(rc == 0, "%s, %s: read at its need, %llu bytes (%s)", name,
              how_name[how], (unsigned long long)need, e.text);
    }
    char what[256];
    snprintf(what, sizeof what, "%s, 1 byte under its need", name);
    expect_refused(path, 1ull << 32, need - 1, msg, what);
}

/* Coefficient bytes of a 61 x 45 JPEG (libjpeg: blocks rounded up to the
 * sampling factors, 128 bytes each): 4:2:0, Y 8 x 6 blocks and Cb, Cr
 * 4 x 3 each; 4:4:4, 8 x 6 blocks for each of 3 components. */
#define COEF_420 ((8 * 6 + 2 * 4 * 3) * 128)
#define COEF_444 (3 * 8 * 6 * 128)

static void test_exact(const char *limits, const char *native)
{
    /* YCbCr: a strip of 45 rows of 61 x 3 bytes, the whole image as RGBA,
     * the progressive JPEG's coefficients: 28431 bytes. */
    const uint64_t ycc = 61 * 45 * 3 + 61 * 45 * 4 + COEF_420;
    const char *ycc_msg = "imageio: PATH: a TIFF of 61 x 45 needs about "
                          "27.8 KiB of decoder memory (a strip of 45 rows, "
                          "the whole image as RGBA, a progressive JPEG's "
                          "coefficients), more than the limit of 27.8 KiB "
                          "(--max-decoder-memory)";
    expect_exact(limits, "jpeg-progressive-61x45.tif", ycc, ycc_msg);
    expect_exact(limits, "jpeg-progressive-tables.tif", ycc, ycc_msg);
    expect_exact(limits, "jpeg-progressive-big.tif", ycc, ycc_msg);
    /* one 64 x 48 tile, whose JPEG claims the whole tile: Y 8 x 6
     * blocks, Cb and Cr 4 x 3 */
    expect_exact(limits, "jpeg-progressive-tiled.tif",
                 64 * 48 * 3 + 61 * 45 * 4 + (8 * 6 + 2 * 4 * 3) * 128,
                 "imageio: PATH: a TIFF of 61 x 45 needs about 28.7 KiB of "
                 "decoder memory (a row of tiles of 48 rows, the whole image "
                 "as RGBA, a progressive JPEG's coefficients), more than the "
                 "limit of 28.7 KiB (--max-decoder-memory)");
    /* RGB: read a row at a time, only the coefficients count */
    expect_exact(limits, "jpeg-rgb-progressive.tif", COEF_444,
                 "imageio: PATH: a TIFF of 61 x 45 needs about 18.0 KiB of "
                 "decoder memory (a progressive JPEG's coefficients), more "
                 "than the limit of 18.0 KiB (--max-decoder-memory)");
    /* tiffcp -c jpeg (baseline YCbCr, JPEGTables, strips of 16 rows): a
     * strip and the RGBA image, no coefficients */
    expect_exact(native, "rgb8-jpeg-declined.tif", 37 * 16 * 3 + 37 * 29 * 4,
                 "imageio: PATH: a TIFF of 37 x 29 needs about 5.9 KiB of "
                 "decoder memory (a strip of 16 rows, the whole image as "
                 "RGBA), more than the limit of 5.9 KiB "
                 "(--max-decoder-memory)");
    /* native, 16 x 16 tiles, 3 across: either reader holds a row of them */
    expect_exact(native, "rgb8-lzw-tiled.tif", 3 * 16 * 16 * 3,
                 "imageio: PATH: a TIFF of 37 x 29 needs about 2.2 KiB of "
                 "decoder memory (a row of tiles of 16 rows), more than the "
                 "limit of 2.2 KiB (--max-decoder-memory)");
}

/* rgb8-be-lzw-pred.tif (LZW strips of 4 rows of 37 x 3 bytes: 444):
 * read natively at 444, declined to the module at 443, which reads it a
 * row at a time.  rgb8-none-strips.tif (uncompressed strips of 555
 * bytes): read natively at 554 too, where its rows lie, with no strip
 * buffer to count (raw_regions.c).  In a child without the module, so
 * that the asking shows. */
static void test_native_declines(const char *native)
{
    const char *path = test_path_in(native, "rgb8-be-lzw-pred.tif");
    char raw[4200];
    snprintf(raw, sizeof raw, "%s", test_path_in(native, "rgb8-none-strips.tif"));
    pid_t pid = fork();
    if (pid < 0)
        fail("fork: %s", strerror(errno));
    if (pid == 0) {
        setenv("GV_OIIO_MODULE", "/nonexistent/gigaview-oiio.so", 1);
        struct gv_error e = {0};
        int bits = read_all(LOADER, path, 1ull << 32, 444, &e) == 0;
        bits |= read_all(LOADER, path, 1ull << 32, 443, &e) < 0
                        && strstr(e.text, "cannot load the OpenImageIO "
                                          "module")
                    ? 2 : 0;
        bits |= read_all(LOADER, raw, 1ull << 32, 554, &e) == 0 ? 4 : 0;
        _exit(bits);
    }
    int st = 0;
    if (waitpid(pid, &st, 0) != pid)
        fail("waitpid: %s", strerror(errno));
    int bits = WIFEXITED(st) ? WEXITSTATUS(st) : 0;
    check(bits & 1, "LZW strips of 444 bytes, limit 444: read natively");
    check(bits & 2, "LZW strips of 444 bytes, limit 443: declined to the module");
    check(bits & 4, "uncompressed strips of 555 bytes, limit 554: read "
          "natively, where the rows lie");
    struct gv_error e = {0};
    check(read_all(LOADER, path, 1ull << 32, 443, &e) == 0,
          "LZW strips of 444 bytes, limit 443: the module reads it (%s)",
          e.text);
}

static void test_hostile(const char *limits)
{
    static const struct {
        const char *name, *msg;
    } cases[] = {
        {"jpeg-progressive-claims-30000.tif",
         "imageio: PATH: a TIFF of 30000 x 30000 needs about 5.9 GiB of "
         "decoder memory (a strip of 30000 rows, the whole image as RGBA), "
         "more than the limit of 1.0 GiB (--max-decoder-memory)"},
        {"jpeg-baseline-claims-30000.tif",
         "imageio: PATH: a TIFF of 30000 x 30000 needs about 5.9 GiB of "
         "decoder memory (a strip of 30000 rows, the whole image as RGBA), "
         "more than the limit of 1.0 GiB (--max-decoder-memory)"},
        {"jpeg-progressive-claims-tile.tif",
         "imageio: PATH: a TIFF of 30016 x 30016 needs about 5.9 GiB of "
         "decoder memory (a row of tiles of 30016 rows, the whole image as "
         "RGBA), more than the limit of 1.0 GiB (--max-decoder-memory)"},
        {"jpeg-rgb-progressive-claims-15000.tif",
         "imageio: PATH: a TIFF of 15000 x 15000 needs about 1.3 GiB of "
         "decoder memory (a progressive JPEG's coefficients), more than the "
         "limit of 1.0 GiB (--max-decoder-memory)"},
        {"ycbcr-claims-30000.tif",
         "imageio: PATH: a TIFF of 30000 x 30000 needs about 5.9 GiB of "
         "decoder memory (a strip of 30000 rows, the whole image as RGBA), "
         "more than the limit of 1.0 GiB (--max-decoder-memory)"},
        {"gray-64x64-tile-65536.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 4.0 GiB of decoder "
         "memory (a row of tiles of 65536 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"jpeg-rps-claims.tif",
         "imageio: PATH: a TIFF of 61 x 45 needs about 186.7 GiB of decoder "
         "memory (a strip of 1095582055 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"gray-tile-duplicate.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 4.0 GiB of decoder "
         "memory (a row of tiles of 65536 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"gray-tile-strip-offsets.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 4.0 GiB of decoder "
         "memory (a row of tiles of 65536 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"gray-tile-long-offsets.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 4.0 GiB of decoder "
         "memory (a row of tiles of 65536 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"gray-tile-bad-entry.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 4.0 GiB of decoder "
         "memory (a row of tiles of 65536 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"bilevel-tile-40000.tif",
         "imageio: PATH: a TIFF of 64 x 64 needs about 1.5 GiB of decoder "
         "memory (a row of tiles of 40000 rows), more than the limit of 1.0 "
         "GiB (--max-decoder-memory)"},
        {"gray-claims-tile.tif",
         "imageio: PATH: a TIFF of 65536 x 65536 needs about 4.0 GiB of "
         "decoder memory (a row of tiles of 65536 rows), more than the limit "
         "of 1.0 GiB (--max-decoder-memory)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        expect_refused(test_path_in(limits, cases[i].name), 1ull << 40, 0,
                       cases[i].msg, cases[i].name);
    const char *huge = test_path_in(limits, "jpeg-progressive-claims-30000.tif");
    expect_refused(huge, 1000000, 0, "imageio: PATH: image of 30000x30000 "
                   "pixels exceeds the limit of 1000000 pixels",
                   "30000 x 30000 under max_pixels 10^6");
    /* cuts of the hostile RGB one, every 5th byte through its directory
     * and its JPEG's header, every 101st after: none opens, no crash */
    size_t len;
    uint8_t *p = test_read_file_found(test_path_in(limits,
                               "jpeg-rgb-progressive-claims-15000.tif"),
                       &len);
    const char *cut = test_path_in(tmpdir, "cut.tif");
    int opened = 0, quiet = 0, tries = 0;
    for (size_t n = 0; n < len; n += n < 700 ? 5 : 101, tries++) {
        test_write_file(cut, p, n);
        struct gv_error e = {0};
        if (read_all(LOADER, cut, 1ull << 40, 0, &e) == 0)
            opened++;
        else if (strncmp(e.text, "imageio: ", 9) != 0)
            quiet++;
    }
    free(p);
    unlink(cut);
    check(opened == 0 && quiet == 0, "%d cuts of a hostile RGB JPEG TIFF: "
          "none read (%d), each failure with an imageio: message (%d "
          "without)", tries, opened, quiet);
}

int main(void)
{
    const char *data = test_data_dir_found();
    test_tmpdir_new(tmpdir, sizeof tmpdir, "gv-test-tiff-limits");
    char native[4096], limits[4096];
    if ((size_t)snprintf(native, sizeof native, "%s/native", data)
            >= sizeof native
        || (size_t)snprintf(limits, sizeof limits, "%s/native/limits", data)
               >= sizeof limits)
        fail("path too long: %s", data);
    test_native_declines(native);   /* first: forks before the module loads */
    test_exact(limits, native);
    test_hostile(limits);
    test_tmpdir_free(tmpdir);
    return tap_done();
}
