/*
 * raw_regions.c - rectangles of an uncompressed image file by positioned
 * reads (see raw_regions.h).
 *
 * A rectangle is read block by block.  Within one block the rows it
 * wants lie row_bytes apart in the file; where the bytes between them
 * (the block's columns left and right of the rectangle) are few, a run
 * of rows is read by one preadv whose vectors put each row's part in its
 * place in dst and the bytes between into a junk buffer, so that a
 * 513 x 513 tile of a file in 128 x 128 tiles takes 25 system calls and
 * no copy of its own.  Where they are many (a file in strips as wide as
 * the image), each row's part is read alone.
 */
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include "imageio/raw_regions.h"

/* Bytes between two rows' parts that a vector of junk may take; more,
 * and the rows are read one by one. */
#define JUNK_BYTES 4096
/* Vectors per preadv: within every system's IOV_MAX (1024 on Linux). */
#define VECTORS 1024

struct gv_raw_regions {
    int fd;
    char *path;
    struct stat made;      /* the file when r was made */
    struct gv_raw_layout l;
    uint64_t *offsets;
};

/* Same shape as gv_store_close in store/store_read.c and gv_shard_close in
 * encode/shard_file.c: deliberately separate, each frees its own struct. */
void gv_raw_regions_free(struct gv_raw_regions *r)
{
    if (!r)
        return;
    if (r->fd >= 0)
        close(r->fd);
    free(r->offsets);
    free(r->path);
    free(r);
}

/* The bytes block (bx, by) needs: all its rows, or in a short last row of
 * blocks the image's rows only. */
static uint64_t block_need(const struct gv_raw_layout *l, uint32_t by)
{
    uint64_t rows = l->block_h;
    if (l->short_last_row && by + 1 == l->down)
        rows = l->height - (uint64_t)by * l->block_h;
    return rows * l->block_w * (uint64_t)l->pixel_bytes;
}

/* Whether *l is self-consistent and every block lies in a file of
 * file_size bytes with at least the bytes it needs stored for it. */
static int layout_fits(const struct gv_raw_layout *l, uint64_t file_size)
{
    if (l->width == 0 || l->height == 0 || l->pixel_bytes < 1
        || l->pixel_bytes > 16 || l->block_w == 0 || l->block_h == 0
        || l->across != (l->width - 1) / l->block_w + 1
        || l->down != (l->height - 1) / l->block_h + 1
        || (uint64_t)l->block_w * (uint64_t)l->pixel_bytes > SIZE_MAX / 2
        || l->block_h > UINT64_MAX / ((uint64_t)l->block_w * l->pixel_bytes))
        return 0;   /* a block's bytes (block_need) must not overflow */
    for (uint32_t by = 0; by < l->down; by++) {
        const uint64_t need = block_need(l, by);
        for (uint32_t bx = 0; bx < l->across; bx++) {
            const size_t k = (size_t)by * l->across + bx;
            const uint64_t off = l->offsets[k];
            if (l->byte_counts[k] < need || off > file_size
                || need > file_size - off)
                return 0;
        }
    }
    return 1;
}

struct gv_raw_regions *gv_raw_regions_new(int fd, const char *path,
                                          const struct gv_raw_layout *l,
                                          struct gv_error *err)
{
    gv_error_clear(err);
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)
        || !layout_fits(l, (uint64_t)st.st_size))
        return NULL;
    struct gv_raw_regions *r = calloc(1, sizeof *r);
    const size_t n = (size_t)l->across * l->down;
    if (r) {
        r->fd = -1;
        r->path = strdup(path);
        r->offsets = malloc(n * sizeof *r->offsets);
    }
    if (!r || !r->path || !r->offsets) {
        gv_raw_regions_free(r);
        gv_fail(err, GV_ENOMEM, "imageio: %s: out of memory", path);
        return NULL;
    }
    r->fd = dup(fd);
    if (r->fd < 0) {
        gv_fail_errno(err, errno, "imageio: %s: cannot reopen", path);
        gv_raw_regions_free(r);
        return NULL;
    }
    memcpy(r->offsets, l->offsets, n * sizeof *r->offsets);
    r->made = st;
    r->l = *l;
    r->l.offsets = r->offsets;
    r->l.byte_counts = NULL;   /* checked; not kept */
    return r;
}

int gv_raw_regions_unchanged(const struct gv_raw_regions *r,
                             struct gv_error *err)
{
    struct stat now;
    if (fstat(r->fd, &now) != 0)
        return gv_fail_errno(err, errno, "imageio: %s: cannot stat", r->path);
    if (now.st_size != r->made.st_size
        || now.st_mtim.tv_sec != r->made.st_mtim.tv_sec
        || now.st_mtim.tv_nsec != r->made.st_mtim.tv_nsec)
        return gv_fail(err, GV_ECORRUPT, "imageio: %s: changed while being "
                       "read (it is read twice: encode a copy, or leave it "
                       "alone until the encode ends)", r->path);
    return 0;
}

void gv_raw_regions_size(const struct gv_raw_regions *r, uint32_t *width,
                         uint32_t *height, int *pixel_bytes)
{
    *width = r->l.width;
    *height = r->l.height;
    *pixel_bytes = r->l.pixel_bytes;
}

static int read_failed(const struct gv_raw_regions *r, ssize_t got,
                       struct gv_error *err)
{
    if (got < 0)
        return gv_fail_errno(err, errno, "imageio: %s: read failed", r->path);
    return gv_fail(err, GV_ECORRUPT, "imageio: %s: the file ends before "
                   "its pixels (cut short while being read?)", r->path);
}

/* One pread of len bytes at off into dst, retried if interrupted. */
static int read_span(const struct gv_raw_regions *r, void *dst, size_t len,
                     uint64_t off, struct gv_error *err)
{
    ssize_t got;
    do
        got = pread(r->fd, dst, len, (off_t)off);
    while (got < 0 && errno == EINTR);
    return (size_t)got == len ? 0 : read_failed(r, got, err);
}

/* Rows r0 .. r0 + n - 1 of one block, `len` bytes from column byte `col`
 * of each (rows row_bytes apart in the file, from the block's offset
 * base), into dst, rows `stride` apart. */
static int read_block_rows(const struct gv_raw_regions *r, uint64_t base,
                           size_t row_bytes, uint32_t r0, uint32_t n,
                           size_t col, size_t len, uint8_t *dst,
                           size_t stride, struct gv_error *err)
{
    const size_t gap = row_bytes - len;
    if (gap > JUNK_BYTES) {
        for (uint32_t i = 0; i < n; i++)
            if (read_span(r, dst + i * stride, len,
                          base + (uint64_t)(r0 + i) * row_bytes + col,
                          err) < 0)
                return -1;
        return 0;
    }
    uint8_t junk[JUNK_BYTES];
    struct iovec v[VECTORS];
    const uint32_t per_call = gap ? VECTORS / 2 : VECTORS;
    for (uint32_t i = 0; i < n;) {
        const uint32_t m = n - i < per_call ? n - i : per_call;
        int nv = 0;
        size_t total = 0;
        for (uint32_t k = 0; k < m; k++) {
            if (k > 0 && gap) {
                v[nv].iov_base = junk;
                v[nv++].iov_len = gap;
                total += gap;
            }
            v[nv].iov_base = dst + (size_t)(i + k) * stride;
            v[nv++].iov_len = len;
            total += len;
        }
        const uint64_t off = base + (uint64_t)(r0 + i) * row_bytes + col;
        ssize_t got;
        do
            got = preadv(r->fd, v, nv, (off_t)off);
        while (got < 0 && errno == EINTR);
        if ((size_t)got != total)
            return read_failed(r, got, err);
        i += m;
    }
    return 0;
}

int gv_raw_regions_read(const struct gv_raw_regions *r, uint32_t x,
                        uint32_t y, uint32_t w, uint32_t h, uint8_t *dst,
                        size_t stride, struct gv_error *err)
{
    const struct gv_raw_layout *l = &r->l;
    if (w == 0 || h == 0 || x >= l->width || y >= l->height
        || w > l->width - x || h > l->height - y)
        return gv_fail(err, GV_EINVAL, "imageio: %s: region %" PRIu32 "x%"
                       PRIu32 " at (%" PRIu32 ", %" PRIu32 ") is outside "
                       "the image", r->path, w, h, x, y);
    const size_t pb = (size_t)l->pixel_bytes;
    const size_t row_bytes = (size_t)l->block_w * pb;
    for (uint32_t by = y / l->block_h; by <= (y + h - 1) / l->block_h; by++) {
        const uint32_t top = by * l->block_h;
        const uint32_t r0 = y > top ? y - top : 0;
        const uint32_t r1 = y + h - top < l->block_h ? y + h - top : l->block_h;
        for (uint32_t bx = x / l->block_w; bx <= (x + w - 1) / l->block_w;
             bx++) {
            const uint32_t left = bx * l->block_w;
            const uint32_t c0 = x > left ? x - left : 0;
            const uint32_t c1 = x + w - left < l->block_w ? x + w - left
                                                          : l->block_w;
            uint8_t *d = dst + (size_t)(top + r0 - y) * stride
                         + (size_t)(left + c0 - x) * pb;
            if (read_block_rows(r, l->offsets[(size_t)by * l->across + bx],
                                row_bytes, r0, r1 - r0, c0 * pb,
                                (c1 - c0) * pb, d, stride, err) < 0)
                return -1;
        }
    }
    return 0;
}
