/*
 * atomic_file.c - write a file, then name it (see atomic_file.h).
 *
 * Every failure goes through fail() or fail_nomem(), which fill the error
 * with the caller's module name and leave errno set to the cause, and
 * every exit on failure closes the file through gv_atomic_file_abort,
 * which keeps errno; so the errno contract of the header holds on every
 * path.
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
#include "base/file_io.h"

/* "<module>: <what> <name>: <strerror(errno)>", errno kept. */
static int fail(const struct gv_atomic_file *f, struct gv_error *err,
                const char *what, const char *name)
{
    int e = errno;
    gv_fail_errno(err, e, "%s: %s %s", f->module, what, name);
    errno = e;
    return -1;
}

static int fail_nomem(const struct gv_atomic_file *f, struct gv_error *err)
{
    gv_fail(err, GV_ENOMEM, "%s: out of memory", f->module);
    errno = ENOMEM;
    return -1;
}

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

/* The hidden name beside `path` used where O_TMPFILE is missing, as a
 * mkostemp template; malloc'ed, or NULL. */
static char *hidden_template(const char *dir, const char *path)
{
    char *base = strdup(path);
    if (!base)
        return NULL;
    const char *b = basename(base);
    size_t n = strlen(dir) + strlen(b) + 32;
    char *t = malloc(n);
    if (t)
        snprintf(t, n, "%s/.%s.XXXXXX", dir, b);
    free(base);
    return t;
}

int gv_atomic_file_open_opts(struct gv_atomic_file *f, const char *path,
                             const struct gv_atomic_opts *opts,
                             struct gv_error *err)
{
    memset(f, 0, sizeof *f);
    f->fd = -1;
    f->module = opts && opts->module ? opts->module : "file";
    f->sync = !(opts && opts->no_sync);
    const unsigned mode = opts && opts->mode ? opts->mode : 0644;
    f->path = strdup(path);
    char *tmp = strdup(path);
    f->dir = tmp ? strdup(dirname(tmp)) : NULL;
    free(tmp);
    char *hidden = f->dir ? hidden_template(f->dir, path) : NULL;
    if (!f->path || !f->dir || !hidden) {
        free(hidden);
        fail_nomem(f, err);
        gv_atomic_file_abort(f);
        return -1;
    }
    int named;
    f->fd = gv_open_unnamed(f->dir, mode, hidden, &named);
    if (f->fd < 0) {
        fail(f, err, "cannot create a file in", f->dir);
        free(hidden);
        gv_atomic_file_abort(f);
        return -1;
    }
    if (!named) {
        free(hidden);
        f->unnamed = 1;
        return 0;
    }
    f->tmpname = hidden;
    /* mkostemp makes 0600; give the file the mode O_TMPFILE would. */
    if (fchmod(f->fd, (mode_t)mode) < 0) {
        fail(f, err, "chmod", f->tmpname);
        gv_atomic_file_abort(f);
        return -1;
    }
    return 0;
}

int gv_atomic_file_open(struct gv_atomic_file *f, const char *path,
                        struct gv_error *err)
{
    return gv_atomic_file_open_opts(f, path, NULL, err);
}

int gv_atomic_file_pwrite(struct gv_atomic_file *f, const void *buf,
                          size_t len, uint64_t off, struct gv_error *err)
{
    if (gv_pwrite_full(f->fd, buf, len, off) < 0)
        return fail(f, err, "writing", f->path);
    return 0;
}

/* Give the unnamed file a temporary name beside the target (linkat fails
 * on an existing name, so the target itself is replaced by rename). */
static int link_unnamed(struct gv_atomic_file *f, struct gv_error *err)
{
    char proc[64];
    size_t n = strlen(f->path) + 32;
    char *link = malloc(n);
    if (!link)
        return fail_nomem(f, err);
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", f->fd);
    for (int attempt = 0;; attempt++) {
        snprintf(link, n, "%s.tmp%ld.%d", f->path, (long)getpid(), attempt);
        if (linkat(AT_FDCWD, proc, AT_FDCWD, link, AT_SYMLINK_FOLLOW) == 0)
            break;
        if (errno != EEXIST || attempt > 100) {
            fail(f, err, "cannot name", f->path);
            free(link);
            return -1;
        }
    }
    f->tmpname = link;
    f->unnamed = 0;
    return 0;
}

/* Make the rename durable; a failure leaves a complete file under the
 * final name, so it is not reported. */
static void sync_dir(const char *dir)
{
    int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        fsync(dfd);
        close(dfd);
    }
}

int gv_atomic_file_publish(struct gv_atomic_file *f, struct gv_error *err)
{
    if (f->sync && fsync(f->fd) < 0) {
        fail(f, err, "fsync", f->path);
        goto fail;
    }
    if (f->unnamed && link_unnamed(f, err) < 0)
        goto fail;
    if (rename(f->tmpname, f->path) < 0) {
        fail(f, err, "cannot rename to", f->path);
        goto fail;
    }
    free(f->tmpname);
    f->tmpname = NULL;
    if (f->sync)
        sync_dir(f->dir);
    release(f);
    return 0;
fail:
    gv_atomic_file_abort(f);
    return -1;
}

void gv_atomic_file_abort(struct gv_atomic_file *f)
{
    int e = errno;
    if (f->tmpname)
        unlink(f->tmpname);
    release(f);
    errno = e;
}

int gv_atomic_file_write(const char *path, const void *buf, size_t len,
                         const struct gv_atomic_opts *opts,
                         struct gv_error *err)
{
    struct gv_atomic_file f;
    if (gv_atomic_file_open_opts(&f, path, opts, err) < 0)
        return -1;
    if (gv_atomic_file_pwrite(&f, buf, len, 0, err) < 0) {
        gv_atomic_file_abort(&f);
        return -1;
    }
    return gv_atomic_file_publish(&f, err);
}
