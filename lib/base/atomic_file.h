/*
 * atomic_file.h - a file that appears under its name only when complete.
 *
 * The one way gigaview publishes a file: stores (store_write.c), shard
 * files, written images (imageio), the client's disk cache and stored
 * filter graphs.  The file is created without a name (O_TMPFILE) in the
 * destination directory, or under a hidden name ".<name>.XXXXXX" beside
 * it where the file system lacks O_TMPFILE (file_io.h, gv_open_unnamed).
 * The caller writes it at any offsets; gv_atomic_file_publish then fsyncs
 * it, gives it its final name and fsyncs the directory (docs/FORMAT.md,
 * section 6).
 *
 * Contract of a publish to `path`:
 *  - Until the rename, a reader of `path` sees the old file (or none),
 *    never a partial new one.  A crash or kill before the rename leaves
 *    no new file under `path`.  What it may leave beside it: with
 *    O_TMPFILE nothing, except a complete "<path>.tmp<pid>.<n>" when it
 *    comes between the linkat and the rename (below); without O_TMPFILE,
 *    the hidden ".<name>.XXXXXX".  gv_atomic_file_abort and every failure
 *    remove what they made.
 *  - Replace: an existing file (or symbolic link) at `path` is replaced
 *    whole by rename(2), atomically: a reader that opened the old file
 *    keeps reading the old bytes, and an open after the rename gets the
 *    new ones.  An existing directory at `path` is not replaced (publish
 *    fails, EISDIR).  The file takes the permission bits of opts->mode,
 *    not those of the file it replaces.
 *  - Publishers of the same `path`, in threads of one process or in
 *    several processes, each publish whole files; the last rename wins.
 *  - The unnamed file is named by linkat(2) through /proc/self/fd to
 *    "<path>.tmp<pid>.<n>" (n the first free number), then renamed over
 *    `path`; so /proc must be mounted where O_TMPFILE is used.
 *  - Durability (unless opts->no_sync): the file is fsynced before it is
 *    named, and the directory after the rename.  A failure to fsync the
 *    directory is not reported: the file is complete under its name
 *    either way.
 *
 * Errors: every function that fails returns -1, fills *err (which may be
 * NULL) with a message "<module>: ..." naming the file or its directory,
 * with the code of gv_fail_errno (GV_ENOSPC for a full disk or a file
 * size limit, GV_EIO otherwise; GV_ENOMEM for memory), and leaves errno
 * set to the cause (ENOMEM for memory), so that a caller may word its own
 * message instead.
 *
 * One thread uses a gv_atomic_file at a time; distinct ones are
 * independent.
 */
#ifndef GV_ATOMIC_FILE_H
#define GV_ATOMIC_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* How a file is created and published.  A zeroed struct (or NULL where a
 * function takes a pointer) means: messages start "file:", mode 0644,
 * fsync. */
struct gv_atomic_opts {
    const char *module;  /* first word of error messages, e.g. "store";
                          * must outlive the file (a string literal) */
    unsigned mode;       /* permission bits of the published file (less the
                          * umask where O_TMPFILE is used); 0: 0644 */
    int no_sync;         /* nonzero: no fsync of the file or the directory
                          * (a cache that checks its entries can afford to
                          * lose them in a crash) */
};

/* Public so that callers can embed it; the fields are private. */
struct gv_atomic_file {
    int fd;                   /* -1 when closed */
    int unnamed;              /* 1: O_TMPFILE, no name yet */
    int sync;                 /* 1: fsync at publish */
    const char *module;
    char *path, *dir, *tmpname;
};

/* Create the unnamed file that will become `path`, with the options in
 * *opts (NULL: the defaults).  Returns 0, or -1 with *err filled and *f
 * closed. */
int gv_atomic_file_open_opts(struct gv_atomic_file *f, const char *path,
                             const struct gv_atomic_opts *opts,
                             struct gv_error *err);

/* gv_atomic_file_open_opts with the defaults. */
int gv_atomic_file_open(struct gv_atomic_file *f, const char *path,
                        struct gv_error *err);

/* Write len bytes at offset off (all of them, retrying short writes).
 * Returns 0, or -1 with *err filled; *f stays open either way. */
int gv_atomic_file_pwrite(struct gv_atomic_file *f, const void *buf,
                          size_t len, uint64_t off, struct gv_error *err);

/* Publish under the final name and close.  Returns 0, or -1 with *err
 * filled; on failure nothing is published, the temporary name (if any) is
 * removed, and *f is closed. */
int gv_atomic_file_publish(struct gv_atomic_file *f, struct gv_error *err);

/* Abandon: remove the temporary name (if any) and close.  Safe on a
 * closed file; leaves errno as it was. */
void gv_atomic_file_abort(struct gv_atomic_file *f);

/* Open, write the len bytes of buf, publish: a whole file in one call.
 * Returns 0, or -1 with *err filled and nothing published. */
int gv_atomic_file_write(const char *path, const void *buf, size_t len,
                         const struct gv_atomic_opts *opts,
                         struct gv_error *err);

#ifdef __cplusplus
}
#endif

#endif
