/*
 * fuzz_height.c - libFuzzer target for the height tile checker and decoder
 * (lib/codec/height_tile.c, docs/FORMAT.md section 12).
 *
 * Byte 0 picks the parent quadrant (bits 0-1); the rest is the tile
 * buffer, in its own exactly-sized allocation so that a read past its end
 * is caught.  The parent is a fixed pseudo-random 513x513 tile of codes.
 * A buffer gv_height_tile_check rejects must be rejected by the decoder
 * too; one the decoder accepts must give the same residuals through
 * gv_height_tile_residuals, and decoding must be deterministic.
 */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "codec/height_tile.h"

static uint16_t parent[GV_HT_SAMPLES];
static uint16_t out[GV_HT_SAMPLES], again[GV_HT_SAMPLES];
static int32_t q[GV_HT_SAMPLES];

static void init_parent(void)
{
    static int done;
    if (done)
        return;
    uint32_t x = 12345;
    for (size_t i = 0; i < GV_HT_SAMPLES; i++) {
        x = x * 1103515245u + 12345u;   /* any fixed pattern will do */
        parent[i] = (uint16_t)(x >> 12);
    }
    done = 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > GV_HT_BUF_MAX + 1)
        return 0;
    init_parent();
    const int qx = data[0] & 1, qy = data[0] >> 1 & 1;
    size_t len = size - 1;
    uint8_t *buf = malloc(len ? len : 1);
    if (!buf)
        return 0;
    memcpy(buf, data + 1, len);
    struct gv_error err = {0};
    int ok = gv_height_tile_check(buf, len, &err) == 0;
    int rc = gv_height_tile_decode(buf, len, parent, qx, qy, out, &err);
    if (!ok && rc == 0)
        abort();   /* the decoder accepted what the checker refused */
    if (rc == 0) {
        int e;
        if (gv_height_tile_residuals(buf, len, q, &e, &err) < 0 ||
            gv_height_tile_decode(buf, len, parent, qx, qy, again, &err) < 0 ||
            memcmp(out, again, sizeof out) != 0)
            abort();
    }
    free(buf);
    return 0;
}
