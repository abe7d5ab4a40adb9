/*
 * spill.h - the encoder's scratch file: every level of the pyramid that
 * pass 1 builds, and the decoded tiles that pass 2 predicts from, live
 * here so that the encoder's memory does not grow with the image.
 *
 * The file is created unnamed (O_TMPFILE, file_io.h) so that it vanishes
 * however the encoder ends; where that is unsupported it is created
 * (mode 0600) and unlinked at once.  Reads and writes are positioned
 * (pread/pwrite) and thread-safe; large reads can be mapped instead
 * (gv_spill_view), which saves a copy of every byte.  Error messages start "spill:" and name
 * the directory, since the file itself has no name.
 */
#ifndef GV_SPILL_H
#define GV_SPILL_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_spill;

/* Create a scratch file in directory `dir`.  Returns NULL with *err
 * filled when the directory cannot hold one. */
struct gv_spill *gv_spill_new(const char *dir, struct gv_error *err);

/* The disk (or memory, in a tmpfs) the file takes now: its allocated
 * blocks, which a hole does not take; 0 for NULL. */
uint64_t gv_spill_bytes(const struct gv_spill *s);

/* Close and discard.  NULL does nothing. */
void gv_spill_free(struct gv_spill *s);

/* Write len bytes at offset off (the file grows as needed; what was never
 * written reads as zeros).  Returns 0, or -1 with *err filled (GV_ENOSPC
 * for a full disk or a file size limit). */
int gv_spill_write(struct gv_spill *s, const void *buf, size_t len,
                   uint64_t off, struct gv_error *err);

/* gv_spill_write of `rows` rows of row_len bytes, each `stride` bytes
 * after the previous in buf, end to end at offset off. */
int gv_spill_write_rows(struct gv_spill *s, const void *buf, size_t stride,
                        size_t row_len, size_t rows, uint64_t off,
                        struct gv_error *err);

/* Read len bytes at offset off.  Returns 0, or -1 with *err filled
 * (GV_EIO, also when the file ends first). */
int gv_spill_read(struct gv_spill *s, void *buf, size_t len, uint64_t off,
                  struct gv_error *err);

/* A read-only view of part of the file, mapped instead of copied. */
struct gv_spill_view {
    const uint8_t *data;   /* byte `off` of the file */
    void *addr;            /* the mapping, for gv_spill_unview */
    size_t len;
};

/* Map len > 0 bytes at offset off for reading into *v.  The bytes must
 * have been written (or lie below a size the file was given): a view
 * never reaches past the end of the file.  Returns 0, or -1 where the
 * bytes cannot be mapped (past the end, no address space), and the
 * caller then reads them with gv_spill_read, which says why.  Writes to
 * the file after the view was made are seen through it. */
int gv_spill_view(struct gv_spill *s, uint64_t off, size_t len,
                  struct gv_spill_view *v);

/* Unmap a view; one with addr NULL (never made, or unviewed) is left
 * alone. */
void gv_spill_unview(struct gv_spill_view *v);

#endif
