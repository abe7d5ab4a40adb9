/*
 * tile_rans.c - entropy-coded index streams for tile buffers (the E and
 * EX layouts of docs/FORMAT.md, sections 4.1 and 4.2).
 *
 * The 257x257 indices of a tile are coded as 257 independent rANS streams,
 * one per row of blocks (cumulative frequencies in 15-bit precision).
 * Independent rows let a GPU decode a tile with 257 threads; within a row
 * the decoder is the textbook rANS with a 32-bit state and 16-bit
 * renormalization:
 *
 *   slot = x & 0x7fff;  s = the last symbol with cum[s] <= slot
 *   x = f[s] * (x >> 15) + slot - cum[s];  if (x < 2^16) x = x << 16 | next
 *
 * starting from the stream's first two words (low, high) and ending, for a
 * well-formed stream, with x = 2^16 and every word used.  The encoder runs
 * each row backwards and stores its words in decoding order.
 *
 * E has one static model per tile.  EX (format version 2) sorts the
 * codebook by use, so that index 0 is the commonest, and codes each index
 * as a symbol of a small model (indices 0..6, or an escape followed by the
 * index in a model over all codevectors).  The small model of a block is
 * picked by the classes of the symbols of the two blocks before it in its
 * row ({0}, {1,2}, {3..6}, escape) through a 16-entry context map, which
 * the encoder chooses per tile among a few candidates by the entropy it
 * would give.  Only the row's own symbols enter the context, so rows stay
 * independent.
 */
#include <stdlib.h>
#include <string.h>

#include "codec/tile_layout.h"
#include "base/byteorder.h"
#include "codec/tile.h"
#include "codec/tile_rans.h"
#include "codec/vq.h"

#define PROB_BITS 15
#define PROB_SCALE (1u << PROB_BITS)
#define RANS_L (1u << 16)
#define LENGTHS_BYTES ((2 * GV_BLOCKS + 3) & ~(size_t)3)  /* n[], padded */
#define MAP_BYTES 8          /* 16 context numbers of 4 bits */
#define MAX_WORDS_E (GV_BLOCKS + 2)        /* one word per symbol, + state */
#define MAX_WORDS_EX (2 * GV_BLOCKS + 2)   /* escapes code two symbols */

/* Class of a small-model symbol: the commonest index, the next two, the
 * next four, an escape. */
static const uint8_t symbol_class[GV_RANS_SYMBOLS] = {0, 1, 1, 2, 2, 2, 2, 3};

size_t gv_rans_tables_offset(int rate, int channels)
{
    size_t book = 1 + ((size_t)1 << rate) * 4 * (size_t)channels;
    return (book + 3) & ~(size_t)3;
}

/* EX: the codevector count N and the offsets of the escape model, the
 * context map, the context models and the stream lengths. */
struct ex_layout {
    uint32_t n;
    int contexts;
    size_t escape, map, models, lengths, streams;
};

static void ex_layout(const uint8_t *buf, int channels, struct ex_layout *l)
{
    l->contexts = buf[1];
    l->n = gv_get16(buf + 2);
    l->escape = 4 + (size_t)l->n * 4 * (size_t)channels;
    l->map = (l->escape + 2 * (size_t)l->n + 3) & ~(size_t)3;
    l->models = l->map + MAP_BYTES;
    l->lengths = l->models + 2 * GV_RANS_SYMBOLS * (size_t)l->contexts;
    l->streams = l->lengths + LENGTHS_BYTES;
}

size_t gv_rans_tables_at(const uint8_t *buf, int channels)
{
    if (buf[0] & GV_TILE_CONTEXT) {
        struct ex_layout l;
        ex_layout(buf, channels, &l);
        return l.escape;
    }
    return gv_rans_tables_offset(buf[0] & 0x0f, channels);
}

/* Quantize counts (summing to total > 0) to frequencies summing to
 * PROB_SCALE, every used symbol at least 1; the rounding surplus or
 * deficit goes to the largest.  All zero when total is 0. */
static void quantize(const uint32_t *count, int k, uint32_t total, uint32_t *freq)
{
    if (total == 0) {
        memset(freq, 0, sizeof *freq * (size_t)k);
        return;
    }
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

/* Cumulative frequencies of k symbols: cum[0] = 0 ... cum[k]. */
static void accumulate(const uint32_t *freq, int k, uint32_t *cum)
{
    cum[0] = 0;
    for (int s = 0; s < k; s++)
        cum[s + 1] = cum[s] + freq[s];
}

size_t gv_rans_put_stream(uint8_t *buf, size_t lengths, int row, size_t at,
                          uint32_t x, const uint16_t *words, int n, size_t cap)
{
    size_t len = 2 + (size_t)n;
    if (len > 0xffff || at + 2 * len > cap)
        return 0;
    gv_put16(buf + lengths + 2 * row, (uint16_t)len);
    gv_put16(buf + at, (uint16_t)x);
    gv_put16(buf + at + 2, (uint16_t)(x >> 16));
    for (int w = 0; w < n; w++)
        gv_put16(buf + at + 4 + 2 * w, words[n - 1 - w]);
    return at + 2 * len;
}

size_t gv_rans_finish(uint8_t *buf, size_t at, size_t cap)
{
    size_t total = (at + 3) & ~(size_t)3;
    if (total > cap)
        return 0;
    memset(buf + at, 0, total - at);
    return total;
}

size_t gv_rans_pack(const uint16_t *idx, int rate, int channels,
                    const int8_t *book, uint8_t *buf, size_t cap)
{
    const int k = 1 << rate;
    static _Thread_local uint32_t count[1 << GV_MAX_RATE], freq[1 << GV_MAX_RATE],
        cum[(1 << GV_MAX_RATE) + 1];
    static _Thread_local uint16_t words[MAX_WORDS_E];
    memset(count, 0, sizeof(uint32_t) * (size_t)k);
    for (uint32_t i = 0; i < GV_NBLOCKS; i++)
        count[idx[i]]++;
    quantize(count, k, GV_NBLOCKS, freq);
    accumulate(freq, k, cum);

    const size_t tables = gv_rans_tables_offset(rate, channels);
    const size_t lengths = tables + 2 * (size_t)k;
    const size_t streams = lengths + LENGTHS_BYTES;
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
        for (int i = GV_BLOCKS - 1; i >= 0; i--)
            x = gv_rans_put(x, freq[sym[i]], cum[sym[i]], PROB_BITS, words, &n);
        if (!(at = gv_rans_put_stream(buf, lengths, row, at, x, words, n, cap)))
            return 0;
    }
    return gv_rans_finish(buf, at, cap);
}

/* ---- EX: context models ---- */

/* Context map candidates, as functions of the classes a (previous block)
 * and b (the one before): one model; a = 0 or not; a; a + b; 2a + (b > 0).
 * The encoder keeps the one with the least estimated size. */
#define MAP_CANDIDATES 5
static const int candidate_contexts[MAP_CANDIDATES] = {1, 2, 4, 7, 8};

static int candidate_map(int cand, int a, int b)
{
    switch (cand) {
    case 0: return 0;
    case 1: return a > 0;
    case 2: return a;
    case 3: return a + b;
    default: return 2 * a + (b > 0);
    }
}

/* Bits (16.16) of n symbols with these counts under their own static
 * model: sum of count * log2(n / count). */
static uint64_t model_bits(const uint32_t *count, int k)
{
    uint64_t n = 0, bits = 0;
    for (int s = 0; s < k; s++)
        n += count[s];
    if (n == 0)
        return 0;
    const uint32_t ln = vq_log2_q16(n);
    for (int s = 0; s < k; s++)
        if (count[s])
            bits += (uint64_t)count[s] * (ln - vq_log2_q16(count[s]));
    return bits;
}

/* Choose the context map: the candidate of least estimated bytes (model
 * bits plus its tables), from the symbol counts of each class pair. */
static int choose_map(const uint32_t pair[16][GV_RANS_SYMBOLS])
{
    int best = 0;
    uint64_t best_cost = UINT64_MAX;
    for (int cand = 0; cand < MAP_CANDIDATES; cand++) {
        uint32_t ctx[GV_RANS_CONTEXTS][GV_RANS_SYMBOLS];
        memset(ctx, 0, sizeof ctx);
        for (int p = 0; p < 16; p++)
            for (int s = 0; s < GV_RANS_SYMBOLS; s++)
                ctx[candidate_map(cand, p >> 2, p & 3)][s] += pair[p][s];
        uint64_t cost = 0;
        for (int c = 0; c < candidate_contexts[cand]; c++)
            cost += model_bits(ctx[c], GV_RANS_SYMBOLS);
        /* bits (16.16) of the tables: 16 bytes a context */
        cost += (uint64_t)candidate_contexts[cand] * 16 * 8 << 16;
        if (cost < best_cost) {
            best_cost = cost;
            best = cand;
        }
    }
    return best;
}

/* Sort keys: (2^32 - 1 - count) << 16 | index, so that ascending order
 * is by use, commonest first, the lower index first among equals. */
static int by_key(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return a < b ? -1 : (a > b);
}

size_t gv_rans_pack_ctx(const uint16_t *idx, int rate, int channels,
                        const int8_t *book, uint8_t *buf, size_t cap)
{
    if (rate < 3)
        return 0;
    const int k = 1 << rate, dim = 4 * channels;
    static _Thread_local uint32_t count[1 << GV_MAX_RATE], efreq[1 << GV_MAX_RATE],
        ecum[(1 << GV_MAX_RATE) + 1];
    static _Thread_local uint16_t order[1 << GV_MAX_RATE], rank[1 << GV_MAX_RATE];
    static _Thread_local uint64_t key[1 << GV_MAX_RATE];
    static _Thread_local uint8_t sym[GV_NBLOCKS], ctx[GV_NBLOCKS];
    static _Thread_local uint16_t words[MAX_WORDS_EX];
    memset(count, 0, sizeof(uint32_t) * (size_t)k);
    for (uint32_t i = 0; i < GV_NBLOCKS; i++)
        count[idx[i]]++;
    for (int s = 0; s < k; s++)
        key[s] = (uint64_t)(UINT32_MAX - count[s]) << 16 | (uint64_t)s;
    qsort(key, (size_t)k, sizeof *key, by_key);
    for (int s = 0; s < k; s++)
        order[s] = (uint16_t)(key[s] & 0xffff);
    uint32_t n = 0;
    for (int s = 0; s < k; s++) {
        rank[order[s]] = (uint16_t)s;
        n += count[order[s]] > 0;
    }
    if (n < GV_RANS_MIN_ENTRIES)
        n = GV_RANS_MIN_ENTRIES;

    /* Small symbols, escape counts, symbol counts per class pair. */
    uint32_t pair[16][GV_RANS_SYMBOLS];
    memset(pair, 0, sizeof pair);
    memset(count, 0, sizeof(uint32_t) * (size_t)k);   /* now: escapes by rank */
    uint32_t escapes = 0;
    for (int row = 0; row < GV_BLOCKS; row++) {
        int a = 0, b = 0;
        for (int i = 0; i < GV_BLOCKS; i++) {
            const uint32_t at = (uint32_t)row * GV_BLOCKS + (uint32_t)i;
            const uint16_t r = rank[idx[at]];
            const int s = r < GV_RANS_ESCAPE ? r : GV_RANS_ESCAPE;
            sym[at] = (uint8_t)s;
            ctx[at] = (uint8_t)(4 * a + b);
            pair[4 * a + b][s]++;
            if (s == GV_RANS_ESCAPE) {
                count[r]++;
                escapes++;
            }
            b = a;
            a = symbol_class[s];
        }
    }
    const int cand = choose_map(pair);
    const int contexts = candidate_contexts[cand];
    uint8_t map[16];
    uint32_t ccount[GV_RANS_CONTEXTS][GV_RANS_SYMBOLS];
    uint32_t cfreq[GV_RANS_CONTEXTS][GV_RANS_SYMBOLS];
    uint32_t ccum[GV_RANS_CONTEXTS][GV_RANS_SYMBOLS + 1];
    memset(ccount, 0, sizeof ccount);
    for (int p = 0; p < 16; p++) {
        map[p] = (uint8_t)candidate_map(cand, p >> 2, p & 3);
        for (int s = 0; s < GV_RANS_SYMBOLS; s++)
            ccount[map[p]][s] += pair[p][s];
    }
    for (int c = 0; c < contexts; c++) {
        uint32_t total = 0;
        for (int s = 0; s < GV_RANS_SYMBOLS; s++)
            total += ccount[c][s];
        quantize(ccount[c], GV_RANS_SYMBOLS, total, cfreq[c]);
        accumulate(cfreq[c], GV_RANS_SYMBOLS, ccum[c]);
    }
    quantize(count, (int)n, escapes, efreq);
    accumulate(efreq, (int)n, ecum);

    /* The header, the codebook by rank, the tables. */
    const size_t escape = 4 + (size_t)n * dim;
    const size_t mapat = (escape + 2 * (size_t)n + 3) & ~(size_t)3;
    const size_t models = mapat + MAP_BYTES;
    const size_t lengths = models + 2 * GV_RANS_SYMBOLS * (size_t)contexts;
    const size_t streams = lengths + LENGTHS_BYTES;
    if (streams > cap)
        return 0;
    memset(buf, 0, streams);
    buf[0] = (uint8_t)(rate | GV_TILE_ENTROPY | GV_TILE_CONTEXT);
    buf[1] = (uint8_t)contexts;
    gv_put16(buf + 2, (uint16_t)n);
    for (uint32_t r = 0; r < n; r++)
        memcpy(buf + 4 + (size_t)r * dim, book + (size_t)order[r] * dim, (size_t)dim);
    for (uint32_t r = 0; r < n; r++)
        gv_put16(buf + escape + 2 * r, (uint16_t)ecum[r]);
    for (int p = 0; p < 16; p++)
        buf[mapat + p / 2] |= (uint8_t)(map[p] << (4 * (p & 1)));
    for (int c = 0; c < contexts; c++)
        for (int s = 0; s < GV_RANS_SYMBOLS; s++)
            gv_put16(buf + models + 2 * (GV_RANS_SYMBOLS * c + s), (uint16_t)ccum[c][s]);

    size_t at = streams;
    for (int row = 0; row < GV_BLOCKS; row++) {
        const uint32_t base = (uint32_t)row * GV_BLOCKS;
        uint32_t x = RANS_L;
        int nw = 0;
        for (int i = GV_BLOCKS - 1; i >= 0; i--) {
            const int s = sym[base + i], c = map[ctx[base + i]];
            if (s == GV_RANS_ESCAPE) {
                const uint16_t r = rank[idx[base + i]];
                x = gv_rans_put(x, efreq[r], ecum[r], PROB_BITS, words, &nw);
            }
            x = gv_rans_put(x, cfreq[c][s], ccum[c][s], PROB_BITS, words, &nw);
        }
        if (!(at = gv_rans_put_stream(buf, lengths, row, at, x, words, nw, cap)))
            return 0;
    }
    return gv_rans_finish(buf, at, cap);
}

/* ---- checking ---- */

/* cum[0 .. k-1] at `tables`: starts at 0, never decreases, at most 2^15.
 * `what` names the model in a message ("" for the E layout's). */
static int check_cum(const uint8_t *buf, size_t tables, int k, const char *what,
                     struct gv_error *err)
{
    if (gv_get16(buf + tables) != 0)
        return gv_fail(err, GV_ECORRUPT, "tile: first cumulative frequency"
                       "%s is not 0", what);
    for (int s = 1; s < k; s++) {
        uint32_t c0 = gv_get16(buf + tables + 2 * (s - 1));
        uint32_t c1 = gv_get16(buf + tables + 2 * s);
        if (c1 < c0 || c1 > PROB_SCALE)
            return gv_fail(err, GV_ECORRUPT, "tile: cumulative frequencies"
                           "%s decrease at symbol %d", what, s);
    }
    return 0;
}

static int check_zero(const uint8_t *buf, size_t from, size_t to,
                      struct gv_error *err)
{
    for (size_t i = from; i < to; i++)
        if (buf[i])
            return gv_fail(err, GV_ECORRUPT, "tile: nonzero padding");
    return 0;
}

/* The stream lengths at `lengths` (each 2 .. max_words) and the buffer's
 * length against their sum. */
static int check_streams(const uint8_t *buf, size_t len, size_t lengths,
                         uint32_t max_words, struct gv_error *err)
{
    const size_t streams = lengths + LENGTHS_BYTES;
    size_t words = 0;
    for (int row = 0; row < GV_BLOCKS; row++) {
        uint32_t n = gv_get16(buf + lengths + 2 * row);
        if (n < 2 || n > max_words)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d has %u words",
                           row, n);
        words += n;
    }
    if (check_zero(buf, lengths + 2 * GV_BLOCKS, streams, err) < 0)
        return -1;
    if (((streams + 2 * words + 3) & ~(size_t)3) != len)
        return gv_fail(err, GV_ECORRUPT, "tile: streams need %zu bytes, the "
                       "buffer has %zu", 2 * words, len - streams);
    return 0;
}

/* An entropy-coded buffer is never longer than the fixed layout at its
 * rate (the encoder writes it only when smaller), so no tile buffer
 * exceeds GV_TILEBUF_MAX. */
static int check_length(size_t len, int rate, int channels, struct gv_error *err)
{
    const size_t fixed = gv_tilebuf_size(rate, channels);
    if (len > fixed)
        return gv_fail(err, GV_ECORRUPT, "tile: entropy-coded buffer of %zu "
                       "bytes, longer than the fixed layout's %zu", len, fixed);
    return 0;
}

static int check_e(const uint8_t *buf, size_t len, int rate, int channels,
                   struct gv_error *err)
{
    if (check_length(len, rate, channels, err) < 0)
        return -1;
    const int k = 1 << rate;
    const size_t tables = gv_rans_tables_offset(rate, channels);
    const size_t lengths = tables + 2 * (size_t)k;
    if (len < lengths + LENGTHS_BYTES || (len & 3))
        return gv_fail(err, GV_ECORRUPT, "tile: entropy-coded buffer of %zu "
                       "bytes is too short for rate %d", len, rate);
    if (check_zero(buf, 1 + (size_t)k * 4 * channels, tables, err) < 0 ||
        check_cum(buf, tables, k, "", err) < 0)
        return -1;
    return check_streams(buf, len, lengths, MAX_WORDS_E, err);
}

static int check_ex(const uint8_t *buf, size_t len, int rate, int channels,
                    struct gv_error *err)
{
    if (rate < 3)
        return gv_fail(err, GV_ECORRUPT, "tile: context-coded indices at "
                       "rate %d (3 is the least)", rate);
    if (check_length(len, rate, channels, err) < 0)
        return -1;
    if (len < 4 || (len & 3))
        return gv_fail(err, GV_ECORRUPT, "tile: context-coded buffer of %zu "
                       "bytes", len);
    struct ex_layout l;
    ex_layout(buf, channels, &l);
    if (l.n < GV_RANS_MIN_ENTRIES || l.n > (1u << rate))
        return gv_fail(err, GV_ECORRUPT, "tile: %u codevectors at rate %d",
                       l.n, rate);
    if (l.contexts < 1 || l.contexts > GV_RANS_CONTEXTS)
        return gv_fail(err, GV_ECORRUPT, "tile: %d context models",
                       l.contexts);
    if (len < l.streams)
        return gv_fail(err, GV_ECORRUPT, "tile: context-coded buffer of %zu "
                       "bytes is too short for its %u codevectors", len, l.n);
    if (check_cum(buf, l.escape, (int)l.n, " of the escape model", err) < 0 ||
        check_zero(buf, l.escape + 2 * (size_t)l.n, l.map, err) < 0)
        return -1;
    for (int p = 0; p < 16; p++) {
        int c = buf[l.map + p / 2] >> (4 * (p & 1)) & 15;
        if (c >= l.contexts)
            return gv_fail(err, GV_ECORRUPT, "tile: context map entry %d is "
                           "%d of %d models", p, c, l.contexts);
    }
    for (int c = 0; c < l.contexts; c++)
        if (check_cum(buf, l.models + 2 * GV_RANS_SYMBOLS * (size_t)c,
                      GV_RANS_SYMBOLS, " of a context model", err) < 0)
            return -1;
    return check_streams(buf, len, l.lengths, MAX_WORDS_EX, err);
}

int gv_rans_check(const uint8_t *buf, size_t len, int rate, int channels,
                  struct gv_error *err)
{
    if (buf[0] & GV_TILE_CONTEXT)
        return check_ex(buf, len, rate, channels, err);
    return check_e(buf, len, rate, channels, err);
}

/* ---- decoding ---- */

/* Fill it->first[] from the k-symbol model at it->tables (cum[0] = 0,
 * non-decreasing: checked). */
static void index_buckets(struct gv_rans_rows *it)
{
    int s = 0;
    for (uint32_t j = 0; j < GV_RANS_BUCKETS; j++) {
        const uint32_t slot = j << GV_RANS_BUCKET_SHIFT;
        while (s + 1 < it->k && gv_get16(it->buf + it->tables + 2 * (size_t)(s + 1)) <= slot)
            s++;
        it->first[j] = (uint16_t)s;
    }
}

void gv_rans_rows_begin(struct gv_rans_rows *it, const uint8_t *buf,
                        int rate, int channels)
{
    it->buf = buf;
    it->row = 0;
    it->context = (buf[0] & GV_TILE_CONTEXT) != 0;
    if (!it->context) {
        it->k = 1 << rate;
        it->tables = gv_rans_tables_offset(rate, channels);
        it->lengths = it->tables + 2 * (size_t)it->k;
        it->at = it->lengths + LENGTHS_BYTES;
        index_buckets(it);
        return;
    }
    struct ex_layout l;
    ex_layout(buf, channels, &l);
    it->k = (int)l.n;
    it->tables = l.escape;
    it->lengths = l.lengths;
    it->at = l.streams;
    for (int p = 0; p < 16; p++)
        it->map[p] = (uint8_t)(buf[l.map + p / 2] >> (4 * (p & 1)) & 15);
    for (int c = 0; c < l.contexts; c++) {
        for (int s = 0; s < GV_RANS_SYMBOLS; s++)
            it->cum[c][s] = gv_get16(buf + l.models + 2 * (GV_RANS_SYMBOLS * c + s));
        it->cum[c][GV_RANS_SYMBOLS] = PROB_SCALE;
    }
    index_buckets(it);
}

/* The last symbol of the rows' k-symbol model whose cumulative frequency
 * is <= slot; its cum and frequency in *c, *f.  The walk starts at the
 * slot's bucket (index_buckets), so it takes a few steps. */
static int find_symbol(const struct gv_rans_rows *it, uint32_t slot,
                       uint32_t *c, uint32_t *f)
{
    const uint8_t *cum = it->buf + it->tables;
    int s = it->first[slot >> GV_RANS_BUCKET_SHIFT];
    uint32_t c1;
    while ((c1 = s + 1 < it->k ? gv_get16(cum + 2 * (size_t)(s + 1)) : PROB_SCALE) <= slot)
        s++;
    *c = gv_get16(cum + 2 * (size_t)s);
    *f = c1 - *c;
    return s;
}

/* One row's stream: state, words, position. */
struct stream {
    const uint8_t *w;
    uint32_t x, n, next;
};

/* Advance the state past a symbol (cum c, frequency f, slot) and
 * renormalize; -1 when the stream runs out. */
static inline int advance(struct stream *st, uint32_t c, uint32_t f, uint32_t slot)
{
    st->x = f * (st->x >> PROB_BITS) + slot - c;
    if (st->x < RANS_L) {
        if (st->next >= st->n)
            return -1;
        st->x = st->x << 16 | gv_get16(st->w + 2 * st->next++);
    }
    return 0;
}

static int next_row_e(struct gv_rans_rows *it, struct stream *st, uint16_t *idx,
                      struct gv_error *err)
{
    for (int i = 0; i < GV_BLOCKS; i++) {
        uint32_t slot = st->x & (PROB_SCALE - 1), c, f;
        int s = find_symbol(it, slot, &c, &f);
        if (f == 0 || st->x < RANS_L)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", it->row);
        idx[i] = (uint16_t)s;
        if (advance(st, c, f, slot) < 0)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d ends early", it->row);
    }
    return 0;
}

static int next_row_ex(struct gv_rans_rows *it, struct stream *st, uint16_t *idx,
                       struct gv_error *err)
{
    int a = 0, b = 0;   /* classes of the two blocks before */
    for (int i = 0; i < GV_BLOCKS; i++) {
        const uint32_t *cum = it->cum[it->map[4 * a + b]];
        if (st->x < RANS_L)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", it->row);
        uint32_t slot = st->x & (PROB_SCALE - 1);
        int s = 0;
        while (s < GV_RANS_ESCAPE && cum[s + 1] <= slot)
            s++;
        if (advance(st, cum[s], cum[s + 1] - cum[s], slot) < 0)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d ends early", it->row);
        if (s == GV_RANS_ESCAPE) {
            uint32_t c, f;
            if (st->x < RANS_L)
                return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", it->row);
            slot = st->x & (PROB_SCALE - 1);
            idx[i] = (uint16_t)find_symbol(it, slot, &c, &f);
            if (advance(st, c, f, slot) < 0)
                return gv_fail(err, GV_ECORRUPT, "tile: stream %d ends early", it->row);
        } else {
            idx[i] = (uint16_t)s;
        }
        b = a;
        a = symbol_class[s];
    }
    return 0;
}

int gv_rans_rows_next(struct gv_rans_rows *it, uint16_t *idx,
                      struct gv_error *err)
{
    struct stream st;
    st.w = it->buf + it->at;
    st.n = gv_get16(it->buf + it->lengths + 2 * it->row);
    st.x = gv_get16(st.w) | (uint32_t)gv_get16(st.w + 2) << 16;
    st.next = 2;
    if ((it->context ? next_row_ex : next_row_e)(it, &st, idx, err) < 0)
        return -1;
    if (st.x != RANS_L || st.next != st.n)
        return gv_fail(err, GV_ECORRUPT, "tile: stream %d does not end "
                       "cleanly", it->row);
    it->at += 2 * (size_t)st.n;
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
