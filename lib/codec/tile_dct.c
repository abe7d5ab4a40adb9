/*
 * tile_dct.c - layouts D and D2 (docs/FORMAT.md sections 4.3 and 4.4):
 * their layout check and the CPU reference decoder.  D2 is D with two more
 * models, in which each block's last coded value is coded: the value
 * that the block's count says is nonzero.
 *
 * A buffer is decoded two rows of 8x8 blocks at a time: the rows' rANS
 * streams in lockstep into their coefficients (2 x 3 x 8 x 520 int16 on
 * the stack), then for each row its eight pixel rows predicted straight
 * into the output and the residuals added (tile_dct_pixels.c).  A rANS step is one table load:
 * each model's 256 slots hold their symbol, its frequency and the slot's
 * offset in one 32-bit entry (the models have 8-bit precision).  Where
 * the CPU has AVX-512 VBMI, gv_dct_decode takes rows 0-63 sixteen at a
 * time through tile_dct_lanes.c instead, which gives the same bytes; this
 * file's scalar rows stay the reference, the path of other CPUs, and the
 * fallback (with the message) for a damaged group.
 */
#include <string.h>

#include "base/byteorder.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_dct_lanes.h"
#include "codec/tile_dct_pixels.h"
#include "codec/tile_layout.h"

#define RANS_L (1u << 16)
#define HEADER_BYTES 12
#define LENGTHS_BYTES (2 * GV_DCT_BLOCKS)

const uint8_t gv_dct_zigzag[64] = {
     0,  1,  8, 16,  9,  2,  3, 10, 17, 24, 32, 25, 18, 11,  4,  5,
    12, 19, 26, 33, 40, 48, 41, 34, 27, 20, 13,  6,  7, 14, 21, 28,
    35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51,
    58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63,
};

const uint8_t gv_dct_band_model[64] = {
    0, 3, 3, 6, 6, 6, 6, 6, 6, 6, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
};

/* Offsets of a checked buffer's parts. */
struct dct_layout {
    uint32_t mask;
    int last;                          /* layout D2: last-value models */
    size_t model_at[GV_DCT_MODELS_D2];  /* 0 for an absent model */
    size_t lengths, streams;
};

static int parse_layout(const uint8_t *buf, size_t len, int channels,
                        struct dct_layout *l, struct gv_error *err)
{
    if (channels != 1 && channels != 3)
        return gv_fail(err, GV_EINVAL, "tile: bad channel count %d", channels);
    if (len < HEADER_BYTES || (len & 3) || !gv_tile_is_dct(buf[0]) || buf[1])
        return gv_fail(err, GV_ECORRUPT, "tile: bad layout D header");
    l->last = buf[0] == GV_TILE_DCT2;
    const int models = l->last ? GV_DCT_MODELS_D2 : GV_DCT_MODELS;
    for (int c = 0; c < 3; c++) {
        unsigned s = gv_get16(buf + 2 + 2 * c);
        if (c < channels ? (s < 1 || s > GV_DCT_MAX_STEP) : s != 0)
            return gv_fail(err, GV_ECORRUPT, "tile: bad quantizer step %u "
                           "of channel %d", s, c);
    }
    l->mask = gv_get32(buf + 8);
    if (!l->last && l->mask >> GV_DCT_MODELS)
        return gv_fail(err, GV_ECORRUPT, "tile: bad model mask 0x%08x",
                       (unsigned)l->mask);
    size_t at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        l->model_at[m] = 0;
        if (m >= models)
            continue;
        if (!(l->mask >> m & 1))
            continue;
        const int k = gv_dct_model_symbols(m);
        if (at + (size_t)k > len)
            return gv_fail(err, GV_ECORRUPT, "tile: models pass the buffer");
        if (buf[at] != 0)
            return gv_fail(err, GV_ECORRUPT, "tile: model %d starts at %u",
                           m, buf[at]);
        for (int s = 1; s < k; s++)
            if (buf[at + s] < buf[at + s - 1])
                return gv_fail(err, GV_ECORRUPT, "tile: model %d decreases", m);
        l->model_at[m] = at;
        at += (size_t)k;
    }
    l->lengths = (at + 1) & ~(size_t)1;
    l->streams = l->lengths + LENGTHS_BYTES;
    if (l->streams > len)
        return gv_fail(err, GV_ECORRUPT, "tile: stream lengths pass the buffer");
    size_t words = 0;
    for (int i = 0; i < GV_DCT_BLOCKS; i++) {
        unsigned n = gv_get16(buf + l->lengths + 2 * i);
        if (n < 2)
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d has %u words", i, n);
        words += n;
    }
    size_t end = l->streams + 2 * words;
    if (((end + 3) & ~(size_t)3) != len)
        return gv_fail(err, GV_ECORRUPT, "tile: %zu bytes where the streams "
                       "end at %zu", len, end);
    for (size_t b = end; b < len; b++)
        if (buf[b])
            return gv_fail(err, GV_ECORRUPT, "tile: nonzero padding");
    return 0;
}

int gv_dct_check(const uint8_t *buf, size_t len, int channels,
                 struct gv_error *err)
{
    struct dct_layout l;
    return parse_layout(buf, len, channels, &l, err);
}

/* The decoder's view of the models: one 32-bit entry per slot, so that a
 * step is one load: the symbol's frequency f (bits 0-8), for a token
 * model the magnitude class of the token's value times 1024 (bits 10-11:
 * the byte distance between the token models of successive classes, so
 * that the next model's address takes one AND; 3 for the escape, whose
 * class depends on the value that follows), the slot's offset within the
 * symbol's range (bits 12-19) and the symbol (bits 20-27).  An absent
 * model's entries are 0: frequency 0, which the decoder reports. */
#define E_FREQ(e) ((e) & 511)
#define E_CLASS_BYTES(e) ((e) & 0xc00)
#define E_OFFSET(e) ((e) >> 12 & 255)
#define E_SYMBOL(e) ((int)((e) >> 20))
struct dct_models {
    uint32_t slot[GV_DCT_MODELS_D2][256];
    int last;                       /* layout D2: last-value models */
};

/* The value of token t < GV_DCT_ESCAPE: 0, 1, -1, 2, -2, ... */
static inline int token_value(int t)
{
    return (t & 1) ? (t + 1) >> 1 : -(t >> 1);
}

static void load_models(const uint8_t *buf, const struct dct_layout *l,
                        struct dct_models *md)
{
    md->last = l->last;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        const int k = gv_dct_model_symbols(m);
        uint32_t *e = md->slot[m];
        if (!l->model_at[m]) {
            memset(e, 0, sizeof md->slot[m]);
            continue;
        }
        const uint8_t *c = buf + l->model_at[m];
        for (int s = 0; s < k; s++) {
            const unsigned lo = c[s], hi = s + 1 < k ? c[s + 1] : 256;
            uint32_t cls = 0;
            if (m >= GV_DCT_EOB_MODELS)
                cls = s == GV_DCT_ESCAPE ? 3 : (uint32_t)gv_dct_class(token_value(s));
            for (unsigned slot = lo; slot < hi; slot++)
                e[slot] = (hi - lo) | cls << 10 | (slot - lo) << 12 | (uint32_t)s << 20;
        }
    }
}

/* The rANS decoding of a row's stream, written for lanes: each macro
 * works on lane L's state (x##L, next##L, n##L, w##L) and jumps to bad##L
 * on a damaged stream.  Two rows decoded in lockstep give the CPU two
 * independent chains of dependent loads and multiplies to overlap; one
 * row alone is the same code with one lane. */

/* One step with the entry table tab (a model's 256 entries): sets e to
 * the slot's entry.  The state stays >= RANS_L from a valid start
 * (checked once per stream): after a step it is at least f * 256 with
 * f >= 1, and a renormalization takes it past 2^24.  (A renormalization
 * without a branch, the next word always read and selected, was slower:
 * 400 against 422 MP/s on Picos de Europa.) */
#define RENORM(L)                                                           \
    do {                                                                    \
        if (x##L < RANS_L) {                                                \
            if (next##L >= n##L)                                            \
                goto bad##L;                                                \
            x##L = x##L << 16 | gv_get16(w##L + 2 * next##L++);             \
        }                                                                   \
    } while (0)

#define STEP(L, tab, e)                                                     \
    do {                                                                    \
        e = (tab)[x##L & 255];                                              \
        if (!E_FREQ(e))                                                     \
            goto bad##L;                                                    \
        x##L = E_FREQ(e) * (x##L >> 8) + E_OFFSET(e);                       \
        RENORM(L);                                                          \
    } while (0)

/* A uniform 6-bit step into h. */
#define STEP_UNIFORM(L, h)                                                  \
    do {                                                                    \
        h = (int)((x##L & 255) >> 2);                                       \
        x##L = 4 * (x##L >> 8) + (x##L & 3);                                \
        RENORM(L);                                                          \
    } while (0)

/* A lane's state: its stream (words at w, n of them), and the contexts
 * of each channel (the previous block's eob class, its DC's class). */
#define LANE(L, at, words)                                                  \
    const uint8_t *w##L = buf + (at);                                       \
    const uint32_t n##L = (words);                                          \
    uint32_t x##L = gv_get16(w##L) | (uint32_t)gv_get16(w##L + 2) << 16,    \
             next##L = 2;                                                   \
    int pe##L[3] = {0, 0, 0}, eob##L;                                       \
    uint32_t dcp##L[3] = {0, 0, 0}, p##L;                                   \
    int16_t *dst##L;                                                        \
    if (x##L < RANS_L)                                                      \
        goto bad##L

/* Block bx's eob of channel c (cc = c > 0) into eob##L. */
#define BLOCK_EOB(L)                                                        \
    do {                                                                    \
        uint32_t e_;                                                        \
        STEP(L, md->slot[3 * cc + pe##L[c]], e_);                           \
        eob##L = E_SYMBOL(e_);                                              \
        eobs##L[c][bx] = (uint8_t)eob##L;                                   \
        pe##L[c] = gv_dct_eob_class(eob##L);                                \
        dst##L = &co##L[c][0][8 * bx];                                      \
        p##L = dcp##L[c];                                                   \
        dcp##L[c] = 0;                                                      \
    } while (0)

/* Where coefficient k in zigzag order lies in a row's coefficients,
 * from its block's first: (v, u) at v * GV_DCT_PLANE + u. */
#define ZZ(v, u) ((v) * GV_DCT_PLANE + (u))
static const uint16_t zz_offset[64] = {
    ZZ(0, 0), ZZ(0, 1), ZZ(1, 0), ZZ(2, 0), ZZ(1, 1), ZZ(0, 2), ZZ(0, 3), ZZ(1, 2),
    ZZ(2, 1), ZZ(3, 0), ZZ(4, 0), ZZ(3, 1), ZZ(2, 2), ZZ(1, 3), ZZ(0, 4), ZZ(0, 5),
    ZZ(1, 4), ZZ(2, 3), ZZ(3, 2), ZZ(4, 1), ZZ(5, 0), ZZ(6, 0), ZZ(5, 1), ZZ(4, 2),
    ZZ(3, 3), ZZ(2, 4), ZZ(1, 5), ZZ(0, 6), ZZ(0, 7), ZZ(1, 6), ZZ(2, 5), ZZ(3, 4),
    ZZ(4, 3), ZZ(5, 2), ZZ(6, 1), ZZ(7, 0), ZZ(7, 1), ZZ(6, 2), ZZ(5, 3), ZZ(4, 4),
    ZZ(3, 5), ZZ(2, 6), ZZ(1, 7), ZZ(2, 7), ZZ(3, 6), ZZ(4, 5), ZZ(5, 4), ZZ(6, 3),
    ZZ(7, 2), ZZ(7, 3), ZZ(6, 4), ZZ(5, 5), ZZ(4, 6), ZZ(3, 7), ZZ(4, 7), ZZ(5, 6),
    ZZ(6, 5), ZZ(7, 4), ZZ(7, 5), ZZ(6, 6), ZZ(5, 7), ZZ(6, 7), ZZ(7, 6), ZZ(7, 7),
};

/* The byte distance from a channel class's first token model to the
 * models of coefficient k's band: gv_dct_band_model[k] * 1024. */
#define B(band) ((band) * 3 * 256 * 4)
static const uint16_t band_bytes[64] = {
    B(0), B(1), B(1), B(2), B(2), B(2), B(2), B(2), B(2), B(2), B(3), B(3),
    B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3),
    B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3),
    B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3),
    B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3), B(3),
    B(3), B(3), B(3), B(3),
};

/* Coefficient k (zigzag order) of the block, with its band's model for
 * the previous value's class. */
#define TOKEN(L, k)                                                         \
    TOKEN_WITH(L, k, (const uint32_t *)((const char *)tok + band_bytes[k] + \
                                        p##L))

/* Coefficient k of the block, with the model of entries tab. */
#define TOKEN_WITH(L, k, tab)                                               \
    do {                                                                    \
        uint32_t e_;                                                        \
        STEP(L, (tab), e_);                                                 \
        const int t_ = E_SYMBOL(e_);                                        \
        int16_t *d_ = dst##L + zz_offset[k];                                \
        if (t_ != GV_DCT_ESCAPE) {                                          \
            *d_ = deq[c][t_];                                               \
            p##L = E_CLASS_BYTES(e_);                                       \
        } else {                                                            \
            int h_, lo_;                                                    \
            STEP_UNIFORM(L, h_);                                            \
            STEP_UNIFORM(L, lo_);                                           \
            const int q_ = 64 * h_ + lo_ - 2048;                            \
            *d_ = clamp_s16(q_ * steps[c]);                                 \
            p##L = (uint32_t)gv_dct_class(q_) << 10;                        \
        }                                                                   \
    } while (0)

/* The block's first coefficient, when it has one: its class is the next
 * block's DC context.  In layout D2 (last non-NULL: the channel class's
 * last-value model) a block's last value has a model of its own, so a
 * block of one value codes it with that. */
#define FIRST_TOKEN(L)                                                      \
    do {                                                                    \
        if (eob##L) {                                                       \
            if (last && eob##L == 1)                                        \
                TOKEN_WITH(L, 0, last);                                     \
            else                                                            \
                TOKEN(L, 0);                                                \
            dcp##L[c] = p##L;                                               \
        }                                                                   \
    } while (0)

/* Layout D2: a block's last value (eob >= 2), after the others. */
#define LAST_TOKEN(L)                                                       \
    do {                                                                    \
        if (last && eob##L > 1)                                             \
            TOKEN_WITH(L, eob##L - 1, last);                                \
    } while (0)

/* After the last block: the state back at its start, every word read. */
#define LANE_END(L, row)                                                    \
    do {                                                                    \
        if (x##L != RANS_L || next##L != n##L)                              \
            return gv_fail(err, GV_ECORRUPT, "tile: stream %d does not "    \
                           "end cleanly", (row));                           \
    } while (0)

static inline int16_t clamp_s16(int32_t v)
{
    return (int16_t)(v < -32768 ? -32768 : (v > 32767 ? 32767 : v));
}

/* The dequantized tokens of each channel, clamped to 16 bits. */
static void dequantized_tokens(const int32_t *steps, int channels,
                               int16_t deq[3][GV_DCT_ESCAPE])
{
    for (int c = 0; c < channels; c++)
        for (int t = 0; t < GV_DCT_ESCAPE; t++)
            deq[c][t] = clamp_s16(token_value(t) * steps[c]);
}

/* Decode the stream of row `row` (at `at`, `words` words) into coA, which must
 * be all zero (only coded coefficients are written), and each block's
 * count of coded coefficients into eobsA.  Returns 0 or -1. */
static int decode_row(const uint8_t *buf, size_t at, unsigned words, int row,
                      int channels, const struct dct_models *md,
                      const int32_t *steps, gv_dct_row coA,
                      uint8_t eobsA[3][GV_DCT_BLOCKS], struct gv_error *err)
{
    int16_t deq[3][GV_DCT_ESCAPE];
    dequantized_tokens(steps, channels, deq);
    LANE(A, at, words);
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++)
        for (int c = 0; c < channels; c++) {
            const int cc = c > 0;
            const uint32_t(*tok)[256] = md->slot + GV_DCT_EOB_MODELS + 12 * cc;
            const uint32_t *last = md->last ? md->slot[GV_DCT_LAST_MODEL + cc] : NULL;
            BLOCK_EOB(A);
            FIRST_TOKEN(A);
            const int endA = eobA - (last != NULL);
            for (int k = 1; k < endA; k++)
                TOKEN(A, k);
            LAST_TOKEN(A);
        }
    LANE_END(A, row);
    return 0;
badA:
    return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", row);
}

/* decode_row of rows `row` (at atA, wordsA words, into coA and eobsA)
 * and row + 1 (at atB, wordsB words, into coB and eobsB) in lockstep.
 * Returns 0, or -1 when either stream is damaged (without a message: the
 * caller decodes the rows again one by one for the message decode_row
 * gives, since the lanes may meet the damage in another order). */
static int decode_row_pair(const uint8_t *buf, size_t atA, unsigned wordsA,
                           size_t atB, unsigned wordsB, int channels,
                           const struct dct_models *md, const int32_t *steps,
                           gv_dct_row coA, uint8_t eobsA[3][GV_DCT_BLOCKS],
                           gv_dct_row coB, uint8_t eobsB[3][GV_DCT_BLOCKS])
{
    int16_t deq[3][GV_DCT_ESCAPE];
    dequantized_tokens(steps, channels, deq);
    LANE(A, atA, wordsA);
    LANE(B, atB, wordsB);
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++)
        for (int c = 0; c < channels; c++) {
            const int cc = c > 0;
            const uint32_t(*tok)[256] = md->slot + GV_DCT_EOB_MODELS + 12 * cc;
            const uint32_t *last = md->last ? md->slot[GV_DCT_LAST_MODEL + cc] : NULL;
            BLOCK_EOB(A);
            BLOCK_EOB(B);
            FIRST_TOKEN(A);
            FIRST_TOKEN(B);
            const int endA = eobA - (last != NULL), endB = eobB - (last != NULL);
            const int both = endA < endB ? endA : endB;
            int k = 1;
            for (; k < both; k++) {
                TOKEN(A, k);
                TOKEN(B, k);
            }
            for (; k < endA; k++)
                TOKEN(A, k);
            for (; k < endB; k++)
                TOKEN(B, k);
            LAST_TOKEN(A);
            LAST_TOKEN(B);
        }
    if (xA == RANS_L && nextA == nA && xB == RANS_L && nextB == nB)
        return 0;
badA:
badB:
    return -1;
}

/* Walk the streams of a checked buffer: begin, then one call per pair of
 * rows (and one for the last row alone). */
struct dct_rows {
    struct dct_layout l;
    struct dct_models md;
    int32_t steps[3];
    size_t at;
};

static int rows_begin(struct dct_rows *it, const uint8_t *buf, size_t len,
                      int channels, struct gv_error *err)
{
    if (parse_layout(buf, len, channels, &it->l, err) < 0)
        return -1;
    load_models(buf, &it->l, &it->md);
    for (int c = 0; c < 3; c++)
        it->steps[c] = gv_get16(buf + 2 + 2 * c);
    it->at = it->l.streams;
    return 0;
}

/* Rows `row` and, when row + 1 < 65, row + 1 into co[0], eobs[0] and
 * co[1], eobs[1]; the rows' coefficients must be all zero before. */
static int rows_next(struct dct_rows *it, const uint8_t *buf, int row,
                     int channels, gv_dct_row co[2],
                     uint8_t eobs[2][3][GV_DCT_BLOCKS], struct gv_error *err)
{
    const unsigned nA = gv_get16(buf + it->l.lengths + 2 * row);
    if (row + 1 == GV_DCT_BLOCKS) {
        if (decode_row(buf, it->at, nA, row, channels, &it->md, it->steps,
                       co[0], eobs[0], err) < 0)
            return -1;
        it->at += 2 * (size_t)nA;
        return 0;
    }
    const unsigned nB = gv_get16(buf + it->l.lengths + 2 * row + 2);
    const size_t atB = it->at + 2 * (size_t)nA;
    if (decode_row_pair(buf, it->at, nA, atB, nB, channels, &it->md,
                        it->steps, co[0], eobs[0], co[1], eobs[1]) < 0) {
        /* The first damage in stream order, and its message. */
        memset(co[0], 0, sizeof co[0]);
        memset(co[1], 0, sizeof co[1]);
        if (decode_row(buf, it->at, nA, row, channels, &it->md, it->steps,
                       co[0], eobs[0], err) < 0 ||
            decode_row(buf, atB, nB, row + 1, channels, &it->md, it->steps,
                       co[1], eobs[1], err) < 0)
            return -1;
    }
    it->at = atB + 2 * (size_t)nB;
    return 0;
}

int gv_dct_unpack(const uint8_t *buf, size_t len, int channels,
                  int16_t *coefs, struct gv_error *err)
{
    struct dct_rows it;
    static _Thread_local gv_dct_row co[2];
    uint8_t eobs[2][3][GV_DCT_BLOCKS];
    if (rows_begin(&it, buf, len, channels, err) < 0)
        return -1;
    for (int by = 0; by < GV_DCT_BLOCKS; by += 2) {
        memset(co, 0, sizeof co);
        if (rows_next(&it, buf, by, channels, co, eobs, err) < 0)
            return -1;
        for (int r = 0; r < 2 && by + r < GV_DCT_BLOCKS; r++)
            for (int v = 0; v < 8; v++) {
                int16_t *dst = coefs + (size_t)4 * (8 * (by + r) + v) * GV_DCT_PLANE;
                for (int X = 0; X < GV_DCT_PLANE; X++) {
                    for (int c = 0; c < 3; c++)
                        dst[4 * X + c] = c < channels ? co[r][c][v][X] : 0;
                    dst[4 * X + 3] = 0;
                }
            }
    }
    return 0;
}

void gv_dct_rebuild(const int16_t (*q)[GV_DCT_BLOCKS * GV_DCT_BLOCKS][64],
                    const uint8_t (*eob)[GV_DCT_BLOCKS * GV_DCT_BLOCKS],
                    const int *steps, int channels, const uint8_t *pred,
                    uint8_t *out)
{
    gv_dct_row co;
    uint8_t eobs[3][GV_DCT_BLOCKS];
    memset(co, 0, sizeof co);
    memcpy(out, pred, (size_t)GV_TILE * GV_TILE * channels);
    for (int by = 0; by < GV_DCT_BLOCKS; by++) {
        /* The coefficients as decode_row leaves them: q * step, clamped,
         * at their places in the row; gv_dct_add_row zeroes them again. */
        for (int c = 0; c < channels; c++)
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx, n = eob[c][b];
                int16_t *dst = &co[c][0][8 * bx];
                eobs[c][bx] = (uint8_t)n;
                for (int k = 0; k < n; k++)
                    dst[zz_offset[k]] = clamp_s16(q[c][b][k] * steps[c]);
            }
        gv_dct_add_row(co, eobs, channels, by, out);
    }
}

int gv_dct_decode(const uint8_t *buf, size_t len, int channels,
                  const uint8_t *parent, int qx, int qy, uint8_t *out,
                  struct gv_error *err)
{
    struct dct_rows it;
    gv_dct_row co[2];
    uint8_t eobs[2][3][GV_DCT_BLOCKS];
    struct gv_predictor pred;
    if (rows_begin(&it, buf, len, channels, err) < 0)
        return -1;
    gv_predictor_init(&pred, parent, channels, qx, qy);
    /* co stays zero between rows: each block's coded coefficients are
     * cleared again once used. */
    memset(co, 0, sizeof co);
    const size_t stride = (size_t)GV_TILE * channels;
    /* Where the CPU has AVX-512: sixteen rows at a time in SIMD lanes
     * (tile_dct_lanes.c), then their pixels; a group with damage, and the
     * last row, by the scalar code below. */
    struct gv_dct_lanes_arena *lanes = gv_dct_lanes_usable() ? gv_dct_lanes_arena() : NULL;
    int lanes_to = lanes ? GV_DCT_BLOCKS - 1 : 0;
    for (int by = 0; by < lanes_to; by += GV_DCT_LANES) {
        uint8_t lane_eobs[GV_DCT_LANES][3][GV_DCT_BLOCKS];
        uint32_t at[GV_DCT_LANES], end[GV_DCT_LANES];
        size_t a = it.at;
        for (int i = 0; i < GV_DCT_LANES; i++) {
            at[i] = (uint32_t)a;
            a += 2 * (size_t)gv_get16(buf + it.l.lengths + 2 * (by + i));
            end[i] = (uint32_t)a;
        }
        if (gv_dct_lanes_rows(buf, at, end, GV_DCT_LANES, channels,
                              &it.md.slot[0][0], it.md.last, it.steps, lanes,
                              lane_eobs) < 0) {
            lanes_to = by;
            break;
        }
        it.at = a;
        for (int r = 0; r < GV_DCT_LANES; r++) {
            const int y0 = 8 * (by + r);
            for (int j = 0; j < 8; j++)
                gv_predictor_row(&pred, y0 + j, out + (size_t)(y0 + j) * stride);
            gv_dct_add_row(lanes->rows[r], lane_eobs[r], channels, by + r, out);
        }
    }
    for (int by = lanes_to; by < GV_DCT_BLOCKS; by += 2) {
        if (rows_next(&it, buf, by, channels, co, eobs, err) < 0)
            return -1;
        for (int r = 0; r < 2 && by + r < GV_DCT_BLOCKS; r++) {
            const int y0 = 8 * (by + r);
            const int rows = y0 + 8 <= GV_TILE ? 8 : GV_TILE - y0;
            for (int j = 0; j < rows; j++)
                gv_predictor_row(&pred, y0 + j, out + (size_t)(y0 + j) * stride);
            gv_dct_add_row(co[r], eobs[r], channels, by + r, out);
        }
    }
    return 0;
}
