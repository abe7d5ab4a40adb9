/*
 * file_io.c - the one retry loop around pread(2) and pwrite(2), and the
 * one O_TMPFILE-or-hidden-name rule (see file_io.h).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/uio.h>
#include <unistd.h>

#include "base/file_io.h"

int gv_pread_full(int fd, void *buf, size_t len, uint64_t off)
{
    uint8_t *p = buf;
    while (len > 0) {
        ssize_t n = pread(fd, p, len, (off_t)off);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        if (n == 0)
            return 1;
        p += n;
        len -= (size_t)n;
        off += (uint64_t)n;
    }
    return 0;
}

int gv_pwrite_full(int fd, const void *buf, size_t len, uint64_t off)
{
    /* At most 64 KiB a call: the kernel copied larger writes into the
     * page cache several times slower (perf on this machine's ext4: one
     * 8 MiB write 7 times, writes of 127 KiB rows or of 790 KiB tiles 5 to
     * 6 times the cost per byte of 64 KiB ones). */
    const size_t most = 64u << 10;
    const uint8_t *p = buf;
    while (len > 0) {
        ssize_t n = pwrite(fd, p, len < most ? len : most, (off_t)off);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        p += n;
        len -= (size_t)n;
        off += (uint64_t)n;
    }
    return 0;
}

int gv_pwrite_rows(int fd, const void *buf, size_t stride, size_t row_len,
                   size_t rows, uint64_t off)
{
    /* Gathered by pwritev, at most 64 KiB a call as gv_pwrite_full does
     * (and at least one row); what a short write leaves is written by
     * gv_pwrite_full. */
    enum { MOST = 64u << 10, IOVS = 64 };
    const uint8_t *p = buf;
    while (rows > 0) {
        struct iovec iov[IOVS];
        int n = 0;
        size_t total = 0;
        while ((size_t)n < rows && n < IOVS &&
               (n == 0 || total + row_len <= MOST)) {
            iov[n].iov_base = (void *)(p + (size_t)n * stride);
            iov[n].iov_len = row_len;
            total += row_len;
            n++;
        }
        ssize_t w = pwritev(fd, iov, n, (off_t)off);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        /* Whole rows written, then the rest of a row cut short. */
        size_t whole = (size_t)w / row_len, part = (size_t)w % row_len;
        if (part && gv_pwrite_full(fd, p + whole * stride + part,
                                   row_len - part, off + (uint64_t)w) < 0)
            return -1;
        const size_t done = whole + (part ? 1 : 0);
        p += done * stride;
        rows -= done;
        off += (uint64_t)done * row_len;
    }
    return 0;
}

int gv_open_unnamed(const char *dir, unsigned mode, char *fallback, int *named)
{
    *named = 0;
    int fd = open(dir, O_TMPFILE | O_RDWR | O_CLOEXEC, (mode_t)mode);
    if (fd >= 0)
        return fd;
    /* What a kernel or file system without O_TMPFILE answers; any other
     * error (no such directory, no permission, no space) is final. */
    if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL)
        return -1;
    fd = mkostemp(fallback, O_CLOEXEC);
    if (fd >= 0)
        *named = 1;
    return fd;
}
