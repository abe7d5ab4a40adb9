/*
 * file_io.h - whole positioned reads and writes on a file descriptor, and
 * files created without a name.
 *
 * pread(2) and pwrite(2) may move fewer bytes than asked, or be
 * interrupted by a signal (EINTR); these loop until the whole buffer is
 * done.  They fill no struct gv_error: every caller words its own message
 * (the module, and the file as its user knows it) from errno, so that one
 * loop serves the store, the shards, the scratch file and atomic files.
 * Thread-safe: nothing moves the file offset.
 *
 * gv_open_unnamed is the one place that decides when the file system lacks
 * O_TMPFILE and a hidden name must do instead (the scratch file and
 * atomic_file.h both start from it).
 */
#ifndef GV_FILE_IO_H
#define GV_FILE_IO_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Read len bytes at offset off into buf.  Returns 0 when all were read,
 * 1 when the file ends first (buf then holds what there was), or -1 with
 * errno set. */
int gv_pread_full(int fd, void *buf, size_t len, uint64_t off);

/* Write len bytes from buf at offset off.  Returns 0, or -1 with errno
 * set (part of the bytes may have been written). */
int gv_pwrite_full(int fd, const void *buf, size_t len, uint64_t off);

/* Write `rows` rows of row_len bytes each, the first at buf and each
 * next one `stride` bytes after the previous, end to end at offset off
 * (a column strip of an image into a file of strips).  Returns 0, or -1
 * with errno set. */
int gv_pwrite_rows(int fd, const void *buf, size_t stride, size_t row_len,
                   size_t rows, uint64_t off);

/*
 * Create a file with no name in directory `dir` (O_TMPFILE: it vanishes
 * when closed unless linked), open for reading and writing, close-on-exec,
 * with permission bits `mode` less the umask.  Where the file system has
 * no O_TMPFILE, create it instead under `fallback`, a path in `dir` ending
 * in "XXXXXX" that mkostemp(3) rewrites in place (mode 0600, umask
 * ignored).  Returns the descriptor and sets *named to 0 (no name) or 1
 * (the file is called `fallback`; the caller unlinks or renames it), or
 * returns -1 with errno set and nothing created.
 */
int gv_open_unnamed(const char *dir, unsigned mode, char *fallback, int *named);

#ifdef __cplusplus
}
#endif

#endif
