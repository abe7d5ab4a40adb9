/*
 * fuzz_tile.c - libFuzzer target for the tile-buffer checker and decoder.
 *
 * Byte 0 picks the channel count (bit 0: 1 or 3) and the parent quadrant
 * (bits 1-2); the rest is the tile buffer, passed in its own exactly-sized
 * allocation so that any read past its end is caught.  The parent is a
 * fixed pseudo-random 513x513 tile.  A fixed-layout buffer that
 * gv_tilebuf_check accepts must decode, and its indices must all be
 * readable (an entropy-coded one may still fail in its streams, which only
 * decoding validates); one it rejects must be rejected by gv_tile_decode
 * too.  For an entropy-coded buffer of either layout (E, or the context-
 * coded EX of format version 2), the whole-tile unpacker must agree with
 * the row-by-row decoder, and every index it gives must lie inside the
 * codebook.  A layout D buffer (format version 4) that passes the check
 * may still fail in its streams; the coefficient unpacker must agree with
 * the decoder on that.
 */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "store/geometry.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_rans.h"

static uint8_t parent[GV_TILE * GV_TILE * 3];
static uint8_t out[GV_TILE * GV_TILE * 3];
static volatile uint32_t sink;
static uint16_t idx[GV_NBLOCKS];
static int16_t plane[GV_DCT_PLANE * GV_DCT_PLANE * 4];

static void init_parent(void)
{
    static int done;
    if (done)
        return;
    uint32_t x = 12345;
    for (size_t i = 0; i < sizeof parent; i++) {
        x = x * 1103515245u + 12345u;   /* any fixed pattern will do */
        parent[i] = (uint8_t)(x >> 16);
    }
    done = 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > (1u << 20))
        return 0;
    init_parent();
    const int channels = data[0] & 1 ? 3 : 1;
    const int qx = data[0] >> 1 & 1, qy = data[0] >> 2 & 1;
    size_t len = size - 1;
    uint8_t *buf = malloc(len ? len : 1);
    if (!buf)
        return 0;
    memcpy(buf, data + 1, len);

    struct gv_error err = {0};
    int rate = gv_tilebuf_check(buf, len, channels, &err);
    int rc = gv_tile_decode(buf, len, channels, parent, qx, qy, out, &err);
    const int entropy = len > 0 && (buf[0] & GV_TILE_ENTROPY);
    const int dct = len > 0 && gv_tile_is_dct(buf[0]);
    if (rate >= 0 && dct) {
        if ((gv_dct_unpack(buf, len, channels, plane, &err) == 0) != (rc == 0))
            abort();  /* the unpacker and the decoder disagree */
        if (rc == 0)
            sink += out[0] + out[sizeof out / 3 * (size_t)channels - 1];
    } else if (rate >= 0 && entropy) {
        /* The check covers an entropy-coded buffer's layout; its streams
         * are validated while decoding, which may still refuse them. */
        int unpacked = gv_rans_unpack(buf, len, rate, channels, idx, &err) == 0;
        if (unpacked != (rc == 0))
            abort();  /* the two decoders disagree on the streams */
        const uint32_t entries = buf[0] & GV_TILE_CONTEXT
                                     ? (uint32_t)buf[2] | (uint32_t)buf[3] << 8
                                     : 1u << rate;
        for (uint32_t k = 0; unpacked && k < GV_NBLOCKS; k++)
            if (idx[k] >= entries)
                abort();  /* an index past the codebook */
        if (rc == 0)
            sink += out[0] + out[sizeof out / 3 * (size_t)channels - 1];
    } else if (rate >= 0) {
        if (rc != 0)
            abort();  /* checked fixed-layout buffers always decode */
        if ((size_t)gv_tilebuf_size(rate, channels) > len)
            abort();
        if (rate >= 1)
            for (uint32_t k = 0; k < GV_NBLOCKS; k += 97)
                if (gv_tilebuf_index(buf, rate, channels, k) >= 1u << rate)
                    abort();
        sink += out[0] + out[sizeof out / 3 * (size_t)channels - 1];
    } else if (rc == 0) {
        abort();  /* decode accepted what check refused */
    }
    free(buf);
    return 0;
}
