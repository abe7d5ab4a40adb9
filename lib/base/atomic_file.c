/*
 * atomic_file.c - write a file, then name it (see atomic_file.h).
 */
#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/atomic_file.h"

static void release(struct gv_atomic_file *f)
{
    if (f->fd >= 0)
        close(f->fd);
    f->fd = -1;
    free(f->path);
    free(f->dir);
    free(f->tmpname);
    f->path = f->dir = f->tmpname = NULL;
}

int gv_atomic_file_open(struct gv_atomic_file *f, const char *path,
                        struct gv_error *err)
{
    memset(f, 0, sizeof *f);
    f->fd = -1;
    f->path = strdup(path);
    char *tmp = strdup(path);
    f->dir = tmp ? strdup(dirname(tmp)) : NULL;
    free(tmp);
    if (!f->path || !f->dir) {
        release(f);
        return gv_fail(err, GV_ENOMEM, "file: out of memory");
    }
    f->fd = open(f->dir, O_TMPFILE | O_RDWR | O_CLOEXEC, 0644);
    if (f->fd >= 0) {
        f->unnamed = 1;
        return 0;
    }
    if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL) {
        gv_fail_errno(err, errno, "file: cannot create a file in %s", f->dir);
        release(f);
        return -1;
    }
    /* No O_TMPFILE here: a hidden name beside the target. */
    char *base = strdup(path);
    const char *b = base ? basename(base) : "";
    size_t n = strlen(f->dir) + strlen(b) + 32;
    f->tmpname = malloc(n);
    if (!base || !f->tmpname) {
        free(base);
        release(f);
        return gv_fail(err, GV_ENOMEM, "file: out of memory");
    }
    snprintf(f->tmpname, n, "%s/.%s.XXXXXX", f->dir, b);
    free(base);
    f->fd = mkostemp(f->tmpname, O_CLOEXEC);
    if (f->fd < 0) {
        gv_fail_errno(err, errno, "file: cannot create a file in %s", f->dir);
        free(f->tmpname);
        f->tmpname = NULL;
        release(f);
        return -1;
    }
    /* mkostemp makes 0600; match O_TMPFILE's 0644. */
    if (fchmod(f->fd, 0644) < 0) {
        gv_fail_errno(err, errno, "file: chmod %s", f->tmpname);
        gv_atomic_file_abort(f);
        return -1;
    }
    return 0;
}

int gv_atomic_file_pwrite(struct gv_atomic_file *f, const void *buf,
                          size_t len, uint64_t off, struct gv_error *err)
{
    const uint8_t *p = buf;
    while (len > 0) {
        ssize_t n = pwrite(f->fd, p, len, (off_t)off);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return gv_fail_errno(err, errno, "file: writing %s", f->path);
        }
        p += n;
        len -= (size_t)n;
        off += (uint64_t)n;
    }
    return 0;
}

int gv_atomic_file_publish(struct gv_atomic_file *f, struct gv_error *err)
{
    if (fsync(f->fd) < 0) {
        gv_fail_errno(err, errno, "file: fsync %s", f->path);
        goto fail;
    }
    if (f->unnamed) {
        /* Name it beside the target, then rename over the target. */
        char proc[64];
        size_t n = strlen(f->path) + 32;
        char *link = malloc(n);
        if (!link) {
            gv_fail(err, GV_ENOMEM, "file: out of memory");
            goto fail;
        }
        snprintf(proc, sizeof proc, "/proc/self/fd/%d", f->fd);
        for (int attempt = 0;; attempt++) {
            snprintf(link, n, "%s.tmp%ld.%d", f->path, (long)getpid(), attempt);
            if (linkat(AT_FDCWD, proc, AT_FDCWD, link, AT_SYMLINK_FOLLOW) == 0)
                break;
            if (errno != EEXIST || attempt > 100) {
                gv_fail_errno(err, errno, "file: cannot name %s", f->path);
                free(link);
                goto fail;
            }
        }
        f->tmpname = link;
    }
    if (rename(f->tmpname, f->path) < 0) {
        gv_fail_errno(err, errno, "file: cannot rename to %s", f->path);
        goto fail;
    }
    free(f->tmpname);
    f->tmpname = NULL;
    int dfd = open(f->dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        fsync(dfd);
        close(dfd);
    }
    release(f);
    return 0;
fail:
    gv_atomic_file_abort(f);
    return -1;
}

void gv_atomic_file_abort(struct gv_atomic_file *f)
{
    if (f->tmpname)
        unlink(f->tmpname);
    release(f);
}
