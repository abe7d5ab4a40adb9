/*
 * tile_dct_encode.c - the layout D encoder (docs/FORMAT.md section 4.3).
 *
 * The residual against the prediction is taken to YCoCg (floating point:
 * the decoder's YCoCg-R lifting inverts it to within its rounding), the
 * pixels past the tile or the image replicated from the last valid ones
 * so that padding costs few bits, and every 8x8 block transformed by the
 * forward form of the decoder's integer DCT.  Blocks wholly outside the
 * image are coded as zero.
 *
 * Quantization rounds with a dead zone (offset ROUND_OFFSET instead of
 * 1/2), which lowers the rate more than it raises the error.  The step
 * of channel 0 is searched over half and then quarter octaves around the
 * high-rate optimum for lambda, each candidate costed by its exact model entropy
 * (the 8-bit models as the buffer will store them, their bytes included)
 * and by its squared error estimated in the transform domain; chroma
 * steps follow at the ratios that equalize the slopes of the YCoCg-R
 * inverse (a unit of error in Y reaches three channels, one in Co half
 * of two, one in Cg a quarter of three: weights 3, 1/2, 3/4).  The best
 * candidate is written and decoded by gv_dct_decode, whose output is the
 * reconstruction and whose error is exact.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_layout.h"
#include "codec/tile_rans.h"

#define NB (GV_DCT_BLOCKS * GV_DCT_BLOCKS)
#define ROUND_OFFSET 0.36f      /* dead-zone rounding: floor(|x|/S + this) */
#define HEADER_BYTES 12
#define LENGTHS_BYTES (2 * GV_DCT_BLOCKS)
#define STEP_CANDIDATES 13      /* quarter octaves from 2^-0.5 to 2^2.5 */
#define LN2 0.69314718055994530942

/* 2^(-0.5 + 0.25 i), written out rather than computed with pow(), whose
 * last bit may differ between C libraries: the steps, and so the stores,
 * must not depend on the machine (sqrt is exact in IEEE arithmetic). */
static const double step_factor[STEP_CANDIDATES] = {
    0.70710678118654752, 0.84089641525371454, 1.0, 1.18920711500272107,
    1.41421356237309505, 1.68179283050742908, 2.0, 2.37841423000544213,
    2.82842712474619010, 3.36358566101485816, 4.0, 4.75682846001088427,
    5.65685424949238020,
};
#define MAX_ROW_SYMBOLS (GV_DCT_BLOCKS * 3 * (1 + 64 * 3))

static const double channel_weight[3] = {3.0, 0.5, 0.75};

struct sym {
    int16_t model;   /* -1: a uniform 6-bit step */
    int16_t s;
};

struct gv_dct_workspace {
    float x[3][NB][64];          /* transform of the residual, natural order */
    int16_t q[3][NB][64];        /* candidate quantized values, zigzag order */
    uint8_t eob[3][NB];
    float maxabs[3][NB];         /* largest |coefficient| of each block */
    double energy[3][NB];        /* sum of its squares */
    int16_t bq[3][NB][64];       /* the best candidate */
    uint8_t beob[3][NB];
    struct sym syms[MAX_ROW_SYMBOLS];
    uint16_t words[MAX_ROW_SYMBOLS + 2];
};

struct gv_dct_workspace *gv_dct_workspace_new(void)
{
    return malloc(sizeof(struct gv_dct_workspace));
}

void gv_dct_workspace_free(struct gv_dct_workspace *ws)
{
    free(ws);
}

/* The residual of channel c (YCoCg when C = 3) at pixel (x, y), the
 * coordinates clamped to the valid area. */
static void residual_block(const uint8_t *orig, const uint8_t *pred,
                           int channels, int bx, int by, uint32_t vw,
                           uint32_t vh, float out[3][64])
{
    for (int j = 0; j < 8; j++) {
        uint32_t y = (uint32_t)(8 * by + j);
        if (y >= vh)
            y = vh - 1;
        for (int i = 0; i < 8; i++) {
            uint32_t x = (uint32_t)(8 * bx + i);
            if (x >= vw)
                x = vw - 1;
            const size_t at = ((size_t)y * GV_TILE + x) * (size_t)channels;
            if (channels == 1) {
                out[0][8 * j + i] = (float)orig[at] - (float)pred[at];
                continue;
            }
            const float r = (float)orig[at] - pred[at];
            const float g = (float)orig[at + 1] - pred[at + 1];
            const float b = (float)orig[at + 2] - pred[at + 2];
            const float co = r - b, t = b + co / 2, cg = g - t;
            out[0][8 * j + i] = t + cg / 2;
            out[1][8 * j + i] = co;
            out[2][8 * j + i] = cg;
        }
    }
}

/* d[v][u] = sum_j sum_i K[v][j] K[u][i] e(i, j) / 4096: the coefficients
 * whose integer inverse (FORMAT.md 4.3) gives back e. */
static void forward(const float *e, float *d)
{
    float t[8][8];   /* t[j][u] */
    for (int j = 0; j < 8; j++)
        for (int u = 0; u < 8; u++) {
            float s = 0;
            for (int i = 0; i < 8; i++)
                s += (float)gv_dct_matrix[u][i] * e[8 * j + i];
            t[j][u] = s;
        }
    for (int v = 0; v < 8; v++)
        for (int u = 0; u < 8; u++) {
            float s = 0;
            for (int j = 0; j < 8; j++)
                s += (float)gv_dct_matrix[v][j] * t[j][u];
            d[8 * v + u] = s / 4096.0f;
        }
}

static void transform_tile(struct gv_dct_workspace *ws, const uint8_t *orig,
                           const uint8_t *pred, int channels, uint32_t vw,
                           uint32_t vh)
{
    for (int by = 0; by < GV_DCT_BLOCKS; by++)
        for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
            const int b = by * GV_DCT_BLOCKS + bx;
            if ((uint32_t)(8 * bx) >= vw || (uint32_t)(8 * by) >= vh) {
                for (int c = 0; c < channels; c++)
                    memset(ws->x[c][b], 0, sizeof ws->x[c][b]);
                continue;
            }
            float e[3][64];
            residual_block(orig, pred, channels, bx, by, vw, vh, e);
            for (int c = 0; c < channels; c++)
                forward(e[c], ws->x[c][b]);
        }
    for (int c = 0; c < channels; c++)
        for (int b = 0; b < NB; b++) {
            float m = 0;
            double e2 = 0;
            for (int k = 0; k < 64; k++) {
                const float a = fabsf(ws->x[c][b][k]);
                m = a > m ? a : m;
                e2 += (double)a * a;
            }
            ws->maxabs[c][b] = m;
            ws->energy[c][b] = e2;
        }
}

/* Quantize every block at steps[], filling q, eob; returns the estimated
 * weighted squared error (transform domain, pixel units).  A block whose
 * largest coefficient rounds to 0 is all zero: its error is its energy and
 * its q is left alone (only the first eob values are ever read). */
static double quantize(struct gv_dct_workspace *ws, int channels,
                       const int *steps)
{
    double sse = 0;
    for (int c = 0; c < channels; c++) {
        const float inv = 1.0f / (float)steps[c], s = (float)steps[c];
        const float zero_below = (1.0f - ROUND_OFFSET) * s;
        const double w = channels == 1 ? 1.0 : channel_weight[c];
        double e2 = 0;
        for (int b = 0; b < NB; b++) {
            if (ws->maxabs[c][b] < zero_below) {
                ws->eob[c][b] = 0;
                e2 += ws->energy[c][b];
                continue;
            }
            const float *x = ws->x[c][b];
            int16_t *q = ws->q[c][b];
            int16_t nat[64];
            float acc[8] = {0, 0, 0, 0, 0, 0, 0, 0};
            /* Branch-free, in eight lanes, so that it vectorizes: the
             * truncation of a non-negative number is its floor. */
            for (int k = 0; k < 64; k += 8)
                for (int l = 0; l < 8; l++) {
                    const float v = x[k + l], a = fabsf(v);
                    float f = a * inv + ROUND_OFFSET;
                    f = f < 2047.5f ? f : 2047.5f;
                    const int m = (int)f;
                    const float err = a - (float)m * s;
                    acc[l] += err * err;
                    nat[k + l] = (int16_t)(v < 0 ? -m : m);
                }
            const float eb = ((acc[0] + acc[1]) + (acc[2] + acc[3])) +
                             ((acc[4] + acc[5]) + (acc[6] + acc[7]));
            int last = 0;
            for (int k = 0; k < 64; k++) {
                q[k] = nat[gv_dct_zigzag[k]];
                if (q[k])
                    last = k + 1;
            }
            ws->eob[c][b] = (uint8_t)last;
            e2 += eb;
        }
        sse += w * e2 / 64.0;
    }
    return sse;
}

static inline int token_of(int q)
{
    if (q == 0)
        return 0;
    if (q > 0 && q <= 7)
        return 2 * q - 1;
    if (q < 0 && q >= -7)
        return -2 * q;
    return GV_DCT_ESCAPE;
}

/* Visit every symbol of block row `by` in stream order: fn(model, symbol)
 * with model -1 for a uniform step. */
#define WALK_ROW(ws, channels, by, EMIT)                                      \
    do {                                                                      \
        int pe_[3] = {0, 0, 0}, dcp_[3] = {0, 0, 0};                          \
        for (int bx_ = 0; bx_ < GV_DCT_BLOCKS; bx_++) {                       \
            const int b_ = (by) * GV_DCT_BLOCKS + bx_;                        \
            for (int c_ = 0; c_ < (channels); c_++) {                         \
                const int cc_ = c_ > 0, n_ = (ws)->eob[c_][b_];               \
                const int16_t *q_ = (ws)->q[c_][b_];                          \
                EMIT(3 * cc_ + pe_[c_], n_);                                  \
                int p_ = dcp_[c_];                                            \
                for (int k_ = 0; k_ < n_; k_++) {                             \
                    const int t_ = token_of(q_[k_]);                          \
                    EMIT(GV_DCT_EOB_MODELS + 12 * cc_ + gv_dct_band_model[k_] + p_, t_); \
                    if (t_ == GV_DCT_ESCAPE) {                                \
                        const int e_ = q_[k_] + 2048;                         \
                        EMIT(-1, e_ >> 6);                                    \
                        EMIT(-1, e_ & 63);                                    \
                    }                                                         \
                    p_ = gv_dct_class(q_[k_]);                                   \
                }                                                             \
                pe_[c_] = n_ == 0 ? 0 : (n_ <= 4 ? 1 : 2);                    \
                dcp_[c_] = n_ ? gv_dct_class(q_[0]) : 0;                         \
            }                                                                 \
        }                                                                     \
    } while (0)

struct models {
    uint32_t count[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS];
    uint32_t freq[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS];
    uint32_t cum[GV_DCT_MODELS][GV_DCT_EOB_SYMBOLS + 1];
    uint32_t total[GV_DCT_MODELS];
    uint64_t uniform;            /* uniform steps */
};

static void count_symbols(struct gv_dct_workspace *ws, int channels,
                          struct models *md)
{
    memset(md, 0, sizeof *md);
#define COUNT(m, s)                                                           \
    do {                                                                      \
        if ((m) < 0)                                                          \
            md->uniform++;                                                    \
        else {                                                                \
            md->count[m][s]++;                                                \
            md->total[m]++;                                                   \
        }                                                                     \
    } while (0)
    for (int by = 0; by < GV_DCT_BLOCKS; by++)
        WALK_ROW(ws, channels, by, COUNT);
#undef COUNT
}

/* Frequencies summing to 256, every used symbol at least 1, and the last
 * symbol at least 1 even when unused: the stored cumulative frequencies
 * are bytes, so none may reach 256. */
static void normalize(const uint32_t *count, int k, uint32_t total,
                      uint32_t *freq)
{
    int big = 0;
    uint32_t sum = 0;
    for (int s = 0; s < k; s++) {
        if (!count[s]) {
            freq[s] = s == k - 1;
            sum += freq[s];
            continue;
        }
        uint32_t f = (uint32_t)(((uint64_t)count[s] * 256 + total / 2) / total);
        freq[s] = f ? f : 1;
        sum += freq[s];
        if (count[s] > count[big] || !count[big])
            big = s;
    }
    /* Take from (or give to) the commonest symbols until the sum is 256;
     * never below 1. */
    while (sum > 256) {
        int best = -1;
        for (int s = 0; s < k; s++)
            if (freq[s] > 1 && (best < 0 || freq[s] > freq[best]))
                best = s;
        freq[best]--;
        sum--;
    }
    freq[big] += 256 - sum;
}

/* Build the stored models from the counts; the model bytes. */
static size_t build_models(struct models *md, uint32_t *mask)
{
    size_t bytes = 0;
    *mask = 0;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        if (!md->total[m])
            continue;
        const int k = gv_dct_model_symbols(m);
        *mask |= 1u << m;
        bytes += (size_t)k;
        normalize(md->count[m], k, md->total[m], md->freq[m]);
        md->cum[m][0] = 0;
        for (int s = 0; s < k; s++)
            md->cum[m][s + 1] = md->cum[m][s] + md->freq[m][s];
    }
    return bytes;
}

static double log2_table[257];

static void init_log2(void)
{
    for (int f = 1; f <= 256; f++)
        log2_table[f] = log2(256.0 / f);
}

/* Estimated bytes of the buffer with these models. */
static double estimate_bytes(const struct models *md, size_t model_bytes)
{
    double bits = 6.0 * (double)md->uniform;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        if (!md->total[m])
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            if (md->count[m][s])
                bits += md->count[m][s] * log2_table[md->freq[m][s]];
    }
    return bits / 8 + (double)model_bytes + HEADER_BYTES + LENGTHS_BYTES +
           4.0 * GV_DCT_BLOCKS;
}

/* Write the buffer of the candidate in ws->q / ws->eob with models md.
 * Returns its length, or 0 past cap. */
static size_t write_buffer(struct gv_dct_workspace *ws, int channels,
                           const int *steps, const struct models *md,
                           uint32_t mask, uint8_t *buf, size_t cap)
{
    size_t at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS; m++)
        if (mask >> m & 1)
            at += (size_t)gv_dct_model_symbols(m);
    const size_t lengths = (at + 1) & ~(size_t)1;
    const size_t streams = lengths + LENGTHS_BYTES;
    if (streams > cap)
        return 0;
    memset(buf, 0, streams);
    buf[0] = GV_TILE_DCT;
    for (int c = 0; c < channels && c < 3; c++)
        gv_put16(buf + 2 + 2 * c, (uint16_t)steps[c]);
    gv_put32(buf + 8, mask);
    at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS; m++) {
        if (!(mask >> m & 1))
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            buf[at++] = (uint8_t)md->cum[m][s];
    }
    at = streams;
    for (int by = 0; by < GV_DCT_BLOCKS; by++) {
        int ns = 0;
#define COLLECT(m, s_)                                                        \
    do {                                                                      \
        ws->syms[ns].model = (int16_t)(m);                                    \
        ws->syms[ns].s = (int16_t)(s_);                                       \
        ns++;                                                                 \
    } while (0)
        WALK_ROW(ws, channels, by, COLLECT);
#undef COLLECT
        uint32_t x = 1u << 16;   /* the initial and final state */
        int n = 0;
        for (int i = ns - 1; i >= 0; i--) {
            const struct sym *y = &ws->syms[i];
            if (y->model < 0)
                x = gv_rans_put(x, 4, 4u * (uint32_t)y->s, 8, ws->words, &n);
            else
                x = gv_rans_put(x, md->freq[y->model][y->s],
                                md->cum[y->model][y->s], 8, ws->words, &n);
        }
        if (!(at = gv_rans_put_stream(buf, lengths, by, at, x, ws->words, n, cap)))
            return 0;
    }
    return gv_rans_finish(buf, at, cap);
}

static void chroma_steps(int s0, int channels, int *steps)
{
    steps[0] = s0;
    steps[1] = steps[2] = 0;
    if (channels == 3) {
        int co = (int)lrint(s0 * 2.449), cg = 2 * s0;
        steps[1] = co > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : co;
        steps[2] = cg > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : cg;
    }
}

size_t gv_dct_encode(struct gv_dct_workspace *ws, const uint8_t *orig,
                     const uint8_t *pred, const uint8_t *parent, int qx,
                     int qy, int channels, uint32_t valid_w, uint32_t valid_h,
                     double lambda, uint8_t *buf, size_t cap, uint8_t *recon,
                     uint64_t *sse)
{
    static _Thread_local struct models md;
    if (!log2_table[1])
        init_log2();
    transform_tile(ws, orig, pred, channels, valid_w, valid_h);
    /* High-rate optimum for channel 0: step^2 = 6 lambda / (w ln 2) in
     * orthonormal units, 8 times that in the plane's. */
    const double w0 = channels == 1 ? 1.0 : channel_weight[0];
    const double s_opt = 8.0 * sqrt(6.0 * lambda / (w0 * LN2));
    /* Half octaves from 2^-0.5 to 2^2.5 times the high-rate optimum (on
     * five photographs the best was never below 2^0, and 2^1.5 was most
     * often the largest candidate then), then the quarter octaves on
     * either side of the best. */
    double best_j = INFINITY;
    int best_s0 = 1, best_i = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (int i = 0; i < STEP_CANDIDATES; i++) {
            if (pass == 0 ? (i & 1) : (i != best_i - 1 && i != best_i + 1))
                continue;
            int s0 = (int)lrint(s_opt * step_factor[i]);
            s0 = s0 < 1 ? 1 : (s0 > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : s0);
            int steps[3];
            chroma_steps(s0, channels, steps);
            double err = quantize(ws, channels, steps);
            count_symbols(ws, channels, &md);
            uint32_t mask;
            size_t mb = build_models(&md, &mask);
            double j = err + lambda * 8.0 * estimate_bytes(&md, mb);
            if (j < best_j) {
                best_j = j;
                best_s0 = s0;
                best_i = i;
                memcpy(ws->bq, ws->q, sizeof ws->q);
                memcpy(ws->beob, ws->eob, sizeof ws->eob);
            }
        }
    }
    memcpy(ws->q, ws->bq, sizeof ws->q);
    memcpy(ws->eob, ws->beob, sizeof ws->eob);
    count_symbols(ws, channels, &md);
    uint32_t mask;
    build_models(&md, &mask);
    int best_steps[3] = {0, 0, 0};
    chroma_steps(best_s0, channels, best_steps);
    size_t len = write_buffer(ws, channels, best_steps, &md, mask, buf, cap);
    if (!len)
        return 0;
    struct gv_error err;
    if (gv_dct_decode(buf, len, channels, parent, qx, qy, recon, &err) < 0)
        return 0;   /* cannot happen: the buffer was just written */
    uint64_t e = 0;
    for (uint32_t y = 0; y < valid_h; y++) {
        const size_t row = (size_t)y * GV_TILE * channels;
        for (uint32_t i = 0; i < valid_w * (uint32_t)channels; i++) {
            int d = (int)orig[row + i] - recon[row + i];
            e += (uint64_t)(d * d);
        }
    }
    *sse = e;
    return len;
}
