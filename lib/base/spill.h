/*
 * spill.h - the encoder's scratch file: every level of the pyramid that
 * pass 1 builds, and the decoded tiles that pass 2 predicts from, live
 * here so that the encoder's memory does not grow with the image.
 *
 * The file is created unnamed (O_TMPFILE, file_io.h) so that it vanishes
 * however the encoder ends; where that is unsupported it is created
 * (mode 0600) and unlinked at once.  Reads and writes are positioned
 * (pread/pwrite) and thread-safe.  Error messages start "spill:" and name
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

/* Close and discard.  NULL does nothing. */
void gv_spill_free(struct gv_spill *s);

/* Write len bytes at offset off (the file grows as needed; what was never
 * written reads as zeros).  Returns 0, or -1 with *err filled (GV_ENOSPC
 * for a full disk or a file size limit). */
int gv_spill_write(struct gv_spill *s, const void *buf, size_t len,
                   uint64_t off, struct gv_error *err);

/* Read len bytes at offset off.  Returns 0, or -1 with *err filled
 * (GV_EIO, also when the file ends first). */
int gv_spill_read(struct gv_spill *s, void *buf, size_t len, uint64_t off,
                  struct gv_error *err);

#endif
