/*
 * spill.c - unnamed scratch file for the encoder (see spill.h).
 *
 * The directory's name is kept for error messages only: when the scratch
 * file's file system fills up, the message must say which one (it is
 * --tmpdir, or the output's directory), since the file itself has no
 * name an operator could find.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/file_io.h"
#include "base/spill.h"

struct gv_spill {
    int fd;
    char *dir;   /* where the file lives, for messages */
};

struct gv_spill *gv_spill_new(const char *dir, struct gv_error *err)
{
    struct gv_spill *s = malloc(sizeof *s);
    if (s && !(s->dir = strdup(dir))) {
        free(s);
        s = NULL;
    }
    if (!s) {
        gv_fail(err, GV_ENOMEM, "spill: out of memory");
        return NULL;
    }
    /* Where the file must have a name, it loses it at once. */
    char name[4096];
    int named;
    snprintf(name, sizeof name, "%s/.gigaview-spill.XXXXXX", dir);
    s->fd = gv_open_unnamed(dir, 0600, name, &named);
    if (s->fd >= 0 && named)
        unlink(name);
    if (s->fd < 0) {
        gv_fail_errno(err, errno, "spill: cannot create a scratch file in %s", dir);
        free(s->dir);
        free(s);
        return NULL;
    }
    return s;
}

uint64_t gv_spill_bytes(const struct gv_spill *s)
{
    struct stat st;
    if (!s || fstat(s->fd, &st) != 0)
        return 0;
    return (uint64_t)st.st_blocks * 512;
}

void gv_spill_free(struct gv_spill *s)
{
    if (!s)
        return;
    close(s->fd);
    free(s->dir);
    free(s);
}

int gv_spill_write(struct gv_spill *s, const void *buf, size_t len,
                   uint64_t off, struct gv_error *err)
{
    if (gv_pwrite_full(s->fd, buf, len, off) < 0)
        return gv_fail_errno(err, errno, "spill: writing the scratch file in %s",
                             s->dir);
    return 0;
}

int gv_spill_write_rows(struct gv_spill *s, const void *buf, size_t stride,
                        size_t row_len, size_t rows, uint64_t off,
                        struct gv_error *err)
{
    if (gv_pwrite_rows(s->fd, buf, stride, row_len, rows, off) < 0)
        return gv_fail_errno(err, errno, "spill: writing the scratch file in %s",
                             s->dir);
    return 0;
}

int gv_spill_read(struct gv_spill *s, void *buf, size_t len, uint64_t off,
                  struct gv_error *err)
{
    int rc = gv_pread_full(s->fd, buf, len, off);
    if (rc < 0)
        return gv_fail_errno(err, errno, "spill: reading the scratch file in %s",
                             s->dir);
    if (rc > 0)
        return gv_fail(err, GV_EIO, "spill: the scratch file in %s ends early",
                       s->dir);
    return 0;
}

int gv_spill_view(struct gv_spill *s, uint64_t off, size_t len,
                  struct gv_spill_view *v)
{
    v->addr = NULL;
    struct stat st;
    if (!len || fstat(s->fd, &st) < 0 || st.st_size < 0 ||
        off > (uint64_t)st.st_size || len > (uint64_t)st.st_size - off)
        return -1;   /* touching a page past the end would raise SIGBUS */
    const long page = sysconf(_SC_PAGESIZE);
    const uint64_t start = off - off % (uint64_t)(page > 0 ? page : 4096);
    const size_t span = (size_t)(off - start) + len;
    void *addr = mmap(NULL, span, PROT_READ, MAP_SHARED, s->fd, (off_t)start);
    if (addr == MAP_FAILED)
        return -1;
    v->addr = addr;
    v->len = span;
    v->data = (const uint8_t *)addr + (off - start);
    return 0;
}

void gv_spill_unview(struct gv_spill_view *v)
{
    if (v->addr)
        munmap(v->addr, v->len);
    v->addr = NULL;
}
