/*
 * raw_regions.h - any rectangle of an image file whose pixels lie in it
 * uncompressed, read where they lie with positioned reads: no decoder,
 * no state, any order, from any thread.
 *
 * Why: the streaming encoder needs the pixels of level 0 twice, once in
 * pass 1 (top to bottom, to build the levels above) and once in pass 2
 * (page by page, to code them).  For a decoded input they go through a
 * scratch file; for an uncompressed TIFF (how gigapixel mosaics are
 * commonly stored: `vips arrayjoin ... [tile,bigtiff]`) the file itself
 * already is such a store, and reading the tiles again saves writing and
 * then reading back a copy as large as the input (docs/FORMAT.md
 * section 9).
 *
 * The layout is a grid of blocks (a TIFF's tiles, or its strips as
 * blocks as wide as the image), each block_w x block_h pixels of
 * pixel_bytes bytes, rows end to end, at its own offset in the file.
 * Every block is checked to lie in the file when the reader is made; a
 * file cut short afterwards gives an error from the read, never SIGBUS
 * (nothing is mapped).
 */
#ifndef GV_RAW_REGIONS_H
#define GV_RAW_REGIONS_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_raw_layout {
    uint32_t width, height;      /* the image */
    int pixel_bytes;             /* bytes per pixel, 1 to 16 */
    uint32_t block_w, block_h;   /* a block's size; it may overhang the
                                  * image's right and bottom edges */
    uint32_t across, down;       /* blocks across and down: width and
                                  * height rounded up to blocks */
    const uint64_t *offsets;     /* across * down, row by row: each
                                  * block's first byte in the file */
    const uint64_t *byte_counts; /* ... and the bytes stored for it */
    int short_last_row;          /* the bottom row of blocks holds only
                                  * the image's rows (a TIFF's last strip),
                                  * not block_h */
};

struct gv_raw_regions;

/*
 * A reader of the file open on fd (dup'ed: the caller keeps its own) with
 * layout *l (copied), named `path` in messages.  Returns NULL with
 * err->code GV_OK where the layout does not describe the file (a block
 * past the end of the file or stored with fewer bytes than it needs, or
 * sizes that do not agree): the caller then reads the file as before,
 * through its decoder, which reports what is wrong.  NULL with *err
 * filled for GV_ENOMEM.
 */
struct gv_raw_regions *gv_raw_regions_new(int fd, const char *path,
                                          const struct gv_raw_layout *l,
                                          struct gv_error *err);

/* Whether the file is still as it was when r was made: the same size and
 * modification time (a file rewritten in place while an encoder read it
 * twice would give it two different images).  Returns 0, or -1 with
 * *err (GV_ECORRUPT, "changed while being read") if it is not. */
int gv_raw_regions_unchanged(const struct gv_raw_regions *r,
                             struct gv_error *err);

/* Free.  NULL does nothing. */
void gv_raw_regions_free(struct gv_raw_regions *r);

/* The image's size and bytes per pixel. */
void gv_raw_regions_size(const struct gv_raw_regions *r, uint32_t *width,
                         uint32_t *height, int *pixel_bytes);

/*
 * Read columns x .. x + w - 1 of rows y .. y + h - 1 (inside the image,
 * w, h >= 1) into dst, row i at dst + i * stride.  Thread-safe.  Returns
 * 0, or -1 with *err: GV_EINVAL for a rectangle outside the image,
 * GV_ECORRUPT for a file that has become shorter, GV_EIO for a failed
 * read.
 */
int gv_raw_regions_read(const struct gv_raw_regions *r, uint32_t x,
                        uint32_t y, uint32_t w, uint32_t h, uint8_t *dst,
                        size_t stride, struct gv_error *err);

#endif
