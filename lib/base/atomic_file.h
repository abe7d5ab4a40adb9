/*
 * atomic_file.h - a file that appears under its name only when complete.
 *
 * The file is created unnamed (O_TMPFILE) in the destination directory,
 * or under a hidden temporary name beside it where the filesystem lacks
 * O_TMPFILE.  gv_atomic_file_publish fsyncs it, gives it its final name
 * (linkat to a temporary name, then rename over the target, so an existing
 * file is replaced whole) and fsyncs the directory.  A crash or kill
 * before that leaves nothing under the final name.  This is the protocol
 * of store_write.c (docs/FORMAT.md, section 6), for the shard files of a
 * distributed encode.  One thread uses a file at a time.
 */
#ifndef GV_ATOMIC_FILE_H
#define GV_ATOMIC_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

struct gv_atomic_file {
    int fd;                   /* -1 when closed */
    int unnamed;              /* 1: O_TMPFILE, no name yet */
    char *path, *dir, *tmpname;
};

/* Create the unnamed file that will become `path` (mode 0644).  Returns 0,
 * or -1 with *err filled and *f closed. */
int gv_atomic_file_open(struct gv_atomic_file *f, const char *path,
                        struct gv_error *err);

/* Write len bytes at offset off (all of them, retrying short writes). */
int gv_atomic_file_pwrite(struct gv_atomic_file *f, const void *buf,
                          size_t len, uint64_t off, struct gv_error *err);

/* Publish under the final name and close.  On failure nothing is
 * published, the temporary name (if any) is removed, and *f is closed. */
int gv_atomic_file_publish(struct gv_atomic_file *f, struct gv_error *err);

/* Abandon: remove the temporary name (if any) and close.  Safe on a
 * closed file. */
void gv_atomic_file_abort(struct gv_atomic_file *f);

#endif
