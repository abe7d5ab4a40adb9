/*
 * tiff_limits.c - a TIFF's decoder memory against --max-decoder-memory,
 * from its first directory, before anything is allocated for its pixels.
 *
 * Why: native_tiff.c declines JPEG-compressed, YCbCr, palette and other
 * TIFFs, which OpenImageIO 2.4 then reads through libtiff 4.5 and
 * libjpeg-turbo, none of which takes the limit.  Measured on files of
 * 1 to 2 KB claiming 30000 x 30000 (tests/data/native/limits,
 * make-tiff-limits.py), peak resident size of `gigaview encode` before
 * this check: 8.9 GB for one YCbCr JPEG strip holding a progressive
 * JPEG, 6.3 GB for the same with a baseline JPEG, 8.9 GB for one such
 * tile, 3.7 GB for an uncompressed YCbCr strip, 1.5 GB for an RGB strip
 * whose progressive JPEG claims 15000 x 15000, 8.5 GB for a 64 x 64
 * grey image of one 65536 x 65536 tile, 3.3 GB for a 1-bit one of
 * 40000 x 40000 - each failing (or "succeeding" on filler) only after.
 * The native reader, too, holds one strip or row of tiles, of whatever
 * size the header claims (1.6 GB for a 1.5 MB deflate strip).
 *
 * What is counted, each from the header, as the readers allocate it
 * (the rows the caller asks for are the caller's):
 *  - a row of tiles (tiles across x TileLength rows), decoded:
 *    ceil(TileWidth x SamplesPerPixel x BitsPerSample / 8) bytes a tile
 *    row, or as the module delivers them when that is more (samples of
 *    1 to 8 bits as bytes, a palette as RGB).  native_tiff.c and the
 *    module (imageio.cpp, read_tiles) both hold one.
 *  - one strip (RowsPerStrip rows, at most the image's), decoded, where
 *    the reader decodes a strip whole: native_tiff.c
 *    (GV_TIFF_READ_STRIPS), libtiff's RGBA interface, and the libtiff
 *    codecs that hold one whatever the caller reads (whole_strip_codec).
 *    OpenImageIO's scanline reader decodes a row at a time
 *    (TIFFReadScanline; measured: a 40000 x 40000 grey strip of deflate
 *    took 176 MB through it, 1.6 GB natively), so imageio_loader.c gives
 *    a file whose strip is too big for the native reader to the module
 *    instead of refusing it.  But where RowsPerStrip exceeds the height
 *    (below 2^31), OpenImageIO allocates a strip of that many rows
 *    (read_scanlines' chunks), and that strip is counted.
 *  - the whole image as RGBA, 4 bytes a pixel, where OpenImageIO reads
 *    through libtiff's RGBA interface (TIFFReadRGBAImage): a
 *    JPEG-compressed file (Compression 7, or old-style 6) with other than
 *    3 samples, and any YCbCr, CIE L*a*b*, ICC Lab, ITU Lab, LogL or
 *    LogLuv file (its tiffinput.cpp, m_use_rgba_interface; measured: an
 *    uncompressed YCbCr 30000 x 30000 took 3.7 GB, 30000^2 x 4 bytes).
 *  - for JPEG compression, the largest coefficient arrays libjpeg
 *    requests for one strip or tile whose stream is progressive or
 *    multi-scan, by native_jpeg.c's rule (coef_bytes), read from that
 *    stream's header after the JPEGTables as libtiff feeds them
 *    (gv_native_jpeg_stream_need).  libtiff refuses a stream larger than
 *    its strip or tile (tif_jpeg.c JPEGPreDecode), except the last
 *    strip's, so when even a stream the size of a strip or tile with any
 *    sampling (bound_coef) stays within the limit only the last strip's
 *    header is read; else every strip's or tile's.  libjpeg frees them
 *    between strips and tiles: the largest counts, not the sum.
 * More than lim->max_decoder_bytes is GV_ELIMIT, naming both and what was
 * counted, in the words of the other readers' limits (size_limit.h).
 * Measured after: every file above refused, or read, in under 20 MB
 * (tiles, RGBA and coefficients) or 260 MB (strips read by the module).
 *
 * The directory is parsed here, not with libtiff, so that nothing of the
 * file is allocated: TIFF 6.0 section 2 (header, IFD entries of 12 bytes,
 * values inline when they fit in 4 bytes) and BigTIFF (version 43, 20-byte
 * entries, 8-byte counts and offsets, values inline in 8), either byte
 * order; every offset and count is checked against the file's size, and
 * arrays are read an element at a time.  As libtiff 4.5 reads the
 * directory (tif_dirread.c): the first of duplicate tags counts, an
 * entry whose values lie outside the file is ignored, either tile
 * dimension makes the file tiled, StripOffsets and TileOffsets are one
 * array, trimmed to what lies in the file.  The memory counted needs the
 * sizes only (no offsets); a file without a directory this can follow,
 * or without width and height, is passed (0): libtiff fails on it too,
 * and the reader says so in its own words.
 * Defaults as libtiff's: 1 sample of 1 bit, no compression, RowsPerStrip
 * the height.
 */
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "imageio/native_file.h"
#include "imageio/native_jpeg.h"
#include "imageio/size_limit.h"
#include "imageio/tiff_limits.h"

/* The fields of the first directory this check needs. */
struct dir {
    FILE *f;
    uint64_t file_bytes;
    int be, big;
    uint64_t width, height, rps, tile_w, tile_h;
    uint64_t spp, bps, compression, photometric, planar;
    int tiled;
    /* the strips' or tiles' offsets and byte counts: [0] from StripOffsets
     * and StripByteCounts, [1] from TileOffsets and TileByteCounts (libtiff
     * keeps one of them, which one depending on the order: both are
     * checked) */
    struct {
        uint64_t at, n, size;              /* offsets; size 0: none */
        uint64_t counts_at, counts_n, counts_size;
    } chunk[2];
    uint64_t tables_at, tables_len;                 /* JPEGTables */
};

/* a * b, or UINT64_MAX when it overflows */
static uint64_t mul(uint64_t a, uint64_t b)
{
    return a && b > UINT64_MAX / a ? UINT64_MAX : a * b;
}

static uint64_t add(uint64_t a, uint64_t b)
{
    return b > UINT64_MAX - a ? UINT64_MAX : a + b;
}

/* n bytes at `at` as an unsigned integer of the file's byte order, or -1
 * when they are not all in the file. */
static int get(const struct dir *d, uint64_t at, unsigned n, uint64_t *v)
{
    uint8_t b[8];
    if (n > 8 || at > d->file_bytes || n > d->file_bytes - at
        || fseeko(d->f, (off_t)at, SEEK_SET) != 0
        || fread(b, 1, n, d->f) != n)
        return -1;
    *v = 0;
    for (unsigned i = 0; i < n; i++)
        *v |= (uint64_t)b[d->be ? i : n - 1 - i] << (8 * (n - 1 - i));
    return 0;
}

/* The size of one value of a TIFF field type, 0 for an unknown one. */
static unsigned type_size(uint64_t type)
{
    static const unsigned size[19] = {0, 1, 1, 2, 4, 8, 1, 1, 2, 4,
                                      8, 4, 8, 4, 0, 0, 8, 8, 8};
    return type < 19 ? size[type] : 0;
}

/* Element i of an array of unsigned integers of `size` bytes at `at`. */
static int element(const struct dir *d, uint64_t at, uint64_t size,
                   uint64_t i, uint64_t *v)
{
    return get(d, add(at, mul(i, size)), (unsigned)size, v);
}

/* Read the header and the first directory: 0, or -1 when it cannot be
 * followed. */
static int read_dir(struct dir *d)
{
    uint64_t magic, version, ifd, n;
    if (get(d, 0, 2, &magic) < 0)
        return -1;
    if (magic == 0x4D4D)
        d->be = 1;
    else if (magic != 0x4949)
        return -1;
    if (get(d, 2, 2, &version) < 0)
        return -1;
    d->big = version == 43;
    if (version != 42 && !d->big)
        return -1;
    if (d->big ? get(d, 8, 8, &ifd) : get(d, 4, 4, &ifd))
        return -1;
    const unsigned count_bytes = d->big ? 8 : 4, inline_bytes = count_bytes;
    const unsigned entry_bytes = d->big ? 20 : 12;
    if (get(d, ifd, d->big ? 8 : 2, &n) < 0)
        return -1;
    const uint64_t first = ifd + (d->big ? 8 : 2);
    if (n > (d->file_bytes - first) / entry_bytes)
        return -1;
    d->spp = d->bps = d->compression = d->planar = 1;
    d->rps = UINT64_MAX;
    /* the tags read: libtiff takes the first of duplicates and ignores
     * the rest (tif_dirread.c, "Mark duplicates of any tag to be
     * ignored"), so does this */
    static const uint16_t tags[] = {256, 257, 258, 259, 262, 273, 277, 278,
                                    279, 284, 322, 323, 324, 325, 347};
    unsigned seen = 0;
    for (uint64_t i = 0; i < n; i++) {
        const uint64_t e = first + i * entry_bytes;
        uint64_t tag, type, count, value;
        if (get(d, e, 2, &tag) < 0 || get(d, e + 2, 2, &type) < 0
            || get(d, e + 4, count_bytes, &count) < 0)
            return -1;
        unsigned k = 0;
        while (k < sizeof tags / sizeof tags[0] && tags[k] != tag)
            k++;
        if (k == sizeof tags / sizeof tags[0] || (seen & 1u << k))
            continue;
        seen |= 1u << k;
        /* An entry whose values cannot be read is ignored, as libtiff
         * ignores it (a required one missing, libtiff fails the file). */
        const unsigned size = type_size(type);
        const uint64_t field = e + 4 + count_bytes;
        uint64_t at = field;   /* where the values are */
        if (size == 0 || count == 0)
            continue;
        if (mul(count, size) > inline_bytes
            && get(d, field, count_bytes, &at) < 0)
            continue;
        if (at >= d->file_bytes)
            continue;
        if (mul(count, size) > d->file_bytes - at) {
            /* libtiff trims an offsets or byte counts array to what it
             * can read; any other such entry it ignores */
            if (tag != 273 && tag != 279 && tag != 324 && tag != 325)
                continue;
            count = (d->file_bytes - at) / size;
            if (count == 0)
                continue;
        }
        switch (tag) {
        case 273:   /* StripOffsets */
        case 324:   /* TileOffsets: the same array in libtiff */
            if (size == 2 || size == 4 || size == 8)
                d->chunk[tag == 324].at = at, d->chunk[tag == 324].n = count,
                d->chunk[tag == 324].size = size;
            continue;
        case 279:   /* StripByteCounts */
        case 325:   /* TileByteCounts */
            d->chunk[tag == 325].counts_at = at;
            d->chunk[tag == 325].counts_n = count;
            d->chunk[tag == 325].counts_size = size;
            continue;
        case 347:   /* JPEGTables */
            d->tables_at = at, d->tables_len = count * size;
            continue;
        default:
            break;
        }
        /* scalars: the first value, of an integer type (a signed one
         * read as unsigned: a negative value is huge, and refused) */
        if (type != 1 && type != 3 && type != 4 && type != 6 && type != 8
            && type != 9 && type != 13 && type != 16 && type != 17
            && type != 18)
            continue;
        if (get(d, at, size, &value) < 0)
            continue;
        switch (tag) {
        case 256: d->width = value; break;
        case 257: d->height = value; break;
        case 258: d->bps = value; break;
        case 259: d->compression = value; break;
        case 262: d->photometric = value; break;
        case 277: d->spp = value; break;
        case 278: d->rps = value; break;
        case 284: d->planar = value; break;
        /* tiled when either is there (libtiff: FIELD_TILEDIMENSIONS),
         * whichever offsets tag the file has */
        case 322: d->tile_w = value; d->tiled = 1; break;
        case 323: d->tile_h = value; d->tiled = 1; break;
        default: break;
        }
    }
    return 0;   /* without offsets: no JPEG header to read */
}

/* Whether OpenImageIO 2.4 reads the file through libtiff's RGBA
 * interface, holding the whole image as RGBA (see the top). */
static int rgba_interface(const struct dir *d)
{
    const int jpeg = d->compression == 6 || d->compression == 7;
    switch (d->photometric) {
    case 6: case 8: case 9: case 10: case 32844: case 32845:
        return 1;
    default:
        return jpeg && d->spp != 3;
    }
}

/* Whether libtiff's codec for this compression decodes a strip or tile
 * whole into a buffer of its own even when read a row at a time:
 * PixarLog (32909), SGI LogL and LogLuv (34676, 34677), JBIG (34661),
 * LERC (34887), WebP (50001); its tif_*.c setup allocates it. */
static int whole_strip_codec(uint64_t compression)
{
    switch (compression) {
    case 32909: case 34661: case 34676: case 34677: case 34887: case 50001:
        return 1;
    default:
        return 0;
    }
}

/* An upper bound of the coefficients of a JPEG stream of at most w x h
 * pixels and `comps` components of any sampling (factors 1 to 4): each
 * component at most ceil(w / 8) + 4 by ceil(h / 8) + 4 blocks (rounded
 * up to its sampling factors; w / 8 + 5 cannot overflow), of 128 bytes. */
static uint64_t bound_coef(uint64_t w, uint64_t h, uint64_t comps)
{
    return mul(comps, mul(mul(w / 8 + 5, h / 8 + 5), 128));
}

/* The refusal: -1 with *err filled. */
static int refuse(const char *path, const struct dir *d, uint64_t need,
                  uint64_t max, const char *what, struct gv_error *err)
{
    char need_s[32], max_s[32];
    gv_image_bytes_text(need_s, sizeof need_s, need);
    gv_image_bytes_text(max_s, sizeof max_s, max);
    return gv_fail(err, GV_ELIMIT, "imageio: %s: a TIFF of %llu x %llu "
                   "needs about %s of decoder memory (%s), more than the "
                   "limit of %s (--max-decoder-memory)", path,
                   (unsigned long long)d->width,
                   (unsigned long long)d->height, need_s, what, max_s);
}

/* The largest coefficient arrays of the JPEG strips or tiles from,
 * from + step, ... below n of both offset arrays, and whether the
 * largest is progressive. */
static uint64_t max_coef(const struct dir *d, uint64_t from, uint64_t step,
                         uint64_t n, int *progressive)
{
    uint64_t most = 0;
    for (int a = 0; a < 2; a++) {
        /* libtiff pads a short array with zeros: no JPEG there */
        const uint64_t count = d->chunk[a].n < n ? d->chunk[a].n : n;
        for (uint64_t i = from; i < count; i = add(i, step)) {
            uint64_t at, len;
            struct gv_jpeg_need need;
            if (element(d, d->chunk[a].at, d->chunk[a].size, i, &at) < 0)
                break;
            if (i >= d->chunk[a].counts_n
                || element(d, d->chunk[a].counts_at,
                           d->chunk[a].counts_size, i, &len) < 0)
                len = d->file_bytes;   /* at most to the end of the file */
            if (gv_native_jpeg_stream_need(d->f, d->tables_at,
                                           d->tables_len, at, len,
                                           &need) == 0
                && need.coef_bytes > most) {
                most = need.coef_bytes;
                *progressive = need.progressive;
            }
        }
    }
    return most;
}

int gv_tiff_limits_check(const char *path, const struct gv_image_limits *lim,
                         enum gv_tiff_reader reader, struct gv_error *err)
{
    gv_error_clear(err);
    struct dir d;
    memset(&d, 0, sizeof d);
    d.f = gv_native_open_regular(path);
    if (!d.f)
        return 0;   /* the reader says why */
    struct stat st;
    int rc = 0;
    if (fstat(fileno(d.f), &st) != 0)
        goto out;
    d.file_bytes = (uint64_t)st.st_size;
    if (read_dir(&d) < 0 || d.width == 0 || d.height == 0)
        goto out;
    if (gv_image_size_check(path, d.width, d.height, lim->max_pixels,
                            err) < 0) {
        rc = -1;
        goto out;
    }
    /* one strip or row of tiles: its width and rows */
    uint64_t chunk_w = d.width, rows, chunk_rows, across = 1;
    if (d.tiled) {
        if (d.tile_w == 0 || d.tile_h == 0)
            goto out;   /* libtiff refuses it */
        across = d.width / d.tile_w + (d.width % d.tile_w != 0);
        chunk_w = d.tile_w;
        rows = chunk_rows = d.tile_h;
    } else {
        chunk_rows = d.rps == 0 ? d.height : d.rps;
        rows = chunk_rows < d.height ? chunk_rows : d.height;
    }
    /* OpenImageIO's read_scanlines reads in chunks of whole strips of
     * RowsPerStrip rows as the file says, not cut to the height (an int:
     * from 2^31 on it takes none), and allocates one (fuzz_imageio: a
     * 61 x 45 JPEG TIFF claiming 1095582055 rows a strip made it ask
     * for 187 GiB) */
    const int oiio_strip = !d.tiled && reader == GV_TIFF_READ_ROWS
                           && chunk_rows > d.height
                           && chunk_rows <= 0x7fffffffu;
    if (oiio_strip)
        rows = chunk_rows;
    const uint64_t bits = mul(mul(chunk_w, d.spp), d.bps);
    uint64_t row_bytes = bits / 8 + (bits % 8 != 0);
    if (d.tiled) {
        /* the module's row of tiles holds them as delivered: samples
         * of 1 to 8 bits as bytes, 9 to 16 as two, a palette as RGB */
        const uint64_t sample = d.bps <= 8    ? 1
                                : d.bps <= 16 ? 2
                                              : d.bps / 8 + (d.bps % 8 != 0);
        const uint64_t out = mul(mul(chunk_w, d.photometric == 3 ? 3 : d.spp),
                                 sample);
        row_bytes = out > row_bytes ? out : row_bytes;
    }
    const int rgba = rgba_interface(&d);
    char what[160] = "";
    uint64_t need = 0;
    if (d.tiled || rgba || reader == GV_TIFF_READ_STRIPS || oiio_strip
        || whole_strip_codec(d.compression)) {
        need = mul(mul(row_bytes, rows), across);
        snprintf(what, sizeof what, "%s of %llu rows",
                 d.tiled ? "a row of tiles" : "a strip",
                 (unsigned long long)rows);
    }
    if (rgba) {
        need = add(need, mul(mul(d.width, d.height), 4));
        size_t k = strlen(what);
        snprintf(what + k, sizeof what - k, "%sthe whole image as RGBA",
                 k ? ", " : "");
    }
    const uint64_t max = gv_image_decoder_limit(lim);
    if (need > max) {
        rc = refuse(path, &d, need, max, what, err);
        goto out;
    }
    if (d.compression != 7 && d.compression != 6)
        goto out;
    /* JPEG: the coefficients of a progressive or multi-scan stream.
     * Every strip's or tile's header, or, when a stream of a strip's or
     * tile's size could not pass the limit, none of a tiled file's and
     * only the last strip of each plane (libtiff lets that one's stream
     * be taller).  No more strips or tiles than the image has, whatever
     * the offsets' count claims. */
    const uint64_t comps = d.planar == 2 ? 1 : d.spp;
    const uint64_t down = d.height / chunk_rows + (d.height % chunk_rows != 0);
    const uint64_t n = mul(mul(across, down), d.planar == 2 ? d.spp : 1);
    uint64_t from = 0, step = 1;
    if (add(need, bound_coef(chunk_w, rows, comps)) <= max) {
        from = d.tiled ? n : down - 1;
        step = down;
    }
    int progressive = 0;
    const uint64_t coef = max_coef(&d, from, step, n, &progressive);
    if (add(need, coef) > max) {
        size_t k = strlen(what);
        snprintf(what + k, sizeof what - k, "%sa %s JPEG's coefficients",
                 k ? ", " : "", progressive ? "progressive" : "multi-scan");
        rc = refuse(path, &d, add(need, coef), max, what, err);
    }
out:
    fclose(d.f);
    return rc;
}
