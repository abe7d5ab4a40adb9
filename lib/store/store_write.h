/*
 * store_write.h - writing a store file, atomically.
 *
 * Pages are appended as they are produced, then the root
 * (gv_store_writer_root); gv_store_writer_finish appends the page index,
 * writes the header over the 128 bytes reserved for it, and only then
 * publishes the file under its name through base/atomic_file.h (fsync,
 * then a rename that replaces an existing store whole, then fsync of the
 * directory).  A crash or kill at any point before that leaves no file
 * under the final name (atomic_file.h says exactly what may remain).
 * Error messages start "store:".  One thread uses a writer at a time.
 */
#ifndef GV_STORE_WRITE_H
#define GV_STORE_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "store/store_format.h"

struct gv_store_writer;

/* Start writing `path` for the geometry and settings in *h (dimensions,
 * channels, source description, target, cap; the offsets are filled in by
 * the writer).  Fails if the directory is not writable. */
struct gv_store_writer *gv_store_writer_new(const char *path,
                                            const struct gv_header *h,
                                            struct gv_error *err);

/*
 * Append page (px,py) of `level`.  tiles[j*8+i] / lens[j*8+i] hold the
 * buffer of tile (8px+i, 8py+j), or NULL / 0 for slots outside the grid.
 */
int gv_store_writer_page(struct gv_store_writer *w, int level, uint32_t px,
                         uint32_t py, const uint8_t *const *tiles,
                         const size_t *lens, struct gv_error *err);

/* Append the root level (root width x height x channels; for a height or
 * sample store, gv_header_codes, width x height x channels interleaved
 * uint16_t codes); its mips are computed by the reader. */
int gv_store_writer_root(struct gv_store_writer *w, const uint8_t *pixels,
                         struct gv_error *err);

/* The same for a picture root already packed by gv_root_pack (z, zlen
 * bytes; the caller keeps and frees z), so that the packing can run
 * while the pages are still being encoded. */
int gv_store_writer_root_packed(struct gv_store_writer *w, const uint8_t *z,
                                size_t zlen, struct gv_error *err);

/* Append the metadata section (store_meta.h: `section`, len bytes, as
 * gv_meta_pack made it) and point the header at it.  Image stores only;
 * at most once.  0, or -1 with *err filled. */
int gv_store_writer_meta(struct gv_store_writer *w, const uint8_t *section,
                         size_t len, struct gv_error *err);

/* Record the level-0 PSNR in millidecibels for the header. */
void gv_store_writer_set_psnr(struct gv_store_writer *w, uint32_t psnr0_mdb);

/* Bytes written so far. */
uint64_t gv_store_writer_bytes(const struct gv_store_writer *w);

/* Finish, publish under the final name and free w.  On failure nothing is
 * published and w is freed all the same. */
int gv_store_writer_finish(struct gv_store_writer *w, struct gv_error *err);

/* Abandon: remove the temporary file and free.  NULL does nothing. */
void gv_store_writer_abort(struct gv_store_writer *w);

#endif
