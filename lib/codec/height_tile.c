/*
 * height_tile.c - prediction, quantization and rANS coding of height tiles
 * (see height_tile.h and docs/FORMAT.md section 9).
 *
 * The rANS coder is the one of tile_rans.c (32-bit state, 16-bit words,
 * 15-bit frequencies, Duda's "Asymmetric numeral systems", rANS variant as
 * in ryg_rans); the encoder runs backwards over each stream and writes the
 * final state first.  Extra bits of large values are rANS steps with a
 * uniform table (frequency 2^(15-k) for k bits), so that a stream is a
 * single sequence of steps that one GPU thread decodes.
 */
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "codec/height_tile.h"

#define PROB_BITS 15
#define PROB_SCALE (1u << PROB_BITS)
#define RANS_L 65536u
#define CHUNK 12   /* extra bits coded in steps of at most 12 bits */

/* Catmull-Rom weights in 128ths (FORMAT.md section 3): child sample u
 * even takes parent columns p-2..p+1, odd p-1..p+2, p = 256q + (u >> 1). */
static const int32_t W[2][4] = {{-3, 29, 111, -9}, {-9, 111, 29, -3}};

static int clamp512(int c)
{
    return c < 0 ? 0 : (c > 512 ? 512 : c);
}

int gv_height_predict(const uint16_t *parent, int qx, int qy, uint16_t *pred)
{
    /* Horizontal sums of the parent rows this quadrant uses (rows
     * 256qy-2 .. 256qy+258, clamped), then the vertical sum: the same
     * integers as the direct double sum, |s| < 2^31. */
    int32_t *hs = malloc(sizeof *hs * 261 * GV_HT_SIDE);
    if (!hs)
        return -1;
    const int r0 = 256 * qy - 2;
    for (int r = 0; r < 261; r++) {
        const uint16_t *row = parent + clamp512(r0 + r) * GV_HT_SIDE;
        for (int u = 0; u < GV_HT_SIDE; u++) {
            int px = 256 * qx + (u >> 1) + ((u & 1) ? -1 : -2);
            const int32_t *w = W[u & 1];
            hs[r * GV_HT_SIDE + u] = w[0] * row[clamp512(px)] + w[1] * row[clamp512(px + 1)] +
                                     w[2] * row[clamp512(px + 2)] + w[3] * row[clamp512(px + 3)];
        }
    }
    for (int v = 0; v < GV_HT_SIDE; v++) {
        /* parent row py = 256qy + (v >> 1) - 2 (+1 for odd v) = r0 + k */
        int k = (v >> 1) + ((v & 1) ? 1 : 0);
        const int32_t *w = W[v & 1];
        const int32_t *a = hs + k * GV_HT_SIDE;
        for (int u = 0; u < GV_HT_SIDE; u++) {
            int32_t sum = w[0] * a[u] + w[1] * a[u + GV_HT_SIDE] +
                          w[2] * a[u + 2 * GV_HT_SIDE] + w[3] * a[u + 3 * GV_HT_SIDE];
            int64_t t = (int64_t)sum + 8192;
            pred[v * GV_HT_SIDE + u] =
                (uint16_t)(t < 0 ? 0 : (t > 65535 * 16384 + 16383 ? 65535 : t >> 14));
        }
    }
    free(hs);
    return 0;
}

/* ---- tokens ---- */

static uint32_t zigzag(int32_t q)
{
    return q >= 0 ? (uint32_t)q << 1 : ((uint32_t)(-(q + 1)) << 1) | 1u;
}

static int32_t unzigzag(uint32_t z)
{
    return (z & 1) ? -(int32_t)(z >> 1) - 1 : (int32_t)(z >> 1);
}

static int bitlen(uint32_t z)
{
    int n = 0;
    while (z) {
        n++;
        z >>= 1;
    }
    return n;
}

/* Token of z, and the number of extra bits after it. */
static int token_of(uint32_t z, int *extra)
{
    if (z < GV_HT_DIRECT) {
        *extra = 0;
        return (int)z;
    }
    int nb = bitlen(z);          /* 5..17 */
    *extra = nb - 1;
    return GV_HT_DIRECT + nb - 5;
}

/* ---- the encoder ---- */

/* Normalize counts to frequencies summing to 2^15, every used token at
 * least 1 (deterministic: largest-count token absorbs the rounding). */
static void normalize(const uint64_t *count, uint32_t *freq)
{
    uint64_t total = 0;
    int big = 0;
    for (int t = 0; t < GV_HT_TOKENS; t++) {
        total += count[t];
        if (count[t] > count[big])
            big = t;
    }
    uint32_t sum = 0;
    for (int t = 0; t < GV_HT_TOKENS; t++) {
        freq[t] = 0;
        if (!count[t])
            continue;
        uint64_t f = count[t] * PROB_SCALE / total;
        freq[t] = f ? (uint32_t)f : 1;
        sum += freq[t];
    }
    /* Move the difference onto (or off) the commonest tokens. */
    while (sum > PROB_SCALE) {
        int m = -1;
        for (int t = 0; t < GV_HT_TOKENS; t++)
            if (freq[t] > 1 && (m < 0 || freq[t] > freq[m]))
                m = t;
        uint32_t d = sum - PROB_SCALE, room = freq[m] - 1;
        uint32_t take = d < room ? d : room;
        freq[m] -= take;
        sum -= take;
    }
    freq[big] += PROB_SCALE - sum;
}

struct enc {
    uint16_t *words;   /* emitted backwards */
    size_t n;
    uint32_t x;
};

static void put(struct enc *e, uint32_t cum, uint32_t f)
{
    uint64_t xmax = (uint64_t)f << 17;   /* ((L >> 15) << 16) * f */
    if (e->x >= xmax) {
        e->words[e->n++] = (uint16_t)(e->x & 0xffff);
        e->x >>= 16;
    }
    e->x = ((e->x / f) << PROB_BITS) + (e->x % f) + cum;
}

/* Extra bits of z after its token, in decoding order: a low chunk of up
 * to 12 bits, then the rest. */
static void put_extra(struct enc *e, uint32_t z, int extra)
{
    uint32_t v = z - (1u << extra);
    int lo = extra < CHUNK ? extra : CHUNK, hi = extra - lo;
    if (hi > 0) {
        uint32_t f = 1u << (PROB_BITS - hi);
        put(e, (v >> lo) * f, f);
    }
    uint32_t f = 1u << (PROB_BITS - lo);
    put(e, (v & ((1u << lo) - 1)) * f, f);
}

/* Context of sample i (row v, column u) of a stream whose first row is
 * r0: bitlen(|left| + |above|) capped, neighbours outside the stream 0. */
static int context_of(const int32_t *q, int u, int v, int r0)
{
    uint32_t a = u ? (uint32_t)abs(q[v * GV_HT_SIDE + u - 1]) : 0;
    uint32_t b = v > r0 ? (uint32_t)abs(q[(v - 1) * GV_HT_SIDE + u]) : 0;
    int c = bitlen(a + b);
    return c < GV_HT_CONTEXTS - 1 ? c : GV_HT_CONTEXTS - 1;
}

/* Bytes before the streams for a context mask. */
static size_t streams_at(unsigned mask)
{
    size_t n = 0;
    for (int c = 0; c < GV_HT_CONTEXTS; c++)
        n += (mask >> c) & 1;
    return (GV_HT_CUM_AT + n * 2 * GV_HT_TOKENS + 3) & ~(size_t)3;
}

size_t gv_height_tile_encode(const uint16_t *orig, const uint16_t *parent,
                             int qx, int qy, int e, int valid_w, int valid_h,
                             uint8_t *out, uint16_t *dec)
{
    const int32_t step = 2 * e + 1;
    int32_t *q = malloc(sizeof *q * GV_HT_SAMPLES);
    uint8_t *ctx = malloc(GV_HT_SAMPLES);
    uint16_t *words = malloc(sizeof *words * (GV_HT_ROWS * GV_HT_SIDE * 2 + 4));
    size_t len = 0;
    if (!q || !ctx || !words || gv_height_predict(parent, qx, qy, dec) < 0)
        goto out;
    static const uint64_t zero[GV_HT_TOKENS];
    uint64_t count[GV_HT_CONTEXTS][GV_HT_TOKENS];
    for (int c = 0; c < GV_HT_CONTEXTS; c++)
        memcpy(count[c], zero, sizeof zero);
    int any = 0;
    for (int v = 0; v < GV_HT_SIDE; v++)
        for (int u = 0; u < GV_HT_SIDE; u++) {
            int i = v * GV_HT_SIDE + u;
            int32_t qq = 0;
            if (u < valid_w && v < valid_h) {
                int32_t r = (int32_t)orig[i] - dec[i];
                qq = r >= 0 ? (r + e) / step : -((-r + e) / step);
                int32_t x = dec[i] + qq * step;
                dec[i] = (uint16_t)(x < 0 ? 0 : (x > 65535 ? 65535 : x));
            }
            q[i] = qq;
            any |= qq != 0;
        }
    for (int v = 0; v < GV_HT_SIDE; v++)
        for (int u = 0; u < GV_HT_SIDE; u++) {
            int i = v * GV_HT_SIDE + u, extra;
            ctx[i] = (uint8_t)context_of(q, u, v, v - v % GV_HT_ROWS);
            count[ctx[i]][token_of(zigzag(q[i]), &extra)]++;
        }
    memset(out, 0, GV_HT_DATA_AT);
    gv_put16(out + 2, (uint16_t)e);
    if (!any) {
        len = 4;
        goto out;
    }
    out[0] = 1;
    uint32_t freq[GV_HT_CONTEXTS][GV_HT_TOKENS], cum[GV_HT_CONTEXTS][GV_HT_TOKENS + 1];
    unsigned mask = 0;
    size_t at = GV_HT_CUM_AT;
    for (int c = 0; c < GV_HT_CONTEXTS; c++) {
        uint64_t total = 0;
        for (int t = 0; t < GV_HT_TOKENS; t++)
            total += count[c][t];
        if (!total)
            continue;
        mask |= 1u << c;
        normalize(count[c], freq[c]);
        cum[c][0] = 0;
        for (int t = 0; t < GV_HT_TOKENS; t++) {
            cum[c][t + 1] = cum[c][t] + freq[c][t];
            gv_put16(out + at, (uint16_t)cum[c][t]);
            at += 2;
        }
    }
    gv_put16(out + GV_HT_MASK_AT, (uint16_t)mask);
    at = streams_at(mask);
    for (int s = 0; s < GV_HT_STREAMS; s++) {
        int r0 = s * GV_HT_ROWS, r1 = r0 + GV_HT_ROWS;
        if (r1 > GV_HT_SIDE)
            r1 = GV_HT_SIDE;
        struct enc en = {words, 0, RANS_L};
        for (int i = r1 * GV_HT_SIDE - 1; i >= r0 * GV_HT_SIDE; i--) {
            int extra;
            uint32_t z = zigzag(q[i]);
            int t = token_of(z, &extra);
            if (extra)
                put_extra(&en, z, extra);
            put(&en, cum[ctx[i]][t], freq[ctx[i]][t]);
        }
        size_t n = en.n + 2;
        if (n > 65535 || at + 2 * n > GV_HT_BUF_MAX - 4) {
            len = 0;
            goto out;
        }
        gv_put16(out + GV_HT_LEN_AT + 2 * s, (uint16_t)n);
        gv_put16(out + at, (uint16_t)(en.x & 0xffff));
        gv_put16(out + at + 2, (uint16_t)(en.x >> 16));
        at += 4;
        for (size_t k = en.n; k-- > 0; at += 2)
            gv_put16(out + at, words[k]);
    }
    while (at & 3)
        out[at++] = 0;
    len = at;
out:
    free(q);
    free(ctx);
    free(words);
    return len;
}

/* ---- the decoder ---- */

size_t gv_height_tile_span(const uint8_t *buf, size_t len)
{
    if (len < 4 || buf[0] > 1)
        return 0;
    if (buf[0] == 0)
        return 4;
    if (len < GV_HT_CUM_AT)
        return 0;
    unsigned mask = gv_get16(buf + GV_HT_MASK_AT);
    if (!mask || mask >> GV_HT_CONTEXTS)
        return 0;
    size_t words = 0;
    for (int s = 0; s < GV_HT_STREAMS; s++)
        words += gv_get16(buf + GV_HT_LEN_AT + 2 * s);
    size_t end = (streams_at(mask) + 2 * words + 3) & ~(size_t)3;
    return end <= len ? end : 0;
}

int gv_height_tile_check(const uint8_t *buf, size_t len, struct gv_error *err)
{
    if (len < 4 || (len & 3) || buf[1] != 0 || buf[0] > 1 ||
        gv_get16(buf + 2) > GV_HT_MAX_E)
        return gv_fail(err, GV_ECORRUPT, "height: bad tile header");
    if (buf[0] == 0)
        return len == 4 ? 0 : gv_fail(err, GV_ECORRUPT, "height: prediction-"
                                      "only tile of %zu bytes", len);
    if (len < GV_HT_CUM_AT || len > GV_HT_BUF_MAX)
        return gv_fail(err, GV_ECORRUPT, "height: tile of %zu bytes", len);
    unsigned mask = gv_get16(buf + GV_HT_MASK_AT);
    if (!mask || mask >> GV_HT_CONTEXTS)
        return gv_fail(err, GV_ECORRUPT, "height: bad context mask");
    size_t sa = streams_at(mask);
    if (len < sa)
        return gv_fail(err, GV_ECORRUPT, "height: tile of %zu bytes", len);
    for (size_t at = GV_HT_CUM_AT; at + 2 * GV_HT_TOKENS <= sa; at += 2 * GV_HT_TOKENS) {
        uint32_t prev = 0;
        for (int t = 0; t < GV_HT_TOKENS; t++) {
            uint32_t c = gv_get16(buf + at + 2 * t);
            if (c < prev || c > PROB_SCALE || (t == 0 && c != 0))
                return gv_fail(err, GV_ECORRUPT, "height: bad frequency table");
            prev = c;
        }
    }
    size_t words = 0;
    for (int s = 0; s < GV_HT_STREAMS; s++) {
        uint32_t n = gv_get16(buf + GV_HT_LEN_AT + 2 * s);
        if (n < 2)
            return gv_fail(err, GV_ECORRUPT, "height: stream %d too short", s);
        words += n;
    }
    size_t end = sa + 2 * words;
    if (((end + 3) & ~(size_t)3) != len)
        return gv_fail(err, GV_ECORRUPT, "height: tile length %zu does not "
                       "match its streams", len);
    return 0;
}

struct dec {
    const uint8_t *w;   /* next word */
    uint32_t left;      /* words left */
    uint32_t x;
};

/* Refill the state from the stream after a step (one 16-bit word when it
 * fell below RANS_L): 0, or -1 when the stream runs out. */
static inline int renorm(struct dec *d)
{
    if (d->x < RANS_L) {
        if (!d->left)
            return -1;
        d->x = (d->x << 16) | gv_get16(d->w);
        d->w += 2;
        d->left--;
    }
    return 0;
}

/* One step with the table cum[0..ntok] (cum[ntok] = 2^15): the symbol, or
 * -1 when the stream runs out. */
static int step_table(struct dec *d, const uint32_t *cum)
{
    uint32_t slot = d->x & (PROB_SCALE - 1);
    int s = GV_HT_TOKENS - 1;
    while (cum[s] > slot)
        s--;
    /* cum[s] <= slot < cum[s+1] so f > 0 */
    d->x = (cum[s + 1] - cum[s]) * (d->x >> PROB_BITS) + slot - cum[s];
    if (renorm(d) < 0)
        return -1;
    return s;
}

/* One uniform step of k bits (1..15); -1 when the stream runs out. */
static int32_t step_bits(struct dec *d, int k)
{
    uint32_t slot = d->x & (PROB_SCALE - 1), sh = (uint32_t)(PROB_BITS - k);
    uint32_t v = slot >> sh;
    d->x = (1u << sh) * (d->x >> PROB_BITS) + (slot & ((1u << sh) - 1));
    if (renorm(d) < 0)
        return -1;
    return (int32_t)v;
}

int gv_height_tile_residuals(const uint8_t *buf, size_t len, int32_t *q,
                             int *e, struct gv_error *err)
{
    if (gv_height_tile_check(buf, len, err) < 0)
        return -1;
    *e = gv_get16(buf + 2);
    if (buf[0] == 0) {
        memset(q, 0, sizeof *q * GV_HT_SAMPLES);
        return 0;
    }
    /* Tables by context; an absent context has none (-1). */
    uint32_t cum[GV_HT_CONTEXTS][GV_HT_TOKENS + 1];
    int have[GV_HT_CONTEXTS];
    unsigned mask = gv_get16(buf + GV_HT_MASK_AT);
    size_t at = GV_HT_CUM_AT;
    for (int c = 0; c < GV_HT_CONTEXTS; c++) {
        have[c] = (mask >> c) & 1;
        if (!have[c])
            continue;
        for (int t = 0; t < GV_HT_TOKENS; t++)
            cum[c][t] = gv_get16(buf + at + 2 * t);
        cum[c][GV_HT_TOKENS] = PROB_SCALE;
        at += 2 * GV_HT_TOKENS;
    }
    const uint8_t *w = buf + streams_at(mask);
    for (int s = 0; s < GV_HT_STREAMS; s++) {
        uint32_t n = gv_get16(buf + GV_HT_LEN_AT + 2 * s);
        struct dec d = {w + 4, n - 2, gv_get16(w) | (uint32_t)gv_get16(w + 2) << 16};
        w += 2 * n;
        int r0 = s * GV_HT_ROWS, r1 = r0 + GV_HT_ROWS;
        if (r1 > GV_HT_SIDE)
            r1 = GV_HT_SIDE;
        for (int v = r0; v < r1; v++)
            for (int u = 0; u < GV_HT_SIDE; u++) {
                int c = context_of(q, u, v, r0);
                if (!have[c])
                    goto corrupt;
                int t = step_table(&d, cum[c]);
                if (t < 0)
                    goto corrupt;
                uint32_t z = (uint32_t)t;
                if (t >= GV_HT_DIRECT) {
                    int extra = t - GV_HT_DIRECT + 4;
                    int lo = extra < CHUNK ? extra : CHUNK, hi = extra - lo;
                    int32_t vl = step_bits(&d, lo), vh = 0;
                    if (vl < 0 || (hi > 0 && (vh = step_bits(&d, hi)) < 0))
                        goto corrupt;
                    z = (1u << extra) + ((uint32_t)vh << lo) + (uint32_t)vl;
                }
                q[v * GV_HT_SIDE + u] = unzigzag(z);
            }
        if (d.x != RANS_L || d.left)
            goto corrupt;
    }
    return 0;
corrupt:
    return gv_fail(err, GV_ECORRUPT, "height: damaged rANS stream");
}

int gv_height_tile_decode(const uint8_t *buf, size_t len,
                          const uint16_t *parent, int qx, int qy,
                          uint16_t *out, struct gv_error *err)
{
    int32_t *q = malloc(sizeof *q * GV_HT_SAMPLES);
    int e, rc = -1;
    if (!q)
        return gv_fail(err, GV_ENOMEM, "height: out of memory");
    if (gv_height_tile_residuals(buf, len, q, &e, err) < 0)
        goto out;
    if (gv_height_predict(parent, qx, qy, out) < 0) {
        gv_fail(err, GV_ENOMEM, "height: out of memory");
        goto out;
    }
    const int64_t step = 2 * e + 1;
    for (int i = 0; i < GV_HT_SAMPLES; i++) {
        int64_t v = out[i] + (int64_t)q[i] * step;
        out[i] = (uint16_t)(v < 0 ? 0 : (v > 65535 ? 65535 : v));
    }
    rc = 0;
out:
    free(q);
    return rc;
}
