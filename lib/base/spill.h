/*
 * spill.h - the encoder's scratch file: pyramid levels and decoded tiles
 * that do not fit the memory bound live here between the two passes.
 *
 * The file is created unnamed (O_TMPFILE) so that it vanishes however the
 * encoder ends; where that is unsupported it is created and unlinked at
 * once.  Reads and writes are positioned (pread/pwrite) and thread-safe.
 */
#ifndef GV_SPILL_H
#define GV_SPILL_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_spill;

/* Create a scratch file in directory `dir`. */
struct gv_spill *gv_spill_new(const char *dir, struct gv_error *err);

/* Close and discard.  NULL does nothing. */
void gv_spill_free(struct gv_spill *s);

int gv_spill_write(struct gv_spill *s, const void *buf, size_t len,
                   uint64_t off, struct gv_error *err);
int gv_spill_read(struct gv_spill *s, void *buf, size_t len, uint64_t off,
                  struct gv_error *err);

#endif
