/*
 * tile_decode.c - tile buffer layout and the CPU reference decoder.
 *
 * This file is the executable form of the tile part of docs/FORMAT.md.
 * Indices are packed LSB-first: bit b of the index stream is bit (b & 7) of
 * byte (b >> 3), which is bit (b & 31) of little-endian 32-bit word
 * (b >> 5), the view a GPU takes.  The stream starts right after the
 * codebook, at bit 8 * (1 + 2^r * 4 * channels).  Entropy-coded buffers
 * are decoded one block row at a time (tile_rans.h), as fixed ones are, so
 * the decoder needs no array of all the indices.  The codebook starts at
 * byte 1, or at byte 4 in the context-coded layout (EX, which stores its
 * context count in byte 1 and codevector count in bytes 2-3).
 */
#include "codec/tile_layout.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_rans.h"

int gv_tilebuf_check(const uint8_t *buf, size_t len, int channels,
                     struct gv_error *err)
{
    if (channels != 1 && channels != 3)
        return gv_fail(err, GV_EINVAL, "tile: bad channel count %d", channels);
    if (len < 4 || (len & 3))
        return gv_fail(err, GV_ECORRUPT, "tile: buffer of %zu bytes is not a "
                       "positive multiple of 4", len);
    if (gv_tile_is_dct(buf[0]))
        return gv_dct_check(buf, len, channels, err) < 0 ? -1 : 0;
    int rate = buf[0] & 0x0f;
    const int ctx_without_e = (buf[0] & GV_TILE_CONTEXT) && !(buf[0] & GV_TILE_ENTROPY);
    if ((buf[0] & 0x30) || ctx_without_e || rate > GV_MAX_RATE || (rate == 0 && buf[0]))
        return gv_fail(err, GV_ECORRUPT, "tile: bad rate byte 0x%02x", buf[0]);
    if (buf[0] & GV_TILE_ENTROPY)
        return gv_rans_check(buf, len, rate, channels, err) < 0 ? -1 : rate;
    size_t want = gv_tilebuf_size(rate, channels);
    if (len != want)
        return gv_fail(err, GV_ECORRUPT, "tile: %zu bytes where rate %d needs "
                       "%zu", len, rate, want);
    return rate;
}

uint32_t gv_tilebuf_index(const uint8_t *buf, int rate, int channels,
                          uint32_t k)
{
    uint64_t bit = 8u * (1u + ((uint64_t)1 << rate) * 4u * (unsigned)channels) +
                   (uint64_t)k * (unsigned)rate;
    const uint8_t *p = buf + (bit >> 3);
    /* r <= 12 and the shift is <= 7, so three bytes always suffice; the
     * padding guarantees they exist except at the very end. */
    uint32_t v = p[0];
    unsigned have = 8;
    while (have < (bit & 7) + (unsigned)rate) {
        v |= (uint32_t)p[have / 8] << have;
        have += 8;
    }
    return (v >> (bit & 7)) & ((1u << rate) - 1);
}

int gv_tile_decode(const uint8_t *buf, size_t len, int channels,
                   const uint8_t *parent, int qx, int qy, uint8_t *out,
                   struct gv_error *err)
{
    int rate = gv_tilebuf_check(buf, len, channels, err);
    if (rate < 0)
        return -1;
    if (gv_tile_is_dct(buf[0]))
        return gv_dct_decode(buf, len, channels, parent, qx, qy, out, err);
    if (rate == 0) {
        gv_predict(parent, channels, qx, qy, out);
        return 0;
    }
    /* Each pixel row is predicted just before its residual is added, so
     * that it stays in cache (predict.h). */
    struct gv_predictor pred;
    gv_predictor_init(&pred, parent, channels, qx, qy);
    const int entropy = (buf[0] & GV_TILE_ENTROPY) != 0;
    struct gv_rans_rows rows;
    if (entropy)
        gv_rans_rows_begin(&rows, buf, rate, channels);
    const int8_t *book = (const int8_t *)(buf + gv_tilebuf_book_offset(buf[0]));
    const size_t row = (size_t)GV_TILE * channels;
    /* Row by row of blocks: the 257 indices (rANS-decoded, or unpacked
     * from the fixed layout), then for each of the block row's two pixel
     * rows the matching half of every codevector, added with clamping
     * (pixel 513 of the last block is skipped). */
    uint16_t ids[GV_BLOCKS];
    const uint64_t start = 8u * (1u + ((uint64_t)1 << rate) * 4u * (unsigned)channels);
    const uint32_t mask = (1u << rate) - 1;
    for (uint32_t by = 0; by < GV_BLOCKS; by++) {
        if (entropy) {
            if (gv_rans_rows_next(&rows, ids, err) < 0)
                return -1;
        } else {
            uint64_t bit = start + (uint64_t)by * GV_BLOCKS * (unsigned)rate;
            for (uint32_t bx = 0; bx < GV_BLOCKS; bx++, bit += (unsigned)rate) {
                /* At most three bytes hold an index (r <= 12, shift <= 7);
                 * only those it occupies are read. */
                const uint8_t *p = buf + (bit >> 3);
                const unsigned end = (unsigned)(bit & 7) + (unsigned)rate;
                uint32_t v = p[0];
                if (end > 8)
                    v |= (uint32_t)p[1] << 8;
                if (end > 16)
                    v |= (uint32_t)p[2] << 16;
                ids[bx] = (uint16_t)((v >> (bit & 7)) & mask);
            }
        }
        for (int half = 0; half < 2; half++) {
            const int y = 2 * (int)by + half;
            if (y >= GV_TILE)
                break;
            uint8_t *px = out + (size_t)y * row;
            gv_predictor_row(&pred, y, px);
            gv_add_residual_row(px, book, ids, channels, half);
        }
    }
    return 0;
}
