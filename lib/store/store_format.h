/*
 * store_format.h - byte layout of a gigaview store file (format version 2;
 * version 1 differs only in that its tiles never use the context-coded
 * layout, so it is read by the same code).
 *
 * Shared by the reader and the writer; docs/FORMAT.md is the normative
 * description.  All integers are little-endian.  The file is:
 *
 *   header   128 bytes at offset 0, CRC32 in its last 4 bytes
 *   pages    one per 8x8 tiles of a level, written coarse to fine
 *   root     the root level as a lossless WebP image, then a CRC32; its
 *            mips down to 1x1 are derived by the box filter
 *   meta     optional (image stores): the metadata section
 *            (store_meta.h), its offset, size and CRC32 in the header
 *   index    16 bytes per page {u64 offset, u32 size, u32 crc32}, then a
 *            CRC32 of the index
 *
 * The header points at the root and the index, which the writer appends
 * after the pages so that it can stream.
 */
#ifndef GV_STORE_FORMAT_H
#define GV_STORE_FORMAT_H

#include <stdint.h>
#include <string.h>

#include "base/byteorder.h"
#include "base/crc32.h"
#include "codec/samples_tile.h"
#include "store/geometry.h"

#define GV_MAGIC "GIGAVIEW"
#define GV_VERSION 2       /* what the writer writes for an image store */
#define GV_VERSION_HEIGHT 3 /* what it writes for a height store */
#define GV_VERSION_DCT 5   /* an image store whose tiles may use layouts D
                            * and D2 (version 4: D only; read the same) */
#define GV_VERSION_SMALL_ROOT 6 /* an image store whose root is the first
                            * level within root_side (header bytes 96-97),
                            * tiles in any layout */
#define GV_VERSION_SAMPLES 7 /* a sample store: 1 to 8 channels of 16-bit
                            * codes (docs/FORMAT.md section 13) */
#define GV_VERSION_MAX 7   /* the newest version the reader reads */
#define GV_VERSION_MIN 1   /* the oldest version the reader reads */

/* Store kinds: header byte 80 in format version 3, the version itself in
 * 7; every other version is an image store. */
#define GV_KIND_IMAGE 0
#define GV_KIND_HEIGHT 1   /* 16-bit codes of a height field (section 12) */
#define GV_KIND_SAMPLES 2  /* 1..GV_SAMPLES_MAX_CHANNELS (codec/samples_tile.h)
                            * channels of 16-bit image samples (section 13,
                            * format version 7) */
#define GV_HEIGHT_UNIT 8   /* bytes of the unit name, NUL-padded */
#define GV_HEADER_SIZE 128
#define GV_INDEX_ENTRY 16
#define GV_PAGE_MAGIC "GVPG"
#define GV_PAGE_HEADER 16
#define GV_PAGE_SLOTS (GV_PAGE_TILES * GV_PAGE_TILES)
#define GV_PAGE_TABLE (GV_PAGE_HEADER + 8 * GV_PAGE_SLOTS)

/* Decoded form of the 128-byte header. */
struct gv_header {
    uint16_t version;
    uint32_t width, height;
    uint8_t channels;
    uint8_t root;           /* root level index */
    uint8_t root_mips;
    uint8_t max_rate;       /* the encoder's cap on r */
    uint8_t src_bits;       /* bits per sample of the input */
    uint8_t src_float;
    uint8_t tone;           /* enum gv_tone_rule */
    uint32_t target_mpsnr;  /* per-tile PSNR target, millidecibels */
    uint32_t psnr0_mdb;     /* PSNR of level 0 against the input, mdB */
    uint64_t root_offset, root_size;   /* root_size includes its CRC */
    uint64_t index_offset, pages;
    uint64_t file_size;
    /* Height and sample stores (gv_header_codes): value = code *
     * height_scale + height_offset, every decoded code within height_e
     * codes of its level's exact code, every level-0 value within
     * height_max_error source units of the input.  A sample store has no
     * unit, and its min and max are those of every channel together. */
    uint8_t kind;
    uint8_t height_float;    /* the input was floating point */
    uint16_t height_e;
    double height_scale, height_offset, height_max_error;
    float height_min, height_max;   /* range of the input values */
    char height_unit[GV_HEIGHT_UNIT + 1];
    uint16_t samples_lo, samples_hi;   /* sample stores: smallest and
                                        * largest code of the input */
    /* Image and sample stores (not version 3): the optional metadata section
     * (store_meta.h), size 0 when there is none. */
    uint64_t meta_offset;
    uint32_t meta_size, meta_crc;   /* the whole section, its CRC32 */
    /* The root is the first level within root_side x root_side pixels:
     * header bytes 96-97 from version 6 on, GV_ROOT_MAX before. */
    uint16_t root_side;
};

/* root_side of the stores the encoder writes: every level larger than
 * 128 x 128 is coded at the store's quality (docs/FORMAT.md section 1;
 * 32, 64 and 256 measured worse on the bench photographs). */
#define GV_ROOT_SIDE 128

/* The version an image store is written with: version 6 (GV_VERSION_SMALL_ROOT)
 * for any root_side other than GV_ROOT_MAX; otherwise `version` when it is
 * 5 (layouts D and D2 in use), else 2. */
static inline uint16_t gv_image_version(uint16_t version, uint16_t root_side)
{
    if (root_side != GV_ROOT_MAX || version == GV_VERSION_SMALL_ROOT)
        return GV_VERSION_SMALL_ROOT;
    return version == GV_VERSION_DCT ? GV_VERSION_DCT : GV_VERSION;
}

/* Whether a store holds 16-bit codes (a height or a sample store) rather
 * than 8-bit image tiles. */
static inline int gv_header_codes(const struct gv_header *h)
{
    return h->kind == GV_KIND_HEIGHT || h->kind == GV_KIND_SAMPLES;
}

/* A sample store's height_min, height_max and height_max_error, from its
 * codes' range, mapping, e and float flag (section 13: the bound of
 * section 12's rule). */
void gv_samples_derive(struct gv_header *h);

/* Serialize h into 128 bytes, CRC included. */
void gv_header_pack(const struct gv_header *h, uint8_t out[GV_HEADER_SIZE]);

struct gv_error;
/* Parse and check magic, version and CRC (not the geometry).  Returns 0 or
 * -1 with *err filled. */
int gv_header_unpack(const uint8_t in[GV_HEADER_SIZE], struct gv_header *h,
                     struct gv_error *err);

/*
 * The root of a height or sample store: w x h pixels of c interleaved
 * codes, stored as zlib (deflate) of each code's difference from the same
 * channel's code of its left neighbour (mod 2^16, the first pixel of a
 * row from 0), u16 little-endian.  *out is malloc'ed.  0 or -1.
 */
int gv_codes_root_pack(const uint16_t *codes, uint32_t w, uint32_t h, int c,
                       uint8_t **out, size_t *len, struct gv_error *err);
/* Inverse of gv_codes_root_pack: exactly w*h*c codes or GV_ECORRUPT. */
int gv_codes_root_unpack(const uint8_t *in, size_t len, uint32_t w,
                         uint32_t h, int c, uint16_t *out,
                         struct gv_error *err);
/* The u16 box filter of section 1 for levels of codes (odd edges
 * replicated), c channels interleaved: src sw x sh -> dst ceil(sw/2) x
 * ceil(sh/2). */
void gv_codes_box_reduce(const uint16_t *src, uint32_t sw, uint32_t sh, int c,
                         uint16_t *dst);
/* One row of it: rows r0 and r1 (r1 = r0 for an odd last row) of sw
 * pixels -> ceil(sw/2) pixels in dst. */
void gv_codes_box_reduce_row(const uint16_t *r0, const uint16_t *r1,
                             uint32_t sw, int c, uint16_t *dst);

/* Bytes of every mip of a w x h root, channels interleaved (what a reader
 * holds in memory). */
uint64_t gv_root_pixels_size(uint32_t w, uint32_t h, int channels);

/* Largest root: 512 x 512 x 3. */
#define GV_ROOT_MAX_BYTES (GV_ROOT_MAX * GV_ROOT_MAX * 3)

/* libwebp lossless effort (0..9): on a 408x306 photographic root, 4 takes
 * 0.06 s for 1.2 % more bytes than 6 (0.15 s) and 2.6 % more than 9 (6 s);
 * the root is a small part of a store, so speed wins. */
#define GV_ROOT_EFFORT 4

/*
 * Compress the root image losslessly as a WebP lossless image (RGB; a gray
 * root is stored with three equal channels).  *out is malloc'ed (caller
 * frees with free()).  Returns 0 or -1.
 */
int gv_root_pack(const uint8_t *pixels, uint32_t w, uint32_t h, int channels,
                 uint8_t **out, size_t *len, struct gv_error *err);

/* The near-lossless setting of the root for a target PSNR q (dB):
 * 5q - 100 clamped to 0..100, so lossless from q = 40 on (docs/FORMAT.md
 * section 6). */
int gv_root_near_lossless(double target_psnr);

/*
 * Replace the root's pixels (w*h*channels) with what a near-lossless WebP
 * encoding of them decodes to, at libwebp's near_lossless setting (0..99;
 * 100 or more leaves them unchanged).  Deterministic; the result packs
 * losslessly (gv_root_pack) to about the near-lossless size.  Returns 0,
 * or -1 with *err filled (pixels unspecified then).
 */
int gv_root_approx(uint8_t *pixels, uint32_t w, uint32_t h, int channels,
                   int near_lossless, struct gv_error *err);

/* Inverse of gv_root_pack into out (w*h*channels bytes).  Fails unless the
 * data is a WebP image of exactly w x h. */
int gv_root_unpack(const uint8_t *in, size_t len, uint32_t w, uint32_t h,
                   int channels, uint8_t *out, struct gv_error *err);

/* Fill the mips after mip 0 in place: buf holds mip 0 (w x h) followed by
 * room for the rest, as gv_root_pixels_size counts. */
void gv_root_build_mips(uint8_t *buf, uint32_t w, uint32_t h, int channels);

/* Box-reduce one 2x2 level (odd edges replicated, rounded to nearest):
 * src is sw x sh, dst receives ceil(sw/2) x ceil(sh/2). */
void gv_box_reduce(const uint8_t *src, uint32_t sw, uint32_t sh, int channels,
                   uint8_t *dst);

/* Reduce two source rows (r1 may equal r0 at an odd bottom edge) of width
 * sw into one row of ceil(sw/2) pixels. */
void gv_box_reduce_row(const uint8_t *r0, const uint8_t *r1, uint32_t sw,
                       int channels, uint8_t *dst);

#endif
