/*
 * imageio.cpp - the extern "C" bridge over OpenImageIO 2.4: the only C++ in
 * gigaview.
 *
 * Design.  Each function is a thin wrapper that catches every C++
 * exception at the boundary and turns OIIO's error strings into a struct
 * gv_error that starts "imageio:" and names the file.  Reading is probe-then-read:
 * gv_image_open reads the header only (ImageInput::open), and
 * gv_image_read hands out scanlines strictly top to bottom, converted by
 * OIIO in type only (UINT8, UINT16 or FLOAT), never to another range.
 *
 *  - Integer files of 1..8 bits are delivered as U8 and of 9..16 bits as
 *    U16.  OIIO's API only knows full-range integers: its readers widen odd
 *    depths (1, 2, 4, 10, 12 bits) to the full range of the container and
 *    report the real depth in "oiio:BitsPerSample".  A U8 sample therefore
 *    always spans 0..255 (for 1..7-bit files that widening is exactly the
 *    255/(2^bits-1) scaling), while for 9..15-bit files this bridge undoes
 *    the widening, v = (v16 * (2^bits-1) + 32767) / 65535, which is exact
 *    because the widened codes are at least 2 apart: U16 samples are in
 *    the file's own units, 0..2^info->bits-1.  Half, float and double
 *    files are delivered as F32 with their values untouched (no
 *    clamping).  Signed integer and 32-bit integer samples are refused
 *    (GV_EFORMAT): the info struct has no way to tell a caller "F32, but
 *    integer-valued", and they do not occur in the images gigaview is
 *    meant for.
 *  - Tiled files (TIFF, EXR) are read one row of tiles at a time with
 *    read_tiles into a buffer of tile_height full rows, from which rows
 *    are then copied.  read_scanlines cannot be used on them: in OIIO
 *    2.4.7 it dies with SIGFPE (integer division by zero) on a tiled TIFF
 *    or EXR, and even where it works it would decode a whole tile row
 *    again for every call of a few rows.
 *  - Decoders report damaged data in different ways: libjpeg's "premature
 *    end of data" is only a warning, which OIIO's JPEG reader records as
 *    an error ("Premature end of JPEG file") while the read itself may
 *    succeed with filler data.  So has_error() is checked after every call
 *    and any recorded message fails the read.
 *  - Every buffer handed to a reader is zeroed first, because a reader
 *    may report success without writing every byte: the heap's old
 *    contents must never reach a store.  EXR is read through OpenEXRCore
 *    ("openexr:core"), since the C++ OpenEXR reader does exactly that on
 *    a damaged file (set_threads_once).
 *  - PNG input is asked for unassociated alpha ("oiio:UnassociatedAlpha"):
 *    gigaview drops alpha, and OIIO would otherwise premultiply colour by
 *    it.
 *  - Only the readers in accepted_formats are used (see there why).
 *  - OIIO's own thread pool is set to one thread once per process
 *    (attribute "threads"): gigaview runs its own workers, one decoder per
 *    input, and a second pool per process would oversubscribe the CPUs.
 *
 * Writing encodes the whole 8-bit image in memory (gv_image_encode) and
 * publishes the bytes through base/atomic_file.h: the image appears under
 * its name only when complete, replacing any file there, and a failure
 * leaves nothing behind.  JPEG and WebP are written at quality 90.
 *
 * Thread safety: distinct gv_image_in objects may be used from different
 * threads; one object by one thread at a time.
 *
 * This file is built as a module of its own, gigaview-oiio.so, which
 * imageio_loader.c opens the first time a program reads or writes an
 * image file: OpenImageIO and the libraries it needs then load only into
 * the processes that use them.  The module exports one table
 * (imageio_module.h).  JPEG, PNG and 8/16-bit grey or RGB TIFF input
 * mostly never reaches it: native_jpeg.c, native_png.c and native_tiff.c
 * read those with the same libraries and settings as OpenImageIO's
 * readers, so what this file does to samples
 * (types, the 8-bit rule, limits, messages) is what they must match
 * (tests/test_native_read.c).
 */
#include <cctype>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include "base/atomic_file.h"
#include "base/error.h"
/* The functions of imageio.h under module-private names: the program's own
 * gv_image_* are imageio_loader.c's, which call these through the table
 * at the end of this file. */
#define gv_image_open oiio_image_open
#define gv_image_read oiio_image_read
#define gv_image_close oiio_image_close
#define gv_image_write oiio_image_write
#define gv_image_encode oiio_image_encode
#define gv_image_write_typed oiio_image_write_typed
#define gv_image_encode_typed oiio_image_encode_typed
/* ...and its reading handle under the name imageio_module.h gives it. */
#define gv_image_in gv_oiio_in
#include "imageio/imageio.h"
#include "imageio/imageio_module.h"
#include "imageio/output_format.h"
#include "imageio/size_limit.h"

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

struct gv_image_in {
    std::unique_ptr<ImageInput> in;
    std::string path;
    TypeDesc type;             /* what reads deliver */
    size_t pixel_bytes;        /* channels * bytes per delivered sample */
    size_t row_bytes;          /* width * pixel_bytes */
    uint32_t height;
    uint32_t next_row;         /* next row to deliver, 0-based */
    uint32_t narrow_max;       /* 2^bits-1 for 9..15-bit files, else 0 */
    int nchannels;
    int x0, y0, z0;            /* data window origin */
    /* tiled files: one row of tiles, rows [buf_first, buf_first+buf_rows) */
    bool tiled;
    uint32_t tile_h;
    std::vector<unsigned char> buf;
    uint32_t buf_first, buf_rows;
    bool failed;               /* a decode error happened: no more reads */
};

static void set_threads_once()
{
    static std::once_flag once;
    std::call_once(once, [] {
        OIIO::attribute("threads", 1);
        /* EXR through the OpenEXRCore library, not the C++ one: on a
         * damaged zip-compressed file (corpus finding-exr-unwritten) the
         * C++ reader copies bytes its decompressor never wrote into the
         * pixels and reports success; Core reads the same file cleanly
         * (valgrind). */
        OIIO::attribute("openexr:core", 1);
    });
}

/* OIIO messages may span lines; keep the first one, trimmed, short. */
static std::string first_line(const std::string &s)
{
    size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos)
        return "unknown error";
    size_t e = s.find_first_of("\r\n", b);
    std::string r = s.substr(b, e == std::string::npos ? e : e - b);
    return r;
}

static int fail_msg(struct gv_error *err, enum gv_code code,
                    const std::string &path, const std::string &msg)
{
    return gv_fail(err, code, "imageio: %s: %s", path.c_str(),
                   first_line(msg).c_str());
}

/* Classify an OIIO read error: truncation and damaged data are
 * GV_ECORRUPT; everything a reader says is taken as data damage. */
static int fail_read(struct gv_error *err, struct gv_image_in *im,
                     const std::string &msg)
{
    im->failed = true;
    return fail_msg(err, GV_ECORRUPT, im->path, msg);
}

/* Decide the delivered type.  Returns 0 or -1 with *err filled. */
static int choose_type(const ImageSpec &spec, const std::string &path,
                       struct gv_image_info *info, TypeDesc *type,
                       struct gv_error *err)
{
    bool any_float = false, any_int = false;
    int maxbytes = 0;
    for (int c = 0; c < spec.nchannels; c++) {
        TypeDesc t = spec.channelformat(c);
        switch (t.basetype) {
        case TypeDesc::HALF:
        case TypeDesc::FLOAT:
        case TypeDesc::DOUBLE:
            any_float = true;
            break;
        case TypeDesc::UINT8:
        case TypeDesc::UINT16:
            any_int = true;
            break;
        default:
            return fail_msg(err, GV_EFORMAT, path,
                            std::string("unsupported sample type ")
                                + t.c_str()
                                + " (use unsigned 8/16-bit or float)");
        }
        if ((int)t.size() > maxbytes)
            maxbytes = (int)t.size();
    }
    if (any_float && any_int)
        return fail_msg(err, GV_EFORMAT, path,
                        "mixed integer and float channels are not supported");
    if (any_float) {
        info->sample = GV_SAMPLE_F32;
        info->bits = maxbytes * 8;
        *type = TypeDesc::FLOAT;
        return 0;
    }
    int bits = spec.get_int_attribute("oiio:BitsPerSample", maxbytes * 8);
    if (bits <= 0 || bits > maxbytes * 8)
        bits = maxbytes * 8;
    info->bits = bits;
    if (bits <= 8) {
        info->sample = GV_SAMPLE_U8;
        *type = TypeDesc::UINT8;
    } else {
        info->sample = GV_SAMPLE_U16;
        *type = TypeDesc::UINT16;
    }
    return 0;
}

/*
 * The readers gigaview accepts input from, by OpenImageIO format name:
 * the formats large images actually come in.  No other reader OpenImageIO
 * has is ever asked to open a file (choose_reader), because each is attack
 * surface that buys nothing here, and some are broken in OIIO 2.4.7 (found
 * by tests/fuzz/fuzz_imageio.c under valgrind; its corpus has a file of
 * each): the ICO reader writes past its buffer on an ordinary 17x13 RGBA
 * icon (corpus rgb-ico); the DPX reader runs strlen over header bytes it
 * never initialised (finding-dpx-strlen); the SGI reader reports success
 * on a damaged RLE file without filling OIIO's conversion buffer, whose
 * old heap bytes would become pixels (finding-sgi-unwritten).  Besides,
 * "null" fabricates images from the file name and "ffmpeg" opens video.
 */
static const char *const accepted_formats[] = {
    "tiff", "jpeg", "png", "openexr", "webp", "jpeg2000", "pnm", "bmp",
    "targa", "hdr", "psd", "fits", "gif",
};

static bool format_accepted(const char *name)
{
    for (const char *f : accepted_formats)
        if (strcmp(f, name) == 0)
            return true;
    return false;
}

static const char *accepted_list()
{
    static std::string list;
    static std::once_flag once;
    std::call_once(once, [] {
        for (const char *f : accepted_formats)
            list += (list.empty() ? "" : ", ") + std::string(f);
    });
    return list.c_str();
}

/* The OpenImageIO format whose reader claims `path`'s extension
 * (case-insensitive), or "" - from OIIO's "extension_list" attribute,
 * "fmt:ext,ext;fmt:ext...". */
static std::string format_of_extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash : path, '.');
    if (!dot || !dot[1])
        return "";
    std::string ext;
    for (const char *p = dot + 1; *p; p++)
        ext += (char)tolower((unsigned char)*p);
    std::string list;
    OIIO::getattribute("extension_list", list);
    size_t i = 0;
    while (i < list.size()) {
        size_t end = list.find(';', i);
        if (end == std::string::npos)
            end = list.size();
        std::string entry = list.substr(i, end - i);
        size_t colon = entry.find(':');
        if (colon != std::string::npos) {
            std::string exts = "," + entry.substr(colon + 1) + ",";
            if (exts.find("," + ext + ",") != std::string::npos)
                return entry.substr(0, colon);
        }
        i = end + 1;
    }
    return "";
}

/*
 * The reader for `path`, not yet opened.  Only readers in
 * accepted_formats are ever created, so no other reader sees a byte of
 * the file (OIIO's ImageInput::open, and create() for a file, would try
 * every reader it has, and a reader's valid_file() is often its open()).
 * First the reader of the file's extension, if accepted and it recognises
 * the file (valid_file); else the first accepted reader that recognises it
 * (a misnamed file); else the extension's reader all the same (formats
 * without a magic number, and its own message for a file that is not
 * one).  NULL with *err when no accepted reader will take the file.
 */
static std::unique_ptr<ImageInput> choose_reader(const char *path,
                                                 const ImageSpec *config,
                                                 struct gv_error *err)
{
    std::string fmt = format_of_extension(path);
    std::unique_ptr<ImageInput> by_ext;
    if (!fmt.empty() && format_accepted(fmt.c_str())) {
        by_ext = ImageInput::create(fmt, false, config);
        if (by_ext && by_ext->valid_file(path))
            return by_ext;
    }
    for (const char *f : accepted_formats) {
        if (fmt == f)
            continue;
        std::unique_ptr<ImageInput> c = ImageInput::create(f, false, config);
        if (c && c->valid_file(path))
            return c;
    }
    (void)OIIO::geterror(); /* what the probes left behind */
    if (by_ext)
        return by_ext;
    if (!fmt.empty())
        gv_fail(err, GV_EFORMAT, "imageio: %s: %s images are not accepted "
                "(accepted: %s)", path, fmt.c_str(), accepted_list());
    else
        gv_fail(err, GV_EFORMAT, "imageio: %s: not an image in an accepted "
                "format (%s)", path, accepted_list());
    return nullptr;
}

/* A regular, non-empty file at path, or -1 with *err filled. */
static int check_file(const char *path, struct gv_error *err)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        int e = errno;
        if (e == ENOENT || e == ENOTDIR)
            return gv_fail(err, GV_ENOTFOUND, "imageio: %s: no such file", path);
        return gv_fail_errno(err, e, "imageio: %s", path);
    }
    if (!S_ISREG(st.st_mode))
        return gv_fail(err, GV_EINVAL, "imageio: %s: not a regular file", path);
    if (st.st_size == 0)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: empty file", path);
    return 0;
}

/* The opened image's size: positive, one slice, at most 64 channels, and
 * sides and area within 31 bits and max_pixels. */
static int check_size(const ImageSpec &spec, const char *path,
                      uint64_t max_pixels, struct gv_error *err)
{
    /* Sizes must be positive and fit in 31 bits; checked as int64 so that
     * the product cannot overflow. */
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: bad image size %dx%d",
                       path, spec.width, spec.height);
    if (spec.depth != 1)
        return gv_fail(err, GV_EFORMAT, "imageio: %s: volume images are not "
                       "supported", path);
    /* 64 channels is far above any real colour image; it bounds the
     * row-size arithmetic of make_input. */
    if (spec.nchannels > 64)
        return gv_fail(err, GV_EFORMAT, "imageio: %s: too many channels (%d)",
                       path, spec.nchannels);
    return gv_image_size_check(path, (uint64_t)spec.width,
                               (uint64_t)spec.height, max_pixels, err);
}

/* The reading state for an opened, checked image delivered as `type`. */
static std::unique_ptr<gv_image_in> make_input(const char *path,
                                               const ImageSpec &spec,
                                               const struct gv_image_info &info,
                                               TypeDesc type)
{
    std::unique_ptr<gv_image_in> im(new gv_image_in());
    im->path = path;
    im->type = type;
    im->nchannels = spec.nchannels;
    im->pixel_bytes = (size_t)spec.nchannels * type.size();
    /* w < 2^31 and pixel_bytes <= 64 * 4: no overflow in 64 bits. */
    im->row_bytes = (size_t)info.width * im->pixel_bytes;
    im->height = info.height;
    im->next_row = 0;
    im->narrow_max = info.sample == GV_SAMPLE_U16 && info.bits < 16
                         ? (1u << info.bits) - 1 : 0;
    im->x0 = spec.x;
    im->y0 = spec.y;
    im->z0 = spec.z;
    im->tiled = spec.tile_width > 0 && spec.tile_height > 0;
    im->tile_h = im->tiled ? (uint32_t)spec.tile_height : 0;
    im->buf_first = 0;
    im->buf_rows = 0;
    im->failed = false;
    return im;
}

static struct gv_image_in *open_impl(const char *path, uint64_t max_pixels,
                                     struct gv_image_info *info,
                                     struct gv_error *err)
{
    set_threads_once();
    if (check_file(path, err) != 0)
        return NULL;
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    std::unique_ptr<ImageInput> in = choose_reader(path, &config, err);
    if (!in)
        return NULL;
    ImageSpec opened;
    if (!in->open(path, opened, config)) {
        std::string msg = in->geterror();
        fail_msg(err, GV_EFORMAT, path,
                 msg.empty() ? "not a readable image" : msg);
        return NULL;
    }
    const ImageSpec &spec = in->spec();
    if (in->has_error()) {
        fail_msg(err, GV_ECORRUPT, path, in->geterror());
        return NULL;
    }
    if (check_size(spec, path, max_pixels, err) != 0)
        return NULL;

    struct gv_image_info tmp;
    memset(&tmp, 0, sizeof tmp);
    TypeDesc type;
    if (choose_type(spec, path, &tmp, &type, err) != 0)
        return NULL;
    tmp.width = (uint32_t)spec.width;
    tmp.height = (uint32_t)spec.height;
    tmp.channels = spec.nchannels;
    snprintf(tmp.format, sizeof tmp.format, "%s", in->format_name());
    std::unique_ptr<gv_image_in> im = make_input(path, spec, tmp, type);
    im->in = std::move(in);
    *info = tmp;
    return im.release();
}

extern "C" struct gv_image_in *gv_image_open(const char *path,
                                             uint64_t max_pixels,
                                             struct gv_image_info *info,
                                             struct gv_error *err)
{
    try {
        return open_impl(path, max_pixels, info, err);
    } catch (const std::bad_alloc &) {
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
    } catch (const std::exception &e) {
        gv_fail(err, GV_ECORRUPT, "imageio: %s: %s", path, e.what());
    } catch (...) {
        gv_fail(err, GV_ECORRUPT, "imageio: %s: unknown decoder exception",
                path);
    }
    return NULL;
}

/* Fill im->buf with the row of tiles holding row `row`. */
static int load_tile_row(struct gv_image_in *im, uint32_t row,
                         struct gv_error *err)
{
    uint32_t first = row - row % im->tile_h;
    uint32_t n = im->height - first < im->tile_h ? im->height - first
                                                   : im->tile_h;
    if (im->buf.empty()) {
        /* tile_h rows of the full width: the smallest unit a tiled file
         * can be decoded in without decoding tiles twice - but never more
         * rows than the image has: tile_h comes from the header and may
         * be far taller than the image, and the buffer must stay inside
         * the pixel cap checked at open. */
        uint32_t buf_h = im->tile_h < im->height ? im->tile_h : im->height;
        uint64_t need = (uint64_t)im->row_bytes * buf_h;
        if (need > SIZE_MAX / 2)
            return gv_fail(err, GV_ENOMEM, "imageio: %s: tile row too large",
                           im->path.c_str());
        im->buf.resize((size_t)need);
    }
    /* Zeroed first: see read_rows. */
    memset(im->buf.data(), 0, im->buf.size());
    int y = im->y0 + (int)first;
    bool ok = im->in->read_tiles(0, 0, im->x0,
                                 im->x0 + (int)(im->row_bytes
                                                / im->pixel_bytes),
                                 y, y + (int)n, im->z0, im->z0 + 1, 0,
                                 im->nchannels, im->type, im->buf.data());
    if (!ok || im->in->has_error()) {
        std::string msg = im->in->geterror();
        return fail_read(err, im, msg.empty() ? "tile read failed" : msg);
    }
    im->buf_first = first;
    im->buf_rows = n;
    return 0;
}

/* Undo OIIO's widening of 9..15-bit samples (see the top of the file). */
static void narrow(const struct gv_image_in *im, void *out, uint32_t rows)
{
    uint16_t *p = static_cast<uint16_t *>(out);
    size_t n = (size_t)rows * (im->row_bytes / 2);
    uint32_t m = im->narrow_max;
    for (size_t i = 0; i < n; i++)
        p[i] = (uint16_t)((p[i] * m + 32767u) / 65535u);
}

static int read_rows(struct gv_image_in *im, uint32_t rows, void *out,
                     struct gv_error *err);

static int read_impl(struct gv_image_in *im, uint32_t rows, void *out,
                     struct gv_error *err)
{
    if (read_rows(im, rows, out, err) != 0)
        return -1;
    if (im->narrow_max)
        narrow(im, out, rows);
    return 0;
}

static int read_rows(struct gv_image_in *im, uint32_t rows, void *out,
                     struct gv_error *err)
{
    if (gv_image_read_check(im->path.c_str(), im->failed, rows, im->next_row,
                            im->height, err) < 0)
        return -1;
    if (rows == 0)
        return 0;
    unsigned char *dst = static_cast<unsigned char *>(out);
    if (!im->tiled) {
        /* A reader may report success without writing every byte.
         * Zeroed first, such bytes become black instead of whatever the
         * heap held before - which the encoder would otherwise put into a
         * store for anyone to download. */
        memset(dst, 0, (size_t)rows * im->row_bytes);
        int y = im->y0 + (int)im->next_row;
        bool ok = im->in->read_scanlines(0, 0, y, y + (int)rows, im->z0, 0,
                                         im->nchannels, im->type, dst);
        if (!ok || im->in->has_error()) {
            std::string msg = im->in->geterror();
            return fail_read(err, im,
                             msg.empty() ? "scanline read failed" : msg);
        }
        im->next_row += rows;
        return 0;
    }
    /* Same shape as the row loop of native_tiff.c's read: deliberately
     * separate, this one is the OpenImageIO module's (C++, its own binary). */
    while (rows > 0) {
        uint32_t r = im->next_row;
        if (im->buf_rows == 0 || r < im->buf_first
            || r >= im->buf_first + im->buf_rows) {
            if (load_tile_row(im, r, err) != 0)
                return -1;
        }
        uint32_t avail = im->buf_first + im->buf_rows - r;
        uint32_t take = rows < avail ? rows : avail;
        size_t skip = (size_t)(r - im->buf_first) * im->row_bytes;
        memcpy(dst, im->buf.data() + skip, (size_t)take * im->row_bytes);
        dst += (size_t)take * im->row_bytes;
        rows -= take;
        im->next_row += take;
    }
    return 0;
}

extern "C" int gv_image_read(struct gv_image_in *in, uint32_t rows,
                             void *out, struct gv_error *err)
{
    try {
        return read_impl(in, rows, out, err);
    } catch (const std::bad_alloc &) {
        in->failed = true;
        return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory",
                       in->path.c_str());
    } catch (const std::exception &e) {
        in->failed = true;
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: %s", in->path.c_str(),
                       e.what());
    } catch (...) {
        in->failed = true;
        return gv_fail(err, GV_ECORRUPT,
                       "imageio: %s: unknown decoder exception",
                       in->path.c_str());
    }
}

extern "C" void gv_image_close(struct gv_image_in *in)
{
    if (!in)
        return;
    try {
        if (in->in)
            in->in->close();
        delete in;
    } catch (...) {
        /* nothing sensible to report from a destructor path */
    }
}

/* ---- writing ---- */

/* Output format for a file name's extension (with its dot, any case),
 * as gv_image_encode names it, or NULL. */
static const char *format_for(const std::string &ext)
{
    const struct gv_output_format *f =
        gv_output_format_for_extension(ext.c_str() + 1);
    return f ? f->name : NULL;
}

/*
 * Encode in memory (gv_image_encode), then publish the bytes with
 * gv_atomic_file_write, so that a full disk or a file size limit is
 * reported with its errno (GV_ENOSPC) rather than as an encoder's message,
 * and the image appears under its name only when complete.
 */
static int write_impl(const char *path, uint32_t width, uint32_t height,
                      int channels, enum gv_sample sample, const void *pixels,
                      struct gv_error *err)
{
    std::string p(path);
    size_t slash = p.rfind('/');
    std::string base = slash == std::string::npos ? p : p.substr(slash + 1);
    size_t dot = base.rfind('.');
    if (base.empty() || dot == std::string::npos || dot + 1 == base.size())
        return gv_fail(err, GV_EINVAL, "imageio: %s: no file extension to "
                       "choose a format by", path);
    const char *format = format_for(base.substr(dot));
    if (!format)
        return gv_fail(err, GV_EFORMAT, "imageio: %s: unsupported output "
                       "format \"%s\" (png, jpg, webp, tif)", path,
                       base.substr(dot).c_str());
    uint8_t *bytes = NULL;
    size_t len = 0;
    /* 90: visually transparent for JPEG and WebP (lossy formats only). */
    if (gv_image_encode_typed(format, width, height, channels, sample, pixels,
                              &bytes, &len, err) != 0)
        return -1;
    std::unique_ptr<uint8_t, void (*)(void *)> hold(bytes, free);
    struct gv_atomic_opts opts = {};
    opts.module = "imageio";
    return gv_atomic_file_write(path, bytes, len, &opts, err);
}

extern "C" int gv_image_write(const char *path, uint32_t width,
                              uint32_t height, int channels,
                              const uint8_t *pixels, struct gv_error *err)
{
    return gv_image_write_typed(path, width, height, channels, GV_SAMPLE_U8,
                                pixels, err);
}

/* ---- in-memory encoding ---- */

/*
 * gv_image_encode writes through an OIIO::Filesystem::IOVecOutput (every
 * writer used here, png, jpeg, webp and tiff, supports("ioproxy") in OIIO
 * 2.4.7), so nothing touches the file system and each call has its own
 * ImageOutput and buffer: safe from any number of threads.  The file name
 * given to open() only carries the extension; no file is created.
 */
static int encode_impl(const char *format, uint32_t width, uint32_t height,
                       int channels, const void *pixels_in, TypeDesc type,
                       int quality, uint8_t **out, size_t *len,
                       struct gv_error *err)
{
    const uint8_t *pixels = static_cast<const uint8_t *>(pixels_in);
    set_threads_once();
    const struct gv_output_format *f = gv_output_format_image(format);
    const char *oiio_name = f ? f->oiio : NULL;
    if (!oiio_name)
        return gv_fail(err, GV_EFORMAT, "imageio: cannot encode format "
                       "\"%s\" (png, jpg, webp or tif)",
                       format ? format : "(null)");
    /* 8-bit images are gray or RGB; 16-bit and float ones (a sample
     * store's codes) 1 to 4 channels in PNG, 1 to 8 in TIFF. */
    const int max_channels = type == TypeDesc::UINT8 ? 3
                           : std::string(oiio_name) == "png" ? 4 : 8;
    if (type == TypeDesc::UINT8 && channels != 1 && channels != 3)
        return gv_fail(err, GV_EINVAL, "imageio: cannot encode %d channels "
                       "(1 or 3)", channels);
    if (channels < 1 || channels > max_channels)
        return gv_fail(err, GV_EINVAL, "imageio: cannot encode %d channels "
                       "of 16-bit or float samples as %s (1 to 4 in PNG, 1 "
                       "to 8 in TIFF)", channels, format);
    if (width == 0 || height == 0 || width > 0x7fffffffu
        || height > 0x7fffffffu)
        return gv_fail(err, GV_EINVAL, "imageio: bad image size %ux%u",
                       width, height);
    if (quality < 1)
        quality = 1;
    if (quality > 100)
        quality = 100;

    std::unique_ptr<ImageOutput> o = ImageOutput::create(oiio_name);
    if (!o) {
        (void)OIIO::geterror();
        return gv_fail(err, GV_EFORMAT, "imageio: this OpenImageIO cannot "
                       "write %s", oiio_name);
    }
    if (!o->supports("ioproxy"))
        return gv_fail(err, GV_EFORMAT, "imageio: the %s writer cannot "
                       "write to memory", oiio_name);
    std::string fmt = oiio_name;
    /* WebP has no gray mode, and OIIO 2.4's WebP writer reads three bytes
     * a pixel whatever the channel count (a 1-channel image made it read
     * past the buffer and crash): write gray as RGB with equal channels. */
    std::vector<uint8_t> rgb;
    if (type != TypeDesc::UINT8 && fmt != "png" && fmt != "tiff")
        return gv_fail(err, GV_EFORMAT, "imageio: %s holds only 8-bit "
                       "samples", format);
    if (type == TypeDesc::FLOAT && fmt != "tiff")
        return gv_fail(err, GV_EFORMAT, "imageio: %s holds no float samples",
                       format);
    if (fmt == "webp" && channels == 1) {
        rgb.resize((size_t)width * height * 3);
        for (size_t i = 0; i < (size_t)width * height; i++)
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = pixels[i];
        pixels = rgb.data();
        channels = 3;
    }
    std::vector<unsigned char> buf;
    OIIO::Filesystem::IOVecOutput vec(buf);
    ImageSpec spec((int)width, (int)height, channels, type);
    /* Samples, not colour with alpha: written as they are (OIIO would
     * otherwise take channel 2 or 4 as an associated alpha). */
    spec.alpha_channel = -1;
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (fmt == "jpeg" || fmt == "webp")
        spec.attribute("CompressionQuality", quality);
    /* OIIO 2.4.7 with libtiff 4.5 records "failed TIFFWriteCustomDirectory()
     * of the Exif data" for every TIFF (an empty Exif directory) while still
     * writing a good file; there is no Exif to write, so skip it. */
    spec.attribute("tiff:write_exif", 0);
    std::string name = std::string("memory.") + format;
    if (!o->set_ioproxy(&vec) || !o->open(name, spec)) {
        std::string msg = o->geterror();
        return gv_fail(err, GV_EIO, "imageio: encoding %s: %s", format,
                       first_line(msg.empty() ? "open failed" : msg).c_str());
    }
    bool ok = o->write_image(type, pixels);
    ok = o->close() && ok;
    if (!ok || o->has_error()) {
        std::string msg = o->geterror();
        return gv_fail(err, GV_EIO, "imageio: encoding %s: %s", format,
                       first_line(msg.empty() ? "write failed" : msg).c_str());
    }
    o.reset();
    if (buf.empty())
        return gv_fail(err, GV_EIO, "imageio: encoding %s produced no bytes",
                       format);
    uint8_t *p = static_cast<uint8_t *>(malloc(buf.size()));
    if (!p)
        return gv_fail(err, GV_ENOMEM, "imageio: out of memory");
    memcpy(p, buf.data(), buf.size());
    *out = p;
    *len = buf.size();
    return 0;
}

/* encode_impl with its exceptions turned into *err (no exception leaves
 * the module). */
static int encode_guarded(const char *format, uint32_t width, uint32_t height,
                          int channels, const void *pixels, TypeDesc t,
                          int quality, uint8_t **out, size_t *len,
                          struct gv_error *err)
{
    try {
        return encode_impl(format, width, height, channels, pixels, t, quality,
                           out, len, err);
    } catch (const std::bad_alloc &) {
        return gv_fail(err, GV_ENOMEM, "imageio: out of memory encoding");
    } catch (const std::exception &e) {
        return gv_fail(err, GV_EIO, "imageio: encoding: %s", e.what());
    } catch (...) {
        return gv_fail(err, GV_EIO, "imageio: unknown encoder exception");
    }
}

extern "C" int gv_image_encode(const char *format, uint32_t width,
                               uint32_t height, int channels,
                               const uint8_t *pixels, int quality,
                               uint8_t **out, size_t *len,
                               struct gv_error *err)
{
    return encode_guarded(format, width, height, channels, pixels,
                          TypeDesc::UINT8, quality, out, len, err);
}

extern "C" int gv_image_write_typed(const char *path, uint32_t width,
                                    uint32_t height, int channels,
                                    enum gv_sample sample, const void *pixels,
                                    struct gv_error *err)
{
    try {
        return write_impl(path, width, height, channels, sample, pixels, err);
    } catch (const std::bad_alloc &) {
        return gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
    } catch (const std::exception &e) {
        return gv_fail(err, GV_EIO, "imageio: %s: %s", path, e.what());
    } catch (...) {
        return gv_fail(err, GV_EIO, "imageio: %s: unknown encoder exception",
                       path);
    }
}

extern "C" int gv_image_encode_typed(const char *format, uint32_t width,
                                     uint32_t height, int channels,
                                     enum gv_sample sample, const void *pixels,
                                     uint8_t **out, size_t *len,
                                     struct gv_error *err)
{
    TypeDesc t = sample == GV_SAMPLE_U16 ? TypeDesc::UINT16
               : sample == GV_SAMPLE_F32 ? TypeDesc::FLOAT : TypeDesc::UINT8;
    /* 90: visually transparent for JPEG and WebP (8-bit only). */
    return encode_guarded(format, width, height, channels, pixels, t, 90, out,
                          len, err);
}

/* ---- the module's table (imageio_module.h) ---- */

extern "C" __attribute__((visibility("default")))
const struct gv_imageio_module gv_imageio_module = {
    GV_IMAGEIO_MODULE_ABI, oiio_image_open, oiio_image_read,
    oiio_image_close, oiio_image_write, oiio_image_encode,
    oiio_image_write_typed, oiio_image_encode_typed,
};
