/*
 * tile_rans.c - entropy-coded index streams for tile buffers (the "E"
 * layout of docs/FORMAT.md, section 4.1).
 *
 * The 257x257 indices of a tile are coded as 257 independent rANS streams,
 * one per row of blocks, with one static model per tile (cumulative
 * frequencies in 15-bit precision).  Independent rows let a GPU decode a
 * tile with 257 threads; within a row the decoder is the textbook rANS
 * with a 32-bit state and 16-bit renormalization:
 *
 *   slot = x & 0x7fff;  s = the last symbol with cum[s] <= slot
 *   x = f[s] * (x >> 15) + slot - cum[s];  if (x < 2^16) x = x << 16 | next
 *
 * starting from the stream's first two words (low, high) and ending, for a
 * well-formed stream, with x = 2^16 and every word used.  The encoder runs
 * each row backwards and stores its words in decoding order.
 */
#include <stdlib.h>
#include <string.h>

#include "codec/tile_layout.h"
#include "base/byteorder.h"
#include "codec/tile.h"
#include "codec/tile_rans.h"

#define PROB_BITS 15
#define PROB_SCALE (1u << PROB_BITS)
#define RANS_L (1u << 16)

size_t gv_rans_tables_offset(int rate, int channels)
{
    size_t book = 1 + ((size_t)1 << rate) * 4 * (size_t)channels;
    return (book + 3) & ~(size_t)3;
}

/* Quantize counts to frequencies summing to PROB_SCALE, every used symbol
 * at least 1; the rounding surplus or deficit goes to the largest. */
static void quantize(const uint32_t *count, int k, uint32_t total, uint32_t *freq)
{
    int64_t sum = 0;
    for (int s = 0; s < k; s++) {
        if (!count[s]) {
            freq[s] = 0;
            continue;
        }
        uint64_t f = ((uint64_t)count[s] * PROB_SCALE + total / 2) / total;
        freq[s] = f ? (uint32_t)f : 1;
        sum += freq[s];
    }
    int64_t diff = (int64_t)PROB_SCALE - sum;
    while (diff != 0) {
        /* Take from (or give to) the largest frequencies, never below 1. */
        int best = -1;
        for (int s = 0; s < k; s++)
            if (freq[s] && (diff > 0 || freq[s] > 1) &&
                (best < 0 || freq[s] > freq[best]))
                best = s;
        if (best < 0)
            break;
        int64_t step = diff > 0 ? diff : -(int64_t)(freq[best] - 1);
        if (diff < 0 && -diff < (int64_t)(freq[best] - 1))
            step = diff;
        freq[best] = (uint32_t)((int64_t)freq[best] + step);
        diff -= step;
    }
}

size_t gv_rans_pack(const uint16_t *idx, int rate, int channels,
                    const int8_t *book, uint8_t *buf, size_t cap)
{
    const int k = 1 << rate;
    static _Thread_local uint32_t count[1 << GV_MAX_RATE], freq[1 << GV_MAX_RATE],
        cum[(1 << GV_MAX_RATE) + 1];
    static _Thread_local uint16_t words[GV_BLOCKS + 2];
    memset(count, 0, sizeof(uint32_t) * (size_t)k);
    for (uint32_t i = 0; i < GV_NBLOCKS; i++)
        count[idx[i]]++;
    quantize(count, k, GV_NBLOCKS, freq);
    cum[0] = 0;
    for (int s = 0; s < k; s++)
        cum[s + 1] = cum[s] + freq[s];

    const size_t tables = gv_rans_tables_offset(rate, channels);
    const size_t lengths = tables + 2 * (size_t)k;
    const size_t streams = lengths + ((2 * GV_BLOCKS + 3) & ~(size_t)3);
    if (streams > cap)
        return 0;
    memset(buf, 0, streams);
    buf[0] = (uint8_t)(rate | GV_TILE_ENTROPY);
    memcpy(buf + 1, book, (size_t)k * 4 * channels);
    for (int s = 0; s < k; s++)
        gv_put16(buf + tables + 2 * s, (uint16_t)cum[s]);
    size_t at = streams;
    for (int row = 0; row < GV_BLOCKS; row++) {
        const uint16_t *sym = idx + (size_t)row * GV_BLOCKS;
        uint32_t x = RANS_L;
        int n = 0;
        for (int i = GV_BLOCKS - 1; i >= 0; i--) {
            uint32_t f = freq[sym[i]];
            uint32_t x_max = ((RANS_L >> PROB_BITS) << 16) * f;
            if (x >= x_max) {
                words[n++] = (uint16_t)x;
                x >>= 16;
            }
            x = ((x / f) << PROB_BITS) + (x % f) + cum[sym[i]];
        }
        size_t len = 2 + (size_t)n;
        if (at + 2 * len > cap)
            return 0;
        gv_put16(buf + lengths + 2 * row, (uint16_t)len);
        gv_put16(buf + at, (uint16_t)x);
        gv_put16(buf + at + 2, (uint16_t)(x >> 16));
        for (int w = 0; w < n; w++)
            gv_put16(buf + at + 4 + 2 * w, words[n - 1 - w]);
        at += 2 * len;
    }
    size_t total = (at + 3) & ~(size_t)3;
    if (total > cap)
        return 0;
    memset(buf + at, 0, total - at);
    return total;
}

int gv_rans_check(const uint8_t *buf, size_t len, int rate, int channels,
                  struct gv_error *err)
{
    const int k = 1 << rate;
    const size_t tables = gv_rans_tables_offset(rate, channels);
    const size_t lengths = tables + 2 * (size_t)k;
    const size_t streams = lengths + ((2 * GV_BLOCKS + 3) & ~(size_t)3);
    if (len < streams || (len & 3))
        return gv_fail(err, GV_ECORRUPT, "tile: entropy-coded buffer of %zu "
                       "bytes is too short for rate %d", len, rate);
    for (size_t i = 1 + (size_t)k * 4 * channels; i < tables; i++)
        if (buf[i])
            return gv_fail(err, GV_ECORRUPT, "tile: nonzero padding");
    if (gv_get16(buf + tables) != 0)
        return gv_fail(err, GV_ECORRUPT, "tile: first cumulative frequency "
                       "is not 0");
    for (int s = 1; s < k; s++) {
        uint32_t c0 = gv_get16(buf + tables + 2 * (s - 1));
        uint32_t c1 = gv_get16(buf + tables + 2 * s);
        if (c1 < c0 || c1 > PROB_SCALE)
            return gv_fail(err, GV_ECORRUPT, "tile: cumulative frequencies "
                           "decrease at symbol %d", s);
    }
    size_t words = 0;
    for (int row = 0; row < GV_BLOCKS; row++) {
        uint32_t n = gv_get16(buf + lengths + 2 * row);
        if (n < 2 || n > GV_BLOCKS + 2)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d has %u words",
                           row, n);
        words += n;
    }
    if (((streams + 2 * words + 3) & ~(size_t)3) != len)
        return gv_fail(err, GV_ECORRUPT, "tile: streams need %zu bytes, the "
                       "buffer has %zu", 2 * words, len - streams);
    return 0;
}

void gv_rans_rows_begin(struct gv_rans_rows *it, const uint8_t *buf,
                        int rate, int channels)
{
    it->buf = buf;
    it->k = 1 << rate;
    it->tables = gv_rans_tables_offset(rate, channels);
    it->lengths = it->tables + 2 * (size_t)it->k;
    it->at = it->lengths + ((2 * GV_BLOCKS + 3) & ~(size_t)3);
    it->row = 0;
}

int gv_rans_rows_next(struct gv_rans_rows *it, uint16_t *idx,
                      struct gv_error *err)
{
    const uint8_t *buf = it->buf;
    const size_t tables = it->tables;
    const int k = it->k, row = it->row;
    const uint32_t n = gv_get16(buf + it->lengths + 2 * row);
    const uint8_t *w = buf + it->at;
    uint32_t x = gv_get16(w) | (uint32_t)gv_get16(w + 2) << 16;
    uint32_t next = 2;
    for (int i = 0; i < GV_BLOCKS; i++) {
        uint32_t slot = x & (PROB_SCALE - 1);
        /* Last symbol whose cumulative frequency is <= slot. */
        int lo = 0, hi = k - 1;
        while (lo < hi) {
            int mid = (lo + hi + 1) / 2;
            if (gv_get16(buf + tables + 2 * mid) <= slot)
                lo = mid;
            else
                hi = mid - 1;
        }
        uint32_t c = gv_get16(buf + tables + 2 * lo);
        uint32_t c1 = lo + 1 < k ? gv_get16(buf + tables + 2 * (lo + 1)) : PROB_SCALE;
        uint32_t f = c1 - c;
        if (f == 0 || x < RANS_L)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", row);
        idx[i] = (uint16_t)lo;
        x = f * (x >> PROB_BITS) + slot - c;
        if (x < RANS_L) {
            if (next >= n)
                return gv_fail(err, GV_ECORRUPT, "tile: stream %d ends early", row);
            x = x << 16 | gv_get16(w + 2 * next++);
        }
    }
    if (x != RANS_L || next != n)
        return gv_fail(err, GV_ECORRUPT, "tile: stream %d does not end "
                       "cleanly", row);
    it->at += 2 * (size_t)n;
    it->row++;
    return 0;
}

int gv_rans_unpack(const uint8_t *buf, size_t len, int rate, int channels,
                   uint16_t *idx, struct gv_error *err)
{
    if (gv_rans_check(buf, len, rate, channels, err) < 0)
        return -1;
    struct gv_rans_rows it;
    gv_rans_rows_begin(&it, buf, rate, channels);
    for (int row = 0; row < GV_BLOCKS; row++)
        if (gv_rans_rows_next(&it, idx + (size_t)row * GV_BLOCKS, err) < 0)
            return -1;
    return 0;
}
