/*
 * file_io.c - the one retry loop around pread(2) and pwrite(2), and the
 * one O_TMPFILE-or-hidden-name rule (see file_io.h).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
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
