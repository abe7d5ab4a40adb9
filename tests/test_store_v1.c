/*
 * test_store_v1.c - a store of format version 1 (tests/data/v1-picos-
 * 530x516.gv, written by the version-1 encoder) still opens and decodes:
 * every tile, the root included, to the CRC32 its pixels had under the
 * version-1 decoder.  Its tiles use the layouts of version 1 only (E at
 * rates 8 and 5, prediction alone at rate 0), which version 2 reads
 * unchanged.  Its store identity (gv_store_identity) is pinned.
 */
#include <stdio.h>
#include <stdlib.h>

#include "base/crc32.h"
#include "codec/tile_layout.h"
#include "render/store_decoder.h"
#include "store/store_read.h"
#include "util.h"

/* Level, tile and the CRC32 of its 513x513x3 decoded pixels, as the
 * version-1 reference decoder gave them when the fixture was written. */
static const struct {
    int level;
    uint32_t tx, ty, crc;
    uint8_t byte0;   /* the tile buffer's byte 0: layout and rate */
} want[] = {
    {1, 0, 0, 0x25ef4aa7, 0},   /* the root tile */
    {0, 0, 0, 0xd14d351b, 0x88},
    {0, 1, 0, 0x6906d7da, 0x85},
    {0, 0, 1, 0xede20139, 0x00},
    {0, 1, 1, 0x75019b90, 0x00},
};

int main(void)
{
    const char *data = getenv("TESTDATA") ? getenv("TESTDATA") : "tests/data";
    char path[1024];
    snprintf(path, sizeof path, "%s/v1-picos-530x516.gv", data);
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s)
        fail("open %s: %s", path, err.text);
    const struct gv_store_info *in = gv_store_info(s);
    const struct gv_geometry *g = &in->geometry;
    check(in->header.version == 1 && g->width == 530 && g->height == 516 &&
          g->channels == 3 && g->root == 1,
          "the fixture opens: format version %u, %ux%u, %d channels, root level %d",
          in->header.version, g->width, g->height, g->channels, g->root);
    /* The identity as docs/FORMAT.md section 6 defines it, computed from
     * that description apart from the reader: it must not change, or
     * every ETag of every store would. */
    struct gv_store *again = gv_store_open(path, &err);
    check(gv_store_identity(s) == 0x7f6a4a5c6ce8b45aull && again &&
              gv_store_identity(again) == gv_store_identity(s),
          "identity %016llx (want 7f6a4a5c6ce8b45a), the same opened twice",
          (unsigned long long)gv_store_identity(s));
    gv_store_close(again);
    struct gv_decoder *d = gv_decoder_new(s, 16u << 20);
    if (!d)
        fail("out of memory");
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        const uint8_t *px, *buf = NULL;
        uint8_t *page = NULL;
        size_t plen, tlen;
        int ok = gv_decoder_tile(d, want[i].level, want[i].tx, want[i].ty, &px, &err) == 0;
        uint32_t crc = ok ? gv_crc32(0, px, gv_tile_bytes(3)) : 0;
        if (want[i].level < g->root) {
            if (gv_store_read_page(s, want[i].level, 0, 0, &page, &plen, &err) < 0 ||
                gv_page_tile(page, plen, 3, (int)want[i].tx, (int)want[i].ty, &buf,
                             &tlen, &err) < 0)
                fail("tile %d/%u/%u: %s", want[i].level, want[i].tx, want[i].ty, err.text);
        }
        check(ok && crc == want[i].crc && (!buf || buf[0] == want[i].byte0),
              "tile %d/%u/%u (byte 0 0x%02x) decodes to CRC32 %08x (want %08x)%s%s",
              want[i].level, want[i].tx, want[i].ty, buf ? buf[0] : 0, crc, want[i].crc,
              ok ? "" : ": ", ok ? "" : err.text);
        free(page);
    }
    gv_decoder_free(d);
    gv_store_close(s);
    return tap_done();
}
