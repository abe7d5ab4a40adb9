/*
 * tile_dct.c - layout D (docs/FORMAT.md section 4.3): its layout check and
 * the CPU reference decoder.
 *
 * A buffer is decoded one row of 8x8 blocks at a time: the row's rANS
 * stream into its coefficients (at most 3 x 8 x 520 int16 on the stack),
 * the row's eight pixel rows predicted straight into the output, then
 * each block's inverse transform and colour transform added with
 * clamping.  Symbols are found through a 256-entry table per model (one
 * load per step: the models have 8-bit precision).  Arithmetic shifts of
 * negative numbers go through asr(), a floor division, so that the result
 * does not depend on the compiler.
 */
#include <string.h>

#include "base/byteorder.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
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

const int32_t gv_dct_matrix[8][8] = {
    {64, 64, 64, 64, 64, 64, 64, 64},
    {89, 75, 50, 18, -18, -50, -75, -89},
    {83, 36, -36, -83, -83, -36, 36, 83},
    {75, -18, -89, -50, 50, 89, 18, -75},
    {64, -64, -64, 64, 64, -64, -64, 64},
    {50, -89, 18, 75, -75, -18, 89, -50},
    {36, -83, 83, -36, -36, 83, -83, 36},
    {18, -50, 75, -89, 89, -75, 50, -18},
};

/* floor(a / 2^s).  GCC and Clang define >> of a negative number as the
 * arithmetic shift (and vectorize it); anything else gets the portable
 * form. */
static inline int32_t asr(int32_t a, int s)
{
#if defined(__GNUC__)
    return a >> s;
#else
    return a >= 0 ? a >> s : ~(~a >> s);
#endif
}

/* Offsets of a checked buffer's parts. */
struct dct_layout {
    uint32_t mask;
    size_t model_at[GV_DCT_MODELS];  /* 0 for an absent model */
    size_t lengths, streams;
};

static int parse_layout(const uint8_t *buf, size_t len, int channels,
                        struct dct_layout *l, struct gv_error *err)
{
    if (channels != 1 && channels != 3)
        return gv_fail(err, GV_EINVAL, "tile: bad channel count %d", channels);
    if (len < HEADER_BYTES || (len & 3) || buf[0] != GV_TILE_DCT || buf[1])
        return gv_fail(err, GV_ECORRUPT, "tile: bad layout D header");
    for (int c = 0; c < 3; c++) {
        unsigned s = gv_get16(buf + 2 + 2 * c);
        if (c < channels ? (s < 1 || s > GV_DCT_MAX_STEP) : s != 0)
            return gv_fail(err, GV_ECORRUPT, "tile: bad quantizer step %u "
                           "of channel %d", s, c);
    }
    l->mask = gv_get32(buf + 8);
    if (l->mask >> GV_DCT_MODELS)
        return gv_fail(err, GV_ECORRUPT, "tile: bad model mask 0x%08x",
                       (unsigned)l->mask);
    size_t at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        l->model_at[m] = 0;
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

/* The decoder's view of the models: the symbol of every slot, and
 * cumulative frequencies with cum[k] = 256 appended.  An absent model's
 * slots all name symbol 0 with frequency 0, which the decoder reports. */
struct dct_models {
    uint8_t sym[GV_DCT_MODELS][256];
    uint16_t cum[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS + 1];
};

static void load_models(const uint8_t *buf, const struct dct_layout *l,
                        struct dct_models *md)
{
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        const int k = gv_dct_model_symbols(m);
        if (!l->model_at[m]) {
            memset(md->sym[m], 0, 256);
            md->cum[m][0] = 0;
            md->cum[m][1] = 0;
            continue;
        }
        const uint8_t *c = buf + l->model_at[m];
        for (int s = 0; s < k; s++)
            md->cum[m][s] = c[s];
        md->cum[m][k] = 256;
        for (int s = 0; s < k; s++)
            for (unsigned slot = md->cum[m][s]; slot < md->cum[m][s + 1]; slot++)
                md->sym[m][slot] = (uint8_t)s;
    }
}

struct dct_stream {
    const uint8_t *w;
    uint32_t x, n, next;
};

/* One step with model m: the symbol, or -1 for a damaged stream.  The
 * state stays >= RANS_L from a valid start (checked once per stream):
 * after a step it is at least f * 256 with f >= 1, and a renormalization
 * takes it past 2^24. */
static inline int step(struct dct_stream *st, const struct dct_models *md, int m)
{
    const uint32_t slot = st->x & 255;
    const int s = md->sym[m][slot];
    const uint32_t c = md->cum[m][s], f = md->cum[m][s + 1] - c;
    if (f == 0)
        return -1;
    st->x = f * (st->x >> 8) + slot - c;
    if (st->x < RANS_L) {
        if (st->next >= st->n)
            return -1;
        st->x = st->x << 16 | gv_get16(st->w + 2 * st->next++);
    }
    return s;
}

/* A uniform 6-bit step. */
static inline int step_uniform(struct dct_stream *st)
{
    const uint32_t slot = st->x & 255;
    st->x = 4 * (st->x >> 8) + (slot & 3);
    if (st->x < RANS_L) {
        if (st->next >= st->n)
            return -1;
        st->x = st->x << 16 | gv_get16(st->w + 2 * st->next++);
    }
    return (int)(slot >> 2);
}

/* A row's coefficients: co[c][v][X], X = 8 * bx + u. */
typedef int16_t dct_row[3][8][GV_DCT_PLANE];

/* Decode stream `row` (at `at`, n words) into co, which must be all
 * zero (only coded coefficients are written), and each block's count of
 * coded coefficients into eobs.  Returns 0 or -1. */
static int decode_row(const uint8_t *buf, size_t at, unsigned n, int row,
                      int channels, const struct dct_models *md,
                      const int32_t *steps, dct_row co,
                      uint8_t eobs[3][GV_DCT_BLOCKS], struct gv_error *err)
{
    struct dct_stream st = {buf + at, 0, n, 2};
    st.x = gv_get16(st.w) | (uint32_t)gv_get16(st.w + 2) << 16;
    if (st.x < RANS_L)
        goto bad;
    int pe[3] = {0, 0, 0}, dcp[3] = {0, 0, 0};
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
        for (int c = 0; c < channels; c++) {
            const int cc = c > 0;
            const int tok_base = GV_DCT_EOB_MODELS + 12 * cc;
            const int eob = step(&st, md, 3 * cc + pe[c]);
            if (eob < 0)
                goto bad;
            eobs[c][bx] = (uint8_t)eob;
            int p = dcp[c], q0 = 0;
            for (int k = 0; k < eob; k++) {
                const int t = step(&st, md, tok_base + gv_dct_band_model[k] + p);
                if (t < 0)
                    goto bad;
                int q;
                if (t == GV_DCT_ESCAPE) {
                    const int h = step_uniform(&st);
                    if (h < 0)
                        goto bad;
                    const int lo = step_uniform(&st);
                    if (lo < 0)
                        goto bad;
                    q = 64 * h + lo - 2048;
                } else {
                    q = (t & 1) ? (t + 1) >> 1 : -(t >> 1);
                }
                int32_t d = q * steps[c];
                d = d < -32768 ? -32768 : (d > 32767 ? 32767 : d);
                const int z = gv_dct_zigzag[k];
                co[c][z >> 3][8 * bx + (z & 7)] = (int16_t)d;
                if (k == 0)
                    q0 = q;
                p = gv_dct_class(q);
            }
            pe[c] = eob == 0 ? 0 : (eob <= 4 ? 1 : 2);
            dcp[c] = gv_dct_class(q0);
        }
    }
    if (st.x != RANS_L || st.next != st.n)
        return gv_fail(err, GV_ECORRUPT, "tile: stream %d does not end "
                       "cleanly", row);
    return 0;
bad:
    return gv_fail(err, GV_ECORRUPT, "tile: stream %d is corrupt", row);
}

/* Walk the streams of a checked buffer: begin, then one call per row. */
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

static int rows_next(struct dct_rows *it, const uint8_t *buf, int row,
                     int channels, dct_row co, uint8_t eobs[3][GV_DCT_BLOCKS],
                     struct gv_error *err)
{
    unsigned n = gv_get16(buf + it->l.lengths + 2 * row);
    if (decode_row(buf, it->at, n, row, channels, &it->md, it->steps, co,
                   eobs, err) < 0)
        return -1;
    it->at += 2 * (size_t)n;
    return 0;
}

int gv_dct_unpack(const uint8_t *buf, size_t len, int channels,
                  int16_t *coefs, struct gv_error *err)
{
    struct dct_rows it;
    static _Thread_local dct_row co;
    uint8_t eobs[3][GV_DCT_BLOCKS];
    if (rows_begin(&it, buf, len, channels, err) < 0)
        return -1;
    for (int by = 0; by < GV_DCT_BLOCKS; by++) {
        memset(co, 0, sizeof co);
        if (rows_next(&it, buf, by, channels, co, eobs, err) < 0)
            return -1;
        for (int v = 0; v < 8; v++) {
            int16_t *dst = coefs + (size_t)4 * (8 * by + v) * GV_DCT_PLANE;
            for (int X = 0; X < GV_DCT_PLANE; X++) {
                for (int c = 0; c < 3; c++)
                    dst[4 * X + c] = c < channels ? co[c][v][X] : 0;
                dst[4 * X + 3] = 0;
            }
        }
    }
    return 0;
}

void gv_dct_inverse(const int16_t *d, int32_t *e)
{
    int32_t t[8][8];   /* t[v][i] */
    for (int v = 0; v < 8; v++) {
        const int16_t *dv = d + 8 * v;
        int any = 0;
        for (int u = 0; u < 8; u++)
            any |= dv[u];
        for (int i = 0; i < 8; i++) {
            int32_t s = 64;
            if (any)
                for (int u = 0; u < 8; u++)
                    s += gv_dct_matrix[u][i] * dv[u];
            t[v][i] = asr(s, 7);
        }
    }
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 8; i++) {
            int32_t s = 1024;
            for (int v = 0; v < 8; v++)
                s += gv_dct_matrix[v][j] * t[v][i];
            e[8 * j + i] = asr(s, 11);
        }
}

/* The rows and columns that the first n coefficients in zigzag order
 * reach: zz_rows[n] = 1 + the largest v, zz_cols[n] = 1 + the largest u. */
static uint8_t zz_rows[65], zz_cols[65];

static void init_zz_extent(void)
{
    int v = 0, u = 0;
    zz_rows[0] = zz_cols[0] = 0;
    for (int n = 1; n <= 64; n++) {
        int z = gv_dct_zigzag[n - 1];
        v = (z >> 3) + 1 > v ? (z >> 3) + 1 : v;
        u = (z & 7) + 1 > u ? (z & 7) + 1 : u;
        zz_rows[n] = (uint8_t)v;
        zz_cols[n] = (uint8_t)u;
    }
}

/* gv_dct_inverse of a block whose coefficients past the first n in
 * zigzag order are zero (n >= 1), read from row-major storage with
 * `stride` between rows: the terms left out are zero, so the integers are
 * the same. */
static void inverse_sparse(const int16_t *d, size_t stride, int n, int32_t *e)
{
    const int rows = zz_rows[n], cols = zz_cols[n];
    if (n == 1) {
        const int32_t t = asr(64 * d[0] + 64, 7), v = asr(64 * t + 1024, 11);
        for (int k = 0; k < 64; k++)
            e[k] = v;
        return;
    }
    int32_t t[8][8];   /* t[v][i], rows v < `rows` */
    /* Loops over i innermost, eight lanes, so that they vectorize. */
    for (int v = 0; v < rows; v++) {
        const int16_t *dv = d + (size_t)v * stride;
        int32_t acc[8] = {64, 64, 64, 64, 64, 64, 64, 64};
        for (int u = 0; u < cols; u++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[u][i] * dv[u];
        for (int i = 0; i < 8; i++)
            t[v][i] = asr(acc[i], 7);
    }
    for (int j = 0; j < 8; j++) {
        int32_t acc[8] = {1024, 1024, 1024, 1024, 1024, 1024, 1024, 1024};
        for (int v = 0; v < rows; v++)
            for (int i = 0; i < 8; i++)
                acc[i] += gv_dct_matrix[v][j] * t[v][i];
        for (int i = 0; i < 8; i++)
            e[8 * j + i] = asr(acc[i], 11);
    }
}

static inline uint8_t clamp_u8(int32_t v)
{
    return (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
}

int gv_dct_decode(const uint8_t *buf, size_t len, int channels,
                  const uint8_t *parent, int qx, int qy, uint8_t *out,
                  struct gv_error *err)
{
    struct dct_rows it;
    dct_row co;
    uint8_t eobs[3][GV_DCT_BLOCKS];
    struct gv_predictor pred;
    if (!zz_rows[64])
        init_zz_extent();
    if (rows_begin(&it, buf, len, channels, err) < 0)
        return -1;
    gv_predictor_init(&pred, parent, channels, qx, qy);
    /* co stays zero between rows: each block's coded coefficients are
     * cleared again once used. */
    memset(co, 0, sizeof co);
    const size_t stride = (size_t)GV_TILE * channels;
    for (int by = 0; by < GV_DCT_BLOCKS; by++) {
        if (rows_next(&it, buf, by, channels, co, eobs, err) < 0)
            return -1;
        const int y0 = 8 * by, rows = y0 + 8 <= GV_TILE ? 8 : GV_TILE - y0;
        for (int j = 0; j < rows; j++)
            gv_predictor_row(&pred, y0 + j, out + (size_t)(y0 + j) * stride);
        for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
            int32_t e[3][64];
            int n[3] = {eobs[0][bx], 0, 0};
            if (channels == 3) {
                n[1] = eobs[1][bx];
                n[2] = eobs[2][bx];
            }
            if (!(n[0] | n[1] | n[2]))
                continue;
            for (int c = 0; c < channels; c++) {
                int16_t *d = &co[c][0][8 * bx];
                if (!n[c]) {
                    /* Zeros only where another channel needs them. */
                    if (c > 0 || n[1] | n[2])
                        memset(e[c], 0, sizeof e[c]);
                    continue;
                }
                inverse_sparse(d, GV_DCT_PLANE, n[c], e[c]);
                for (int k = 0; k < n[c]; k++) {
                    const int z = gv_dct_zigzag[k];
                    d[(size_t)(z >> 3) * GV_DCT_PLANE + (z & 7)] = 0;
                }
            }
            const int x0 = 8 * bx, cols = x0 + 8 <= GV_TILE ? 8 : GV_TILE - x0;
            const int gray_residual = channels == 1 || !(n[1] | n[2]);
            for (int j = 0; j < rows; j++) {
                uint8_t *px = out + (size_t)(y0 + j) * stride + (size_t)x0 * channels;
                const int32_t *ey = e[0] + 8 * j;
                if (channels == 1) {
                    for (int i = 0; i < cols; i++)
                        px[i] = clamp_u8(px[i] + ey[i]);
                } else if (gray_residual) {
                    /* Co = Cg = 0: YCoCg-R gives R = G = B = Y. */
                    for (int i = 0; i < 3 * cols; i++)
                        px[i] = clamp_u8(px[i] + ey[i / 3]);
                } else {
                    for (int i = 0; i < cols; i++, px += 3) {
                        const int k = 8 * j + i;
                        const int32_t y = e[0][k], co_ = e[1][k], cg = e[2][k];
                        const int32_t t = y - asr(cg, 1);
                        const int32_t g = cg + t, b = t - asr(co_, 1), r = b + co_;
                        px[0] = clamp_u8(px[0] + r);
                        px[1] = clamp_u8(px[1] + g);
                        px[2] = clamp_u8(px[2] + b);
                    }
                }
            }
        }
    }
    return 0;
}
