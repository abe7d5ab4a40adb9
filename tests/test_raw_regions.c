/*
 * test_raw_regions.c - lib/imageio/raw_regions.c: rectangles of a file of
 * uncompressed blocks against the pixels the file was written from, and
 * the layouts and files it must refuse.
 *
 * Files are written here in a made-up order (blocks shuffled, gaps and
 * trailing bytes between them) from a pattern whose every byte depends
 * on (x, y, channel), so that a byte read from the wrong place shows.
 * Layouts: tiles that overhang both edges; tiles so tall that a run of
 * rows takes more than one preadv; strips as wide as the image (each
 * row read alone), the last one short; one-pixel blocks.  Every
 * rectangle of a random set, and the ones at the edges and corners, must
 * match the pattern.  Refused at creation (NULL with GV_OK: the caller
 * reads through the decoder): a block past the end of the file, a byte
 * count short of the block, a grid that does not cover the image.  After
 * the file is cut short, a read of a lost block fails with GV_ECORRUPT
 * (no SIGBUS: nothing is mapped); a rectangle outside the image fails
 * with GV_EINVAL.  gv_raw_regions_unchanged says a file whose
 * modification time or size changed since the reader was made has
 * changed.
 */
#include <fcntl.h>
#include <stdint.h>
#include <sys/stat.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "imageio/raw_regions.h"
#include "test_env.h"
#include "util.h"

static uint8_t pattern(uint32_t x, uint32_t y, int c)
{
    uint32_t h = x * 0x9e3779b1u ^ (y + 77u) * 0x85ebca77u ^ (uint32_t)c * 0xc2b2ae3du;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    return (uint8_t)(h >> 24);
}

struct made {
    struct gv_raw_layout l;
    uint64_t *offsets, *counts;
    int fd;
    uint64_t size;
};

/* Write `path` with the blocks of l (offsets and counts filled here) in
 * a shuffled order, 0..99 junk bytes before each block and after the
 * last; a strip layout (short_last_row) stores its last strip short. */
static void make_file(const char *path, struct made *m, uint64_t *rng)
{
    struct gv_raw_layout *l = &m->l;
    const size_t n = (size_t)l->across * l->down;
    m->offsets = calloc(n, sizeof *m->offsets);
    m->counts = calloc(n, sizeof *m->counts);
    size_t *order = malloc(n * sizeof *order);
    if (!m->offsets || !m->counts || !order)
        fail("out of memory");
    for (size_t k = 0; k < n; k++)
        order[k] = k;
    for (size_t k = n; k > 1; k--) {
        size_t j = test_rand(rng) % k, t = order[k - 1];
        order[k - 1] = order[j];
        order[j] = t;
    }
    m->fd = open(path, O_RDWR | O_CREAT | O_TRUNC, 0600);
    if (m->fd < 0)
        fail("open %s", path);
    const size_t pb = (size_t)l->pixel_bytes;
    uint8_t *block = malloc((size_t)l->block_w * l->block_h * pb);
    if (!block)
        fail("out of memory");
    uint64_t at = 0;
    for (size_t k = 0; k < n; k++) {
        const uint32_t bx = (uint32_t)(order[k] % l->across);
        const uint32_t by = (uint32_t)(order[k] / l->across);
        uint32_t rows = l->block_h;
        if (l->short_last_row && by + 1 == l->down)
            rows = l->height - by * l->block_h;
        size_t len = 0;
        for (uint32_t v = 0; v < rows; v++)
            for (uint32_t u = 0; u < l->block_w; u++)
                for (size_t c = 0; c < pb; c++)
                    block[len++] = pattern(bx * l->block_w + u,
                                           by * l->block_h + v, (int)c);
        at += test_rand(rng) % 100;
        if (pwrite(m->fd, block, len, (off_t)at) != (ssize_t)len)
            fail("pwrite");
        m->offsets[order[k]] = at;
        m->counts[order[k]] = len;
        at += len;
    }
    at += test_rand(rng) % 100;
    if (ftruncate(m->fd, (off_t)at) != 0)
        fail("ftruncate");
    m->size = at;
    l->offsets = m->offsets;
    l->byte_counts = m->counts;
    free(block);
    free(order);
}

static void free_made(struct made *m)
{
    close(m->fd);
    free(m->offsets);
    free(m->counts);
}

/* Read (x, y, w, h) into a buffer with a stride of w * pb + 7 and compare
 * it with the pattern; 1 when every byte matches. */
static int rect_ok(const struct gv_raw_regions *r, const struct gv_raw_layout *l,
                   uint32_t x, uint32_t y, uint32_t w, uint32_t h)
{
    const size_t pb = (size_t)l->pixel_bytes, stride = w * pb + 7;
    uint8_t *buf = malloc(stride * h);
    if (!buf)
        fail("out of memory");
    memset(buf, 0xAB, stride * h);
    struct gv_error err = {0};
    int ok = gv_raw_regions_read(r, x, y, w, h, buf, stride, &err) == 0;
    if (!ok)
        printf("# read (%u, %u) %ux%u: %s\n", x, y, w, h, err.text);
    for (uint32_t v = 0; ok && v < h; v++) {
        for (uint32_t u = 0; ok && u < w; u++)
            for (size_t c = 0; c < pb; c++)
                if (buf[v * stride + u * pb + c] != pattern(x + u, y + v, (int)c)) {
                    printf("# (%u, %u) channel %zu differs\n", x + u, y + v, c);
                    ok = 0;
                    break;
                }
        /* the stride's padding is never written */
        for (size_t p = w * pb; ok && p < stride; p++)
            ok = buf[v * stride + p] == 0xAB;
    }
    free(buf);
    return ok;
}

/* Every rectangle of a set: edges, corners, the whole image, and 60
 * random ones (some large). */
static void check_layout(const char *dir, const char *name,
                         struct gv_raw_layout l, uint64_t seed)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    struct made m = {.l = l};
    uint64_t rng = seed;
    make_file(path, &m, &rng);
    struct gv_error err = {0};
    struct gv_raw_regions *r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    if (!check(r != NULL, "%s: a reader is made", name)) {
        free_made(&m);
        return;
    }
    uint32_t W = l.width, H = l.height, w, h;
    int pb;
    gv_raw_regions_size(r, &w, &h, &pb);
    check(w == W && h == H && pb == l.pixel_bytes, "%s: its size", name);
    int all = rect_ok(r, &m.l, 0, 0, W, H);
    all &= rect_ok(r, &m.l, W - 1, H - 1, 1, 1);
    all &= rect_ok(r, &m.l, 0, H - 1, W, 1);
    all &= rect_ok(r, &m.l, W - 1, 0, 1, H);
    check(all, "%s: the whole image, the last pixel, row and column", name);
    int good = 1;
    for (int k = 0; k < 60; k++) {
        uint32_t x = test_rand(&rng) % W, y = test_rand(&rng) % H;
        uint32_t rw = 1 + test_rand(&rng) % (W - x), rh = 1 + test_rand(&rng) % (H - y);
        good &= rect_ok(r, &m.l, x, y, rw, rh);
    }
    check(good, "%s: 60 random rectangles", name);
    gv_raw_regions_free(r);
    free_made(&m);
}

int main(void)
{
    char dir[4096];
    test_tmpdir_new(dir, sizeof dir, "gv-raw-regions");

    /* Tiles that overhang both edges, RGB. */
    check_layout(dir, "tiles", (struct gv_raw_layout){
        .width = 300, .height = 190, .pixel_bytes = 3, .block_w = 64,
        .block_h = 48, .across = 5, .down = 4}, 11);
    /* Gray tiles of 16 x 1100: a run of rows takes more than one preadv. */
    check_layout(dir, "tall", (struct gv_raw_layout){
        .width = 70, .height = 1100, .pixel_bytes = 1, .block_w = 16,
        .block_h = 1100, .across = 5, .down = 1}, 12);
    /* Strips as wide as the image, a short last strip: where a row's
     * part is far from the next (2000 x 3 bytes), each is read alone. */
    check_layout(dir, "strips", (struct gv_raw_layout){
        .width = 2000, .height = 37, .pixel_bytes = 3, .block_w = 2000,
        .block_h = 5, .across = 1, .down = 8, .short_last_row = 1}, 13);
    /* One-pixel blocks of 4 bytes. */
    check_layout(dir, "pixels", (struct gv_raw_layout){
        .width = 9, .height = 7, .pixel_bytes = 4, .block_w = 1,
        .block_h = 1, .across = 9, .down = 7}, 14);

    /* Refusals at creation: NULL with GV_OK, so the caller decodes. */
    struct gv_raw_layout base = {.width = 100, .height = 60, .pixel_bytes = 3,
                                 .block_w = 32, .block_h = 32, .across = 4,
                                 .down = 2};
    char path[4200];
    snprintf(path, sizeof path, "%s/bad", dir);
    struct made m = {.l = base};
    uint64_t rng = 21;
    make_file(path, &m, &rng);
    struct gv_error err = {0};
    struct gv_raw_regions *r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    check(r != NULL, "the file for the refusals is readable as written");
    gv_raw_regions_free(r);
    const size_t last = 7;
    const uint64_t keep_off = m.offsets[last], keep_count = m.counts[last];
    m.offsets[last] = m.size - m.counts[last] + 1;
    r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    check(!r && err.code == GV_OK, "a block one byte past the end of the file: declined");
    m.offsets[last] = UINT64_MAX - 5;
    r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    check(!r && err.code == GV_OK, "a block at offset 2^64 - 6: declined");
    m.offsets[last] = keep_off;
    m.counts[last] = keep_count - 1;
    r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    check(!r && err.code == GV_OK, "a byte count one short of the block: declined");
    m.counts[last] = keep_count;
    struct gv_raw_layout odd = m.l;
    odd.across = 3;
    r = gv_raw_regions_new(m.fd, path, &odd, &err);
    check(!r && err.code == GV_OK, "a grid one block short of the width: declined");
    odd = m.l;
    odd.block_w = 0x80000000u;
    odd.block_h = 0x20000000u;
    odd.across = 1;
    odd.down = 1;
    odd.pixel_bytes = 16;
    r = gv_raw_regions_new(m.fd, path, &odd, &err);
    check(!r && err.code == GV_OK, "blocks of 2^31 x 2^29 pixels of 16 bytes "
          "(2^64 bytes, 0 in 64 bits): declined");
    odd = m.l;
    odd.block_w = 0;
    r = gv_raw_regions_new(m.fd, path, &odd, &err);
    check(!r && err.code == GV_OK, "blocks 0 pixels wide: declined");
    int pipefd[2];
    if (pipe(pipefd) != 0)
        fail("pipe");
    r = gv_raw_regions_new(pipefd[0], path, &m.l, &err);
    check(!r && err.code == GV_OK, "a pipe, not a regular file: declined");
    close(pipefd[0]);
    close(pipefd[1]);

    /* A reader outlives the caller's descriptor, and a file cut short
     * later gives an error, not a signal. */
    r = gv_raw_regions_new(m.fd, path, &m.l, &err);
    if (!r)
        fail("reader: %s", err.text);
    close(m.fd);
    m.fd = open(path, O_RDWR);
    check(rect_ok(r, &m.l, 0, 0, 100, 60),
          "the reader reads after the caller closed its descriptor");
    uint8_t px[3 * 100 * 60];
    gv_error_clear(&err);
    check(gv_raw_regions_read(r, 90, 0, 11, 1, px, 33, &err) < 0
              && err.code == GV_EINVAL,
          "a rectangle past the right edge: GV_EINVAL");
    gv_error_clear(&err);
    check(gv_raw_regions_read(r, 0, 60, 1, 1, px, 3, &err) < 0
              && err.code == GV_EINVAL,
          "a rectangle below the last row: GV_EINVAL");
    gv_error_clear(&err);
    check(gv_raw_regions_read(r, 0, 0, 0, 1, px, 3, &err) < 0
              && err.code == GV_EINVAL,
          "an empty rectangle: GV_EINVAL");
    check(gv_raw_regions_unchanged(r, &err) == 0,
          "the file as it was: unchanged");
    struct stat st;
    if (fstat(m.fd, &st) != 0)
        fail("fstat");
    struct timespec times[2] = {st.st_atim, st.st_mtim};
    times[1].tv_sec -= 10;
    if (futimens(m.fd, times) != 0)
        fail("futimens");
    gv_error_clear(&err);
    check(gv_raw_regions_unchanged(r, &err) < 0 && err.code == GV_ECORRUPT
              && strstr(err.text, "changed while being read"),
          "a new modification time: changed (%s)", err.text);
    times[1] = st.st_mtim;
    if (futimens(m.fd, times) != 0)
        fail("futimens");
    check(gv_raw_regions_unchanged(r, &err) == 0,
          "the modification time put back: unchanged");
    uint64_t first = UINT64_MAX;
    for (size_t k = 0; k < 8; k++)
        first = m.offsets[k] < first ? m.offsets[k] : first;
    if (ftruncate(m.fd, (off_t)first + 10) != 0)
        fail("ftruncate");
    gv_error_clear(&err);
    check(gv_raw_regions_read(r, 0, 0, 100, 60, px, 300, &err) < 0
              && err.code == GV_ECORRUPT && strstr(err.text, "ends before"),
          "the file cut short: GV_ECORRUPT (%s)", err.text);
    if (futimens(m.fd, times) != 0)
        fail("futimens");
    gv_error_clear(&err);
    check(gv_raw_regions_unchanged(r, &err) < 0 && err.code == GV_ECORRUPT,
          "the file cut short, its time put back: changed (size)");
    gv_raw_regions_free(r);
    gv_raw_regions_free(NULL);
    free_made(&m);
    test_tmpdir_free(dir);
    return tap_done();
}
