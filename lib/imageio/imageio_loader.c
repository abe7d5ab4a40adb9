/*
 * imageio_loader.c - the functions of imageio.h, served by the OpenImageIO
 * module (gigaview-oiio.so, built from imageio.cpp), which this file opens
 * with dlopen the first time a program reads or writes an image file.
 *
 * Why: OpenImageIO needs some 260 shared libraries, and loading and
 * relocating them took about 0.2 s of every gigaview process's start on
 * the benchmark machine (perf: 71 % of `gigaview encode` of a 32 x 8
 * image in the dynamic linker), longer than `vips dzsave` takes for a
 * whole 8-megapixel photograph.  Processes that never touch an image file
 * (gigaview info, refused command lines, synthetic inputs, gigaviewd until
 * its first image output) now skip it.
 *
 * Where the module is looked for: only $GV_OIIO_MODULE when it is set;
 * else beside the executable (a build tree's gigaview and gigaviewd), in
 * its parent and grandparent directories (a build tree's tests/, bench/
 * and tests/fuzz/ programs), in ../lib/gigaview beside it (an installed
 * tree moved elsewhere, or staged with DESTDIR), and in the configured
 * PKGLIBDIR.  One found beside the program is taken only if it and its
 * directory belong to root or to the user and are not writable by all.
 * A module that cannot be opened, or whose table is of another version,
 * makes every call fail with GV_EFORMAT and one line that says where it
 * looked.
 *
 * JPEG, PNG and TIFF input skips the module: gv_image_open looks at the
 * file's first bytes and offers a JPEG to native_jpeg.c (libjpeg-turbo),
 * a PNG to native_png.c (libpng) and a TIFF or BigTIFF to native_tiff.c
 * (libtiff), which deliver exactly the module's info and samples for the
 * variants they accept and decline the rest (CMYK and 12-bit JPEG,
 * palette, alpha, float or JPEG-compressed TIFF, damaged headers...),
 * which then go to the module as before.  struct gv_image_in is a
 * tagged handle over any of them.  With GIGAVIEW_NATIVE_READERS=0 in the
 * environment every file goes to the module (tests compare the two; the
 * bench measures both); a JPEG's header is still checked first by
 * native_jpeg.c against the limits (max_pixels and the decoder memory of
 * a progressive JPEG), which OpenImageIO's reader would only apply after
 * allocating, and so are a PNG's (native_png.c: an interlaced one is
 * held whole) and a Photoshop file's thumbnail (psd_thumbnail.c).  A
 * TIFF's decoder memory (tiff_limits.c: a row of tiles, the RGBA image
 * of OpenImageIO's RGBA interface, a progressive JPEG strip's
 * coefficients) is checked from its first directory before the module
 * opens it, and one native_tiff.c took is checked after its open (which
 * reads the header only) against its strip too: a file whose strip
 * passes the limit goes to the module, which reads a strip a row at a
 * time.
 * Whole-slide images and georeferenced rasters go, before any of these,
 * to OpenSlide (slide_openslide.c) and GDAL (raster_gdal.c) where the
 * build has them: a TIFF whose first directory carries a scanner's mark
 * or GeoTIFF tags (tiff_sniff.c), a JPEG 2000, or a file named as a
 * MIRAX, VMS or Sakura slide is offered to them, and what they decline
 * goes on as above.  GIGAVIEW_NATIVE_READERS does not change this.
 * Writing goes through the module, but for gv_image_encode's JPEG
 * (native_jpeg_write.c) and WebP (native_webp_write.c), gv_image_encode's
 * and gv_image_encode_typed's
 * PNG of 8 or 16-bit samples (native_png_write.c), and a PNG file that
 * gv_image_write or gv_image_write_typed writes: the module's very bytes,
 * with no module to load, so that a server's first JPEG, PNG or WebP answer
 * does not wait for OpenImageIO, nor `gigaview render -o view.png`;
 * GIGAVIEW_NATIVE_WRITERS=0 sends those to the module too (tests compare
 * the two).
 */
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.h"
#include "base/atomic_file.h"
#include "imageio/imageio.h"
#include "imageio/imageio_module.h"
#include "imageio/native_file.h"
#include "imageio/native_jpeg.h"
#include "imageio/native_jpeg_write.h"
#include "imageio/native_png_write.h"
#include "imageio/native_webp_write.h"
#include "imageio/output_format.h"
#include "imageio/native_png.h"
#include "imageio/native_tiff.h"
#include "imageio/ome_tiff.h"
#include "imageio/psd_thumbnail.h"
#include "imageio/tiff_limits.h"
#include "imageio/tiff_sniff.h"
#ifdef GV_HAVE_OPENSLIDE
#include "imageio/slide_openslide.h"
#endif
#ifdef GV_HAVE_GDAL
#include "imageio/raster_gdal.h"
#endif

#ifndef PKGLIBDIR
#define PKGLIBDIR "/usr/local/lib/gigaview"
#endif

/* RTLD_DEEPBIND puts the module's own libraries first when their
 * references are resolved: OpenImageIO's some 260 libraries find one
 * another without first searching every library of the program (measured:
 * `gigaview encode` of a 1100 x 700 JPEG 458 ms without it, 362 with it,
 * 387 with OpenImageIO linked into the program).  AddressSanitizer refuses
 * RTLD_DEEPBIND, so sanitizer builds go without. */
#if defined(__SANITIZE_ADDRESS__)
#define GV_DEEPBIND 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GV_DEEPBIND 0
#endif
#endif
#ifndef GV_DEEPBIND
#define GV_DEEPBIND RTLD_DEEPBIND
#endif

static pthread_once_t once = PTHREAD_ONCE_INIT;
static const struct gv_imageio_module *module;
static char why[PATH_MAX + 256];   /* when module is NULL */

/* Whether a module found by searching may be loaded: the file and its
 * directory owned by root or by this user and not writable by all, so
 * that a build tree under a shared directory such as /tmp cannot be made
 * to load a module someone else put there. */
static int trusted(const char *path)
{
    char dir[PATH_MAX + 64];
    if ((size_t)snprintf(dir, sizeof dir, "%s", path) >= sizeof dir)
        return 0;
    char *slash = strrchr(dir, '/');
    if (!slash)
        return 0;
    *slash = '\0';
    struct stat f, d;
    if (stat(path, &f) < 0 || stat(dir[0] ? dir : "/", &d) < 0)
        return 0;
    const uid_t me = geteuid();
    return (f.st_uid == 0 || f.st_uid == me) && (d.st_uid == 0 || d.st_uid == me) &&
           !(f.st_mode & S_IWOTH) && !(d.st_mode & S_IWOTH);
}

/* Try one path; 1 when the module is loaded. */
static int try_path(const char *path)
{
    void *h = dlopen(path, RTLD_LAZY | RTLD_LOCAL | GV_DEEPBIND);
    if (!h) {
        snprintf(why, sizeof why, "%s", dlerror());
        return 0;
    }
    const struct gv_imageio_module *m = dlsym(h, GV_IMAGEIO_MODULE_SYMBOL);
    if (!m || m->abi != GV_IMAGEIO_MODULE_ABI) {
        snprintf(why, sizeof why, "%s: not a gigaview %d OpenImageIO module",
                 path, GV_IMAGEIO_MODULE_ABI);
        dlclose(h);
        return 0;
    }
    module = m;   /* kept open for the life of the process */
    return 1;
}

static void load(void)
{
    const char *env = getenv("GV_OIIO_MODULE");
    if (env && *env) {
        try_path(env);
        return;
    }
    char exe[PATH_MAX], path[PATH_MAX + 64];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        char *slash = strrchr(exe, '/');
        if (slash)
            *slash = '\0';
        static const char *const rel[] = {"", "/..", "/../..",
                                          "/../lib/gigaview"};
        for (size_t k = 0; k < sizeof rel / sizeof rel[0]; k++) {
            snprintf(path, sizeof path, "%s%s/%s", exe, rel[k],
                     GV_IMAGEIO_MODULE_FILE);
            if (trusted(path) && try_path(path))   /* trusted: it exists */
                return;
        }
    }
    snprintf(path, sizeof path, "%s/%s", PKGLIBDIR, GV_IMAGEIO_MODULE_FILE);
    if (access(path, F_OK) == 0) {
        try_path(path);
        return;
    }
    if (!why[0])
        snprintf(why, sizeof why, "no %s beside the program or in the two "
                 "directories above it (owned by root or this user, "
                 "not writable by all), nor in %s (set GV_OIIO_MODULE "
                 "to its path)",
                 GV_IMAGEIO_MODULE_FILE, PKGLIBDIR);
}

/* The module, or NULL with *err filled. */
static const struct gv_imageio_module *get(struct gv_error *err)
{
    pthread_once(&once, load);
    if (!module)
        gv_fail(err, GV_EFORMAT, "imageio: cannot load the OpenImageIO "
                "module: %s", why);
    return module;
}

/* Who reads an opened image. */
enum reader { BY_MODULE, BY_JPEG, BY_PNG, BY_TIFF, BY_OME, BY_SLIDE, BY_RASTER };

struct gv_image_in {
    enum reader by;
    union {
        struct gv_oiio_in *module;
        struct gv_native_jpeg *jpeg;
        struct gv_native_png *png;
        struct gv_native_tiff *tiff;
        struct gv_ome *ome;
#ifdef GV_HAVE_OPENSLIDE
        struct gv_slide *slide;
#endif
#ifdef GV_HAVE_GDAL
        struct gv_raster *raster;
#endif
    } u;
};

/* Whether native readers may be used: not with GIGAVIEW_NATIVE_READERS=0. */
static int native_allowed(void)
{
    const char *v = getenv("GIGAVIEW_NATIVE_READERS");
    return !(v && strcmp(v, "0") == 0);
}

/* Which domain reader a file wants, from its first bytes and name:
 * OpenSlide for a scanner's slide, GDAL for a georeferenced raster or a
 * JPEG 2000.  The library decides; these only say whom to ask. */
struct gv_domain {
    int slide, raster;
};

/* A slide format that is not a TIFF, by the name OpenSlide detects it
 * by: MIRAX (.mrxs), Hamamatsu VMS/VMU, Sakura (.svslide). */
static int slide_name(const char *path)
{
    const char *dot = strrchr(path, '.');
    static const char *const ext[] = {".mrxs", ".vms", ".vmu", ".svslide"};
    for (size_t i = 0; dot && i < sizeof ext / sizeof ext[0]; i++)
        if (strcasecmp(dot, ext[i]) == 0)
            return 1;
    return 0;
}

/* Offer the file to OpenSlide, then GDAL, as dom says.  1 when one took
 * it (in->by and in->u set), 0 when both declined, -1 when one refused
 * it (*err filled). */
static int open_domain(struct gv_image_in *in, const char *path,
                       const struct gv_domain *dom,
                       const struct gv_image_limits *lim,
                       struct gv_image_info *info, struct gv_error *err)
{
    struct gv_error e = {0};
    gv_error_clear(&e);
#ifdef GV_HAVE_OPENSLIDE
    if (dom->slide) {
        in->u.slide = gv_slide_open(path, lim, info, &e);
        if (in->u.slide) {
            in->by = BY_SLIDE;
            return 1;
        }
        if (e.code != GV_OK)
            goto refused;
    }
#endif
#ifdef GV_HAVE_GDAL
    if (dom->raster) {
        in->u.raster = gv_raster_open(path, lim, info, &e);
        if (in->u.raster) {
            in->by = BY_RASTER;
            return 1;
        }
        if (e.code != GV_OK)
            goto refused;
    }
#endif
    (void)in, (void)path, (void)dom, (void)lim, (void)info, (void)err;
    return 0;
#if defined(GV_HAVE_OPENSLIDE) || defined(GV_HAVE_GDAL)
refused:
    if (err)
        *err = e;
    return -1;
#endif
}

/* The native reader for `path`'s first bytes, or BY_MODULE (also when it
 * is not a regular file or cannot be read: the module says why in its
 * words).  *soi: whether they are a JPEG's start of image, FF D8, as
 * libjpeg (which skips bytes between markers, with a warning) and so the
 * module take them even when the native reader does not.  *psd: whether
 * they are a Photoshop file's, whose thumbnail the module decodes. */
static enum reader sniff(const char *path, int *soi, int *psd,
                         struct gv_domain *dom)
{
    uint8_t head[12];
    *soi = *psd = 0;
    memset(dom, 0, sizeof *dom);
    FILE *f = gv_native_open_regular(path);
    if (!f)
        return BY_MODULE;
    size_t n = fread(head, 1, sizeof head, f);
    if (gv_native_tiff_sniff(head, n)) {
        struct gv_tiff_sniff t;
        gv_tiff_sniff(f, &t);
        dom->slide = t.slide;
        dom->raster = t.geo;
    }
    fclose(f);
    static const uint8_t jp2[12] = {0, 0, 0, 12, 'j', 'P', ' ', ' ',
                                    0x0d, 0x0a, 0x87, 0x0a};
    static const uint8_t j2k[4] = {0xFF, 0x4F, 0xFF, 0x51};
    if ((n == 12 && memcmp(head, jp2, 12) == 0) ||
        (n >= 4 && memcmp(head, j2k, 4) == 0))
        dom->raster = 1;
    dom->slide |= slide_name(path);
    *soi = n >= 2 && head[0] == 0xFF && head[1] == 0xD8;
    *psd = gv_psd_sniff(head, n);
    if (gv_native_jpeg_sniff(head, n))
        return BY_JPEG;
    if (gv_native_png_sniff(head, n))
        return BY_PNG;
    if (gv_native_tiff_sniff(head, n))
        return BY_TIFF;
    return BY_MODULE;
}

/* gv_image_open_limits but for the plane rule. */
static struct gv_image_in *open_any(const char *path, const struct gv_image_limits *lim,
                                    struct gv_image_info *info, struct gv_error *err)
{
    struct gv_image_in *in = calloc(1, sizeof *in);
    if (!in) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        return NULL;
    }
    int soi, psd;
    struct gv_domain dom;
    in->by = sniff(path, &soi, &psd, &dom);
    switch (open_domain(in, path, &dom, lim, info, err)) {
    case 1:
        return in;
    case -1:
        free(in);
        return NULL;
    default:
        break;
    }
    const int png = in->by == BY_PNG;   /* the PNG signature */
    const int tiff = in->by == BY_TIFF;   /* a TIFF's or BigTIFF's */
    if (!native_allowed())
        in->by = BY_MODULE;
    struct gv_error e = {0};
    gv_error_clear(&e);
    const void *native = NULL;   /* the native reader opened, if any */
    if (in->by == BY_JPEG)
        native = in->u.jpeg = gv_native_jpeg_open(path, lim, info, &e);
    else if (in->by == BY_PNG)
        native = in->u.png = gv_native_png_open(path, lim, info, &e);
    else if (in->by == BY_TIFF)
        native = in->u.tiff = gv_native_tiff_open(path, lim->max_pixels,
                                                  info, &e);
    /* A TIFF native_tiff.c takes, whose strip or row of tiles (allocated
     * at its first read: its open has read the header only) would pass
     * the decoder memory limit (tiff_limits.c), is declined unless it is
     * read where its rows lie (no such buffer at all): the
     * module's scanline reader holds a row of a strip, not the strip,
     * and its own check below still applies. */
    if (in->by == BY_TIFF && native && !gv_native_tiff_reads_raw(in->u.tiff)
        && gv_tiff_limits_check(path, lim, GV_TIFF_READ_STRIPS, &e) < 0) {
        gv_native_tiff_close(in->u.tiff);
        native = NULL;
        gv_error_clear(&e);
    }
    /* An OME-TIFF whose channels are pages: all of them, of one plane
     * (ome_tiff.h); a stack it refuses is refused. */
    if (in->by == BY_TIFF && native) {
        struct gv_ome *ome = gv_ome_take(path, in->u.tiff, lim, info, &e);
        if (ome) {
            in->by = BY_OME;
            in->u.ome = ome;
        } else if (e.code != GV_OK) {
            gv_native_tiff_close(in->u.tiff);
            if (err)
                *err = e;
            free(in);
            return NULL;
        }
    }
    if (native)
        return in;
    /* For the module, whose libjpeg takes no limit on its memory and
     * whose PNG reader allocates an interlaced image whole before
     * decoding it: the native reader's limits from the header (again,
     * for a JPEG it declined: it may have done so before reading the
     * header), a Photoshop file's thumbnail, and a TIFF's tiles, RGBA
     * image and JPEG coefficients (tiff_limits.c), before it opens the
     * file. */
    if (e.code == GV_OK && soi)
        gv_native_jpeg_check(path, lim, &e);
    else if (e.code == GV_OK && png)
        gv_native_png_check(path, lim, &e);
    else if (e.code == GV_OK && psd)
        gv_psd_thumbnail_check(path, lim, &e);
    else if (e.code == GV_OK && tiff)
        gv_tiff_limits_check(path, lim, GV_TIFF_READ_ROWS, &e);
    if (e.code != GV_OK) {   /* refused, not declined */
        if (err)
            *err = e;
        free(in);
        return NULL;
    }
    in->by = BY_MODULE;
    const struct gv_imageio_module *m = get(err);
    in->u.module = m ? m->open(path, lim->max_pixels, info, err) : NULL;
    if (!in->u.module) {
        free(in);
        return NULL;
    }
    return in;
}

struct gv_image_in *gv_image_open_limits(const char *path,
                                         const struct gv_image_limits *lim,
                                         struct gv_image_info *info,
                                         struct gv_error *err)
{
    struct gv_image_in *in = open_any(path, lim, info, err);
    if (in && lim->plane.set && in->by != BY_OME) {
        gv_image_close(in);
        gv_fail(err, GV_EINVAL, "imageio: %s: --plane picks a plane of an OME-TIFF "
                "stack, and this is not one", path);
        return NULL;
    }
    return in;
}

struct gv_image_in *gv_image_open(const char *path, uint64_t max_pixels,
                                  struct gv_image_info *info,
                                  struct gv_error *err)
{
    const struct gv_image_limits lim = {.max_pixels = max_pixels};
    return gv_image_open_limits(path, &lim, info, err);
}

int gv_image_read(struct gv_image_in *in, uint32_t rows, void *out,
                  struct gv_error *err)
{
    switch (in->by) {
    case BY_JPEG:
        return gv_native_jpeg_read(in->u.jpeg, rows, out, err);
    case BY_PNG:
        return gv_native_png_read(in->u.png, rows, out, err);
    case BY_TIFF:
        return gv_native_tiff_read(in->u.tiff, rows, out, err);
    case BY_OME:
        return gv_ome_read(in->u.ome, rows, out, err);
#ifdef GV_HAVE_OPENSLIDE
    case BY_SLIDE:
        return gv_slide_read(in->u.slide, rows, out, err);
#endif
#ifdef GV_HAVE_GDAL
    case BY_RASTER:
        return gv_raster_read(in->u.raster, rows, out, err);
#endif
    default:
        break;
    }
    /* An image was opened by the module, so it is loaded. */
    return module->read(in->u.module, rows, out, err);
}

struct gv_raw_regions *gv_image_raw_regions(struct gv_image_in *in,
                                            struct gv_error *err)
{
    gv_error_clear(err);
    return in->by == BY_TIFF ? gv_native_tiff_regions(in->u.tiff, err) : NULL;
}

int gv_image_reads_raw(const struct gv_image_in *in)
{
    return in->by == BY_TIFF && gv_native_tiff_reads_raw(in->u.tiff);
}

void gv_image_close(struct gv_image_in *in)
{
    if (!in)
        return;
    switch (in->by) {
    case BY_JPEG:
        gv_native_jpeg_close(in->u.jpeg);
        break;
    case BY_PNG:
        gv_native_png_close(in->u.png);
        break;
    case BY_TIFF:
        gv_native_tiff_close(in->u.tiff);
        break;
    case BY_OME:
        gv_ome_close(in->u.ome);
        break;
    case BY_MODULE:
        module->close(in->u.module);
        break;
#ifdef GV_HAVE_OPENSLIDE
    case BY_SLIDE:
        gv_slide_close(in->u.slide);
        break;
#endif
#ifdef GV_HAVE_GDAL
    case BY_RASTER:
        gv_raster_close(in->u.raster);
        break;
#endif
    default:
        break;
    }
    free(in);
}

const char *gv_image_meta(const struct gv_image_in *in)
{
    if (in->by == BY_OME)
        return gv_ome_meta(in->u.ome);
#ifdef GV_HAVE_OPENSLIDE
    if (in->by == BY_SLIDE)
        return gv_slide_meta(in->u.slide);
#endif
#ifdef GV_HAVE_GDAL
    if (in->by == BY_RASTER)
        return gv_raster_meta(in->u.raster);
#endif
    (void)in;
    return NULL;
}

/* Whether the native writers may write (JPEG, PNG): not with
 * GIGAVIEW_NATIVE_WRITERS=0. */
static int native_writer_allowed(void)
{
    const char *v = getenv("GIGAVIEW_NATIVE_WRITERS");
    return !(v && strcmp(v, "0") == 0);
}

/* Whether native_png_write.c writes this image in format f (a PNG of
 * samples it takes, native writers allowed) rather than the module. */
static int native_png(const struct gv_output_format *f, uint32_t width,
                      uint32_t height, int channels, enum gv_sample sample)
{
    return f && strcmp(f->name, "png") == 0 &&
           gv_native_png_encodes(width, height, channels, sample) &&
           native_writer_allowed();
}

/* A PNG that native_png_write.c takes, written as the module would
 * (encoded in memory, then published whole by gv_atomic_file_write):
 * 1 when written here, with 0 or -1 in *rc; 0 when the module is to
 * write it (another format, or a name the module refuses in its own
 * words). */
static int write_natively(const char *path, uint32_t width, uint32_t height,
                          int channels, enum gv_sample sample,
                          const void *pixels, int *rc, struct gv_error *err)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    if (!native_png(dot ? gv_output_format_for_extension(dot + 1) : NULL,
                    width, height, channels, sample))
        return 0;
    uint8_t *bytes = NULL;
    size_t len = 0;
    *rc = gv_native_png_encode(width, height, channels, sample, pixels, &bytes,
                               &len, err);
    if (*rc == 0)
        *rc = gv_atomic_file_write(path, bytes, len,
                                   &(struct gv_atomic_opts){.module = "imageio"},
                                   err);
    free(bytes);
    return 1;
}

int gv_image_write(const char *path, uint32_t width, uint32_t height,
                   int channels, const uint8_t *pixels, struct gv_error *err)
{
    int rc;
    if (write_natively(path, width, height, channels, GV_SAMPLE_U8, pixels,
                       &rc, err))
        return rc;
    const struct gv_imageio_module *m = get(err);
    return m ? m->write(path, width, height, channels, pixels, err) : -1;
}

int gv_image_encode(const char *format, uint32_t width, uint32_t height,
                    int channels, const uint8_t *pixels, int quality,
                    uint8_t **out, size_t *len, struct gv_error *err)
{
    const struct gv_output_format *f = gv_output_format_image(format);
    if (f && strcmp(f->name, "jpg") == 0 &&
        gv_native_jpeg_encodes(width, height, channels) &&
        native_writer_allowed())
        return gv_native_jpeg_encode(width, height, channels, pixels, quality,
                                     out, len, err);
    if (native_png(f, width, height, channels, GV_SAMPLE_U8))
        return gv_native_png_encode(width, height, channels, GV_SAMPLE_U8,
                                    pixels, out, len, err);
    if (f && strcmp(f->name, "webp") == 0 &&
        gv_native_webp_encodes(width, height, channels) &&
        native_writer_allowed())
        return gv_native_webp_encode(width, height, channels, pixels, quality,
                                     out, len, err);
    const struct gv_imageio_module *m = get(err);
    return m ? m->encode(format, width, height, channels, pixels, quality,
                         out, len, err) : -1;
}

int gv_image_write_typed(const char *path, uint32_t width, uint32_t height,
                         int channels, enum gv_sample sample,
                         const void *pixels, struct gv_error *err)
{
    int rc;
    if (write_natively(path, width, height, channels, sample, pixels, &rc,
                       err))
        return rc;
    const struct gv_imageio_module *m = get(err);
    return m ? m->write_typed(path, width, height, channels, sample, pixels,
                              err) : -1;
}

int gv_image_encode_typed(const char *format, uint32_t width, uint32_t height,
                          int channels, enum gv_sample sample,
                          const void *pixels, uint8_t **out, size_t *len,
                          struct gv_error *err)
{
    if (native_png(gv_output_format_image(format), width, height, channels,
                   sample))
        return gv_native_png_encode(width, height, channels, sample, pixels,
                                    out, len, err);
    const struct gv_imageio_module *m = get(err);
    return m ? m->encode_typed(format, width, height, channels, sample,
                               pixels, out, len, err) : -1;
}
