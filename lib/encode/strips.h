/*
 * strips.h - how the streaming encoders (stream_encoder.c for images,
 * height_encode.c for height stores) lay out a pyramid level in their
 * scratch file (base/spill.h), and the scratch file itself.
 *
 * A level is stored as one strip per column of pages: the 4097 columns of
 * the page's window (fewer in the last strip), all of the level's rows,
 * row-major, so that a page's window is one contiguous span of the file
 * and can be mapped as it is (gv_spill_view).  Neighbouring strips share
 * one column (the windows' overlap).  Pixels are `px` bytes (3 for RGB,
 * 2 for a height code); a level starts at a byte offset `base` of the
 * caller's choosing.
 */
#ifndef GV_STRIPS_H
#define GV_STRIPS_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "base/spill.h"
#include "store/geometry.h"

#define GV_STRIP_WINDOW (GV_PAGE_TILES * GV_STEP + 1)  /* 4097: a page plus overlap */
#define GV_STRIP_PAGE_W (GV_PAGE_TILES * GV_STEP)      /* 4096: from page to page */

/* Width of strip p (page column p's window) of a level `width` wide. */
uint32_t gv_strip_width(uint32_t width, uint32_t p);

/* Strips of a level: one per column of pages (the root, which has no
 * pages, is one strip). */
uint32_t gv_strip_count(const struct gv_level *l);

/* Bytes of level l laid out in strips. */
uint64_t gv_strips_bytes(const struct gv_level *l, size_t px);

/* Offset of row y of strip p of level l stored at `base`: every strip
 * before the last is 4097 wide. */
uint64_t gv_strip_at(const struct gv_level *l, uint64_t base, size_t px,
                     uint32_t p, uint32_t y);

/* Store columns x0 .. x1-1 of row y of level l (row holds the whole row)
 * in each strip they reach.  0, or -1 with *err (the spill's). */
int gv_strips_store(struct gv_spill *s, const struct gv_level *l,
                    uint64_t base, size_t px, uint32_t y, const void *row,
                    uint32_t x0, uint32_t x1, struct gv_error *err);

/* A scratch file in `tmpdir`, or where NULL, in the directory of
 * `output` (the current one for a bare name).  NULL with *err. */
struct gv_spill *gv_strips_spill_new(const char *tmpdir, const char *output,
                                     struct gv_error *err);

#endif
