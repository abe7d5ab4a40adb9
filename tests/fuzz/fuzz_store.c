/*
 * fuzz_store.c - libFuzzer target for the store reader and the decoder.
 *
 * The input is a whole store file.  It is put in a memfd (the reader
 * takes a path, so it opens /proc/self/fd/N) and then walked the way
 * `gigaview export` and the server would: open and validate, read every
 * root mip, read and check every page and locate every tile slot, decode
 * tiles through the recursive decoder, and decode a region at the far
 * corner of level 0 and one of a root mip - once as given and once with
 * its CRCs recomputed (fix_crcs), so that mutations reach the parsers
 * behind the checksums.  Any crash, sanitizer report,
 * leak or hang is a bug: damaged input must only ever produce an error.
 * Work per input is capped (pages, tiles, region size) so the fuzzer stays
 * fast on inputs that claim huge geometries.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "render/samples_region.h"
#include "render/store_decoder.h"
#include "fuzz.h"
#include "store/store_read.h"
#include "store/store_format.h"

#define MAX_INPUT (4u << 20)   /* larger inputs add nothing but time */
#define MAX_PAGES 64           /* pages read per input */
#define MAX_TILES 12           /* tiles decoded per input (~1 ms each) */
#define MAX_REGION 600         /* region edge: crosses two tile columns */

static volatile uint32_t sink;  /* keeps reads of decoded bytes alive */

static void touch(const uint8_t *p, size_t n)
{
    uint32_t s = 0;
    for (size_t i = 0; i < n; i += 61)
        s += p[i];
    if (n)
        s += p[n - 1];
    sink += s;
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w <= 0)
            return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

static void walk(struct gv_store *s)
{
    struct gv_error err = {0};
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    const int c = g->channels;

    /* Every root mip, then one past the end (must be NULL). */
    uint32_t w, h;
    int m;
    for (m = 0; m < g->root_mips; m++) {
        const uint8_t *px = gv_store_root(s, m, &w, &h);
        if (px)
            touch(px, (size_t)w * h * c);
    }
    if (gv_store_root(s, m, &w, &h))
        abort();

    /* Pages, their tables and every tile slot. */
    int pages = 0;
    for (int level = 0; level < g->root && pages < MAX_PAGES; level++) {
        const struct gv_level *l = &g->level[level];
        for (uint32_t py = 0; py < l->pages_y && pages < MAX_PAGES; py++)
            for (uint32_t px = 0; px < l->pages_x && pages < MAX_PAGES; px++) {
                uint8_t *page;
                size_t len;
                pages++;
                if (gv_store_read_page(s, level, px, py, &page, &len, &err) < 0)
                    continue;
                if (gv_page_check(s, page, len, level, px, py, &err) == 0)
                    for (int j = 0; j < GV_PAGE_TILES; j++)
                        for (int i = 0; i < GV_PAGE_TILES; i++) {
                            const uint8_t *t;
                            size_t tl;
                            if (gv_page_tile(page, len, c, i, j, &t, &tl, &err) == 0)
                                touch(t, tl);
                        }
                free(page);
            }
    }
    uint64_t off;
    uint32_t size, crc;
    (void)gv_store_page_extent(s, g->pages, &off, &size, &crc);
    for (int level = 0; level <= g->root; level++)
        sink += (uint32_t)gv_store_level_bytes(s, level);

    /* Tiles through the decoder: the first and last of each level. */
    struct gv_decoder *d = gv_decoder_new(s, 4u << 20);
    if (!d)
        return;
    int tiles = 0;
    for (int level = g->root - 1; level >= 0 && tiles < MAX_TILES; level--) {
        const struct gv_level *l = &g->level[level];
        const uint8_t *px;
        if (gv_decoder_tile(d, level, 0, 0, &px, &err) == 0)
            touch(px, gv_tile_bytes(c));
        tiles++;
        if (l->tiles_x > 1 || l->tiles_y > 1) {
            if (gv_decoder_tile(d, level, l->tiles_x - 1, l->tiles_y - 1, &px,
                                &err) == 0)
                touch(px, gv_tile_bytes(c));
            tiles++;
        }
    }
    /* Out of range must fail, not crash. */
    const uint8_t *px;
    if (g->root > 0 &&
        gv_decoder_tile(d, 0, g->level[0].tiles_x, 0, &px, &err) == 0)
        abort();

    /* A region at the bottom-right corner of level 0, and of a root mip. */
    int levels[2] = {0, g->root + (g->root_mips > 1 ? 1 : 0)};
    for (int k = 0; k < 2; k++) {
        int level = levels[k];
        uint32_t lw, lh;
        if (level >= g->root) {
            if (!gv_store_root(s, level - g->root, &lw, &lh))
                continue;
        } else {
            lw = g->level[level].width;
            lh = g->level[level].height;
        }
        uint32_t rw = lw < MAX_REGION ? lw : MAX_REGION;
        uint32_t rh = lh < MAX_REGION ? lh : MAX_REGION;
        /* 8-bit pixels: a sample store's are gray or RGB */
        const int dc = gv_display_channels(&gv_store_info(s)->header);
        uint8_t *out = malloc((size_t)rw * rh * dc);
        if (!out)
            continue;
        if (gv_decode_region(d, level, lw - rw, lh - rh, rw, rh, out, &err) == 0)
            touch(out, (size_t)rw * rh * dc);
        free(out);
    }
    gv_decoder_free(d);
}

/*
 * Every part of a store is covered by a CRC, so almost every mutation
 * would stop at the first check.  fix_crcs rewrites the CRCs that the
 * header's pointers lead to (page CRCs in the index, the index's, the
 * root's, the header's) so that the parsers behind them get fuzzed too.
 * Returns 1 if it changed anything.
 */
static int put_crc(uint8_t *d, size_t size, uint64_t off, uint64_t len,
                   uint64_t at)
{
    if (off > size || len > size - off || at > size || size - at < 4)
        return 0;
    uint32_t crc = gv_crc32(0, d + off, (size_t)len);
    if (gv_get32(d + at) == crc)
        return 0;
    gv_put32(d + at, crc);
    return 1;
}

static int fix_crcs(uint8_t *d, size_t size)
{
    if (size < GV_HEADER_SIZE)
        return 0;
    int changed = 0;
    uint64_t index = gv_get64(d + 56), pages = gv_get64(d + 64);
    if (index <= size && pages <= (size - index) / GV_INDEX_ENTRY) {
        for (uint64_t p = 0; p < pages; p++) {
            uint8_t *e = d + index + p * GV_INDEX_ENTRY;
            changed |= put_crc(d, size, gv_get64(e), gv_get32(e + 8),
                               index + p * GV_INDEX_ENTRY + 12);
        }
        changed |= put_crc(d, size, index, pages * GV_INDEX_ENTRY,
                           index + pages * GV_INDEX_ENTRY);
    }
    uint64_t root = gv_get64(d + 40), root_size = gv_get64(d + 48);
    if (root_size >= 4)
        changed |= put_crc(d, size, root, root_size - 4, root + root_size - 4);
    changed |= put_crc(d, size, 0, 124, 124);
    return changed;
}

static void open_and_walk(const uint8_t *data, size_t size)
{
    int fd = memfd_create("fuzz_store", MFD_CLOEXEC);
    if (fd < 0) {
        perror("memfd_create");
        abort();
    }
    if (write_all(fd, data, size) < 0) {
        perror("write");
        abort();
    }
    char path[64];
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    struct gv_error err = {0};
    gv_error_clear(&err);
    struct gv_store *s = gv_store_open(path, &err);
    if (s) {
        walk(s);
        gv_store_close(s);
    } else if (err.text[0] == '\0') {
        abort();  /* a failure must say why */
    }
    close(fd);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_INPUT)
        return 0;
    /* As given (the CRC checks themselves), then with the CRCs made to
     * match (everything behind them). */
    open_and_walk(data, size);
    uint8_t *copy = malloc(size ? size : 1);
    if (!copy)
        return 0;
    memcpy(copy, data, size);
    if (fix_crcs(copy, size))
        open_and_walk(copy, size);
    free(copy);
    return 0;
}
