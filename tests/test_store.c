/*
 * test_store.c - the store file: write, reopen, read pages and regions,
 * and refuse damaged files (bad CRCs, truncation, versions, hostile
 * offsets) without crashing or reading out of bounds.  Run under ASan or
 * valgrind this is also the memory-safety check of the reader (the root
 * section read again as stored included).  Also the
 * contract of base/atomic_file.h that the writer publishes through.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/atomic_file.h"
#include "render/store_decoder.h"
#include "store/store_read.h"
#include "store/store_write.h"
#include "codec/tile.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

/* A 1100x600 gray store (levels 0 and 1 tiled, 275x150 root), every tile
 * coded at rate 0 except tile 0/1/0 at rate 2, whose indices depend on
 * salt (so stores of different salts differ in pixels alone). */
static int write_store(const char *path, int salt, struct gv_error *err)
{
    struct gv_header h = {0};
    h.width = 1100;
    h.height = 600;
    h.channels = 1;
    h.max_rate = 2;
    h.src_bits = 8;
    h.target_mpsnr = 30000;
    struct gv_store_writer *w = gv_store_writer_new(path, &h, err);
    if (!w)
        return -1;
    struct gv_geometry g;
    gv_geometry_init(&g, 1100, 600, 1, GV_ROOT_MAX);
    static uint8_t zero4[4];
    size_t l2 = gv_tilebuf_size(2, 1);
    uint8_t *r2 = calloc(1, l2);
    r2[0] = 2;
    for (int i = 0; i < 4 * 4; i++)
        r2[1 + i] = (uint8_t)(i * 5 - 40);
    for (size_t k = 17; k < l2; k++)
        r2[k] = (uint8_t)(k * 37 + (size_t)salt);
    for (int k = g.root - 1; k >= 0; k--) {
        const uint8_t *tiles[64] = {0};
        size_t lens[64] = {0};
        for (uint32_t ty = 0; ty < g.level[k].tiles_y; ty++)
            for (uint32_t tx = 0; tx < g.level[k].tiles_x; tx++) {
                int rate2 = k == 0 && tx == 1 && ty == 0;
                tiles[ty * 8 + tx] = rate2 ? r2 : zero4;
                lens[ty * 8 + tx] = rate2 ? l2 : 4;
            }
        if (gv_store_writer_page(w, k, 0, 0, tiles, lens, err) < 0) {
            gv_store_writer_abort(w);
            free(r2);
            return -1;
        }
    }
    uint8_t *root = malloc(275 * 150);
    for (int i = 0; i < 275 * 150; i++)
        root[i] = (uint8_t)(i % 275);
    int rc = gv_store_writer_root(w, root, err);
    free(root);
    free(r2);
    if (rc < 0) {
        gv_store_writer_abort(w);
        return -1;
    }
    return gv_store_writer_finish(w, err);
}

static void spit(const char *path, const uint8_t *b, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b, 1, len, f) != len)
        fail("cannot write %s", path);
    fclose(f);
}

/* Open a store and touch everything in it; returns how many parts failed
 * (open counts as everything). */
static int exercise(const char *path)
{
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s)
        return 1000;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    struct gv_decoder *d = gv_decoder_new(s, 1 << 20);
    int failures = 0;
    for (int k = 0; k < g->root; k++)
        for (uint32_t ty = 0; ty < g->level[k].tiles_y; ty++)
            for (uint32_t tx = 0; tx < g->level[k].tiles_x; tx++) {
                const uint8_t *px;
                failures += gv_decoder_tile(d, k, tx, ty, &px, &err) < 0;
            }
    uint8_t *out = malloc((size_t)g->width * g->height * g->channels);
    failures += gv_decode_region(d, 0, 0, 0, g->width, g->height, out, &err) < 0;
    free(out);
    gv_decoder_free(d);
    gv_store_close(s);
    return failures;
}

/* gv_atomic_file_write: replaces a file whole (an open reader keeps the
 * old bytes), takes opts->mode, and fails with the module's message and
 * errno set, leaving nothing behind. */
static void atomic_file_contract(void)
{
    char p[256], sub[256], missing[256];
    snprintf(p, sizeof p, "%s/af", dir);
    snprintf(sub, sizeof sub, "%s/sub", dir);
    snprintf(missing, sizeof missing, "%s/nodir/af", dir);
    const struct gv_atomic_opts opts = {.module = "af", .mode = 0600};
    struct gv_error err = {0};
    int ok = gv_atomic_file_write(p, "one", 3, &opts, &err) == 0;
    int fd = open(p, O_RDONLY);
    ok = ok && fd >= 0 && gv_atomic_file_write(p, "second", 6, &opts, &err) == 0;
    char old[8] = {0};
    size_t n = 0;
    uint8_t *now = test_read_file(p, &n);
    struct stat st;
    check(ok && read(fd, old, sizeof old) == 3 && memcmp(old, "one", 3) == 0 &&
              now && n == 6 && memcmp(now, "second", 6) == 0 &&
              stat(p, &st) == 0 && (st.st_mode & 0777) == 0600,
          "atomic file: replaced whole, an open reader keeps the old bytes, mode 0600");
    free(now);
    if (fd >= 0)
        close(fd);
    unlink(p);

    errno = 0;
    int rc = gv_atomic_file_write(missing, "x", 1, &opts, &err);
    check(rc == -1 && errno == ENOENT && err.code == GV_EIO &&
              strncmp(err.text, "af: cannot create a file in ", 28) == 0,
          "atomic file: a missing directory fails with errno ENOENT: %s", err.text);

    mkdir(sub, 0755);
    errno = 0;
    rc = gv_atomic_file_write(sub, "x", 1, &opts, &err);
    int e = errno;
    check(rc == -1 && e != 0 && stat(sub, &st) == 0 && S_ISDIR(st.st_mode) &&
              strncmp(err.text, "af: ", 4) == 0,
          "atomic file: a directory is not replaced: %s", err.text);
    rmdir(sub);
}

/* gv_store_identity: the same bytes give the same identity (the store at
 * path, orig: its len bytes, opened twice and as a copy), and a store
 * with a byte-identical header but other pixels gets another. */
static void identity_contract(const char *path, const uint8_t *orig, size_t len)
{
    char other[256], copy[256];
    snprintf(other, sizeof other, "%s/other.gv", dir);
    snprintf(copy, sizeof copy, "%s/copy.gv", dir);
    struct gv_error err = {0};
    struct gv_store *a = gv_store_open(path, &err);
    struct gv_store *a2 = gv_store_open(path, &err);
    spit(copy, orig, len);
    struct gv_store *c = gv_store_open(copy, &err);
    check(a && a2 && c && gv_store_identity(a) == gv_store_identity(a2) &&
              gv_store_identity(a) == gv_store_identity(c),
          "identity: the same file twice, and a copy, give the same identity");

    check(write_store(other, 1, &err) == 0, "identity: write a store with other pixels");
    size_t olen = 0;
    uint8_t *ob = test_read_file(other, &olen);
    struct gv_store *b = gv_store_open(other, &err);
    check(ob && olen == len && memcmp(ob, orig, GV_HEADER_SIZE) == 0 &&
              memcmp(ob, orig, len) != 0,
          "identity: the other store has a byte-identical header, other bytes");
    check(a && b && gv_store_identity(a) != gv_store_identity(b),
          "identity: other pixels under the same header give another identity "
          "(%016llx, %016llx)", a ? (unsigned long long)gv_store_identity(a) : 0,
          b ? (unsigned long long)gv_store_identity(b) : 0);
    free(ob);
    gv_store_close(a);
    gv_store_close(a2);
    gv_store_close(b);
    gv_store_close(c);
    unlink(other);
    unlink(copy);
}

int main(void)
{
    test_tmpdir_new(dir, sizeof dir, "gv-test-store");
    char path[256], bad[256];
    snprintf(path, sizeof path, "%s/a.gv", dir);
    snprintf(bad, sizeof bad, "%s/bad.gv", dir);
    struct gv_error err = {0};

    check(write_store(path, 0, &err) == 0, "write a store");
    struct gv_store *s = gv_store_open(path, &err);
    check(s != NULL, "reopen it");
    if (!s)
        fail("%s", err.text);
    const struct gv_store_info *in = gv_store_info(s);
    check(in->geometry.root == 2 && in->header.pages == 2 && in->geometry.channels == 1,
          "geometry: root level 2, two pages");
    uint32_t w, h;
    const uint8_t *root = gv_store_root(s, 0, &w, &h);
    check(root && w == 275 && h == 150 && root[274] == (uint8_t)274 && root[275] == 0, "root pixels survive");
    const uint8_t *mip = gv_store_root(s, in->geometry.root_mips - 1, &w, &h);
    check(mip && w == 1 && h == 1 && !gv_store_root(s, in->geometry.root_mips, &w, &h),
          "root mips end at 1x1");
    /* The root section as stored (GET .../root?format=webp sends it): a
     * lossless WebP that decodes to the root level (gray: channel 0). */
    uint8_t *webp = NULL, *dec = malloc(275 * 150);
    size_t wlen = 0;
    check(dec && gv_store_read_root_webp(s, &webp, &wlen, &err) == 0 &&
          wlen + 4 == in->header.root_size &&
          gv_root_unpack(webp, wlen, 275, 150, 1, dec, &err) == 0 &&
          memcmp(dec, gv_store_root(s, 0, &w, &h), 275 * 150) == 0,
          "the root's WebP as stored decodes to the root level");
    free(webp);
    free(dec);
    uint8_t *page;
    size_t plen;
    check(gv_store_read_page(s, 0, 0, 0, &page, &plen, &err) == 0, "read page 0/0/0");
    const uint8_t *t;
    size_t tl;
    check(gv_page_tile(page, plen, 1, 1, 0, &t, &tl, &err) == 0 &&
          tl == gv_tilebuf_size(2, 1) && t[0] == 2, "tile 1,0 is the rate-2 buffer");
    gv_error_clear(&err);
    check(gv_page_tile(page, plen, 1, 5, 5, &t, &tl, &err) < 0,
          "slot outside the grid is empty");
    free(page);
    gv_error_clear(&err);
    check(gv_store_read_page(s, 1, 1, 0, &page, &plen, &err) < 0 &&
          err.code == GV_ENOTFOUND, "no page 1/1/0: GV_ENOTFOUND");
    check_str(err.text, "store: no page 1/1/0", "no page 1/1/0: the message");
    gv_store_close(s);
    check(exercise(path) == 0, "every tile and the full region decode");

    size_t len;
    uint8_t *orig = test_read_file(path, &len);
    uint8_t *copy = malloc(len);

    /* A flipped byte inside page 0 (level 0, written last): that page
     * fails, the rest still decodes. */
    struct gv_store *tmp = gv_store_open(path, &err);
    uint64_t off;
    uint32_t psize, pcrc;
    gv_store_page_extent(tmp, gv_page_number(&gv_store_info(tmp)->geometry, 0, 0, 0),
                         &off, &psize, &pcrc);
    gv_store_close(tmp);
    memcpy(copy, orig, len);
    copy[off + psize / 2] ^= 0x40;
    spit(bad, copy, len);
    gv_error_clear(&err);
    s = gv_store_open(bad, &err);
    int page_fails = s && gv_store_read_page(s, 0, 0, 0, &page, &plen, &err) < 0 &&
                     err.code == GV_ECORRUPT;
    check(page_fails, "corrupt page reported: GV_ECORRUPT");
    check_str(err.text, "store: CRC mismatch in page 0/0/0", "corrupt page reported: the message");
    uint8_t *p1;
    check(s && gv_store_read_page(s, 1, 0, 0, &p1, &plen, &err) == 0,
          "the other page still reads");
    if (s && plen)
        free(p1);
    gv_store_close(s);

    memcpy(copy, orig, len);
    copy[8] = 9;
    spit(bad, copy, len);
    gv_error_clear(&err);
    check(!gv_store_open(bad, &err) && err.code == GV_EFORMAT, "bad version: GV_EFORMAT");
    check_str(err.text, "store: format version 9 is not supported (this build reads versions 1 to 7)",
              "bad version: the message");

    /* Version 6 names its root side in bytes 96-97: a store with the
     * 512-pixel root is the same store as version 6 with side 512; sides
     * 0 and 513 are refused, and a side that gives other levels than the
     * header's is corrupt. */
    static const struct { uint16_t side; int opens; const char *text; } sides[] = {
        {512, 1, NULL},
        {0, 0, "store: root side 0 is not 1..512"},
        {513, 0, "store: root side 513 is not 1..512"},
        {64, 0, "store: level count does not match the dimensions"},
    };
    for (size_t i = 0; i < sizeof sides / sizeof sides[0]; i++) {
        memcpy(copy, orig, len);
        gv_put16(copy + 8, 6);
        gv_put16(copy + 96, sides[i].side);
        gv_put32(copy + 124, gv_crc32(0, copy, 124));
        spit(bad, copy, len);
        gv_error_clear(&err);
        struct gv_store *v6 = gv_store_open(bad, &err);
        if (sides[i].opens)
            check(v6 && gv_store_info(v6)->header.root_side == 512 &&
                  gv_store_info(v6)->geometry.root == orig[21],
                  "version 6 with root side 512 opens as the same store");
        else
            check(!v6 && err.code == GV_ECORRUPT && !strcmp(err.text, sides[i].text),
                  "version 6 with root side %u: %s (got %s)", sides[i].side,
                  sides[i].text, err.text);
        gv_store_close(v6);
    }

    char want[512];
    spit(bad, orig, len - 7);
    gv_error_clear(&err);
    check(!gv_store_open(bad, &err) && err.code == GV_ECORRUPT, "truncated: GV_ECORRUPT");
    snprintf(want, sizeof want, "store: file is %zu bytes, header says %zu (truncated?)",
             len - 7, len);
    check_str(err.text, want, "truncated: the message");
    snprintf(want, sizeof want, "store: %s is too short to be a store", bad);
    spit(bad, orig, 100);
    gv_error_clear(&err);
    check(!gv_store_open(bad, &err) && err.code == GV_EFORMAT,
          "truncated inside the header: GV_EFORMAT");
    check_str(err.text, want, "truncated inside the header: the message");
    spit(bad, orig, 0);
    gv_error_clear(&err);
    check(!gv_store_open(bad, &err) && err.code == GV_EFORMAT, "empty file: GV_EFORMAT");
    check_str(err.text, want, "empty file: the message");

    /* Index entry pointing past the end, with a valid index CRC. */
    memcpy(copy, orig, len);
    uint64_t idx = gv_get64(copy + 56);
    gv_put64(copy + idx, (uint64_t)len - 10);
    gv_put32(copy + idx + 2 * 16, gv_crc32(0, copy + idx, 2 * 16));
    spit(bad, copy, len);
    gv_error_clear(&err);
    check(!gv_store_open(bad, &err) && err.code == GV_ECORRUPT,
          "hostile page offset: GV_ECORRUPT");
    check_str(err.text, "store: page 0 lies outside the file", "hostile page offset: the message");

    /* Every single-byte corruption, at a stride: never a crash, and only
     * damage inside the rate-2 tile's indices can go unnoticed by CRCs...
     * which CRCs catch too, so everything must fail somewhere. */
    int undetected = 0, trials = 0;
    for (size_t pos = 0; pos < len; pos += 97, trials++) {
        memcpy(copy, orig, len);
        copy[pos] ^= 0x5a;
        spit(bad, copy, len);
        undetected += exercise(bad) == 0;
    }
    check(undetected == 0, "%d single-byte corruptions, %d undetected", trials, undetected);

    /* Abort leaves nothing; an existing store survives a failed rewrite. */
    struct gv_header hh = {0};
    hh.width = 600;
    hh.height = 600;
    hh.channels = 3;
    struct gv_store_writer *wr = gv_store_writer_new(path, &hh, &err);
    gv_store_writer_abort(wr);
    size_t len2;
    uint8_t *again = test_read_file(path, &len2);
    check(again && len2 == len && memcmp(again, orig, len) == 0,
          "aborted rewrite leaves the old store intact");
    free(again);
    int entries = 0;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "ls -A %s | wc -l", dir);
    FILE *ls = popen(cmd, "r");
    if (ls && fscanf(ls, "%d", &entries) != 1)
        entries = -1;
    if (ls)
        pclose(ls);
    check(entries == 2, "no temporary files left (%d entries)", entries);
    atomic_file_contract();
    snprintf(cmd, sizeof cmd, "ls -A %s | wc -l", dir);
    ls = popen(cmd, "r");
    if (ls && fscanf(ls, "%d", &entries) != 1)
        entries = -1;
    if (ls)
        pclose(ls);
    check(entries == 2, "atomic file: nothing left behind (%d entries)", entries);

    identity_contract(path, orig, len);
    free(orig);
    free(copy);
    test_tmpdir_free(dir);
    return tap_done();
}
