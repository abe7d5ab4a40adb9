/*
 * tile_dct_encode.c - the layout D2 encoder (docs/FORMAT.md sections 4.3
 * and 4.4): layout D, each block's last value coded in a model of its own.
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
 * of channel 0 is searched over quarter octaves around the high-rate
 * optimum for lambda, by descent from the commonest best while the cost
 * falls (J is unimodal there but for a plateau where every block is
 * zero), each candidate costed by its exact model entropy
 * (the 8-bit models as the buffer will store them, their bytes included)
 * and by its squared error estimated in the transform domain; chroma
 * steps follow at the ratios that equalize the slopes of the YCoCg-R
 * inverse (a unit of error in Y reaches three channels, one in Co half
 * of two, one in Cg a quarter of three: weights 3, 1/2, 3/4).  The best
 * candidate's blocks are then cut short where their last values cost
 * more bits than the error they remove (truncate_tails), and it is
 * written and rebuilt as gv_dct_decode would decode it, whose error is
 * exact.
 *
 * Speed (bench/README.md, 2026-11-26 later): a candidate is quantized and
 * its symbols counted in one pass, without copying; the transform and the
 * quantizer run in SSE2 (the transform also in AVX2, chosen at run time)
 * with the roundings of the plain C, in the same order, so the stores do
 * not depend on the path.  The AVX2 transform also takes the residual of
 * eight pixels at once and writes its second pass straight in zigzag
 * order (2.1 times faster than the plain C's structure in 8 lanes).
 * The transform and quantization are written once in
 * tile_dct_encode_int.h and compiled here for the baseline and in
 * x86/tile_dct_encode_avx2.c for AVX2 with FMA, chosen by
 * dct_encode_dsp_init from gv_cpu_flags() (base/cpu.h).
 * The encoder of 2026-11-26 (bench/README.md, "2026-11-26, encoder CPU"):
 * the tokens, contexts and escapes of a block are computed eight at a
 * time as slots (block_slots), which both the counting and the writing
 * use; the rANS rows are coded four at a time in lockstep, without a
 * branch, by a per-symbol table and a 64-bit multiply for x / f.  All of
 * it integer, so every path gives the same bytes.
 */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "base/cpu.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_dct_encode_int.h"
#include "codec/tile_layout.h"
#include "codec/sse.h"
#include "codec/tile_rans.h"
#include "codec/x86/tile_dct_encode_avx2.h"

#define HEADER_BYTES 12
#define LENGTHS_BYTES (2 * GV_DCT_BLOCKS)
#define STEP_CANDIDATES 13      /* quarter octaves from 2^-0.5 to 2^2.5 */
#define STEP_START 3            /* the commonest best: 2^0.25 */
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


struct gv_dct_workspace *gv_dct_workspace_new(void)
{
    return malloc(sizeof(struct gv_dct_workspace));
}

void gv_dct_workspace_free(struct gv_dct_workspace *ws)
{
    free(ws);
}

/* The tables of tile_dct_encode_int.h, filled once by init_tables. */
float gv_dct_enc_kt[8][8];
_Alignas(32) int32_t gv_dct_enc_zz_col[8][8];
_Alignas(32) float gv_dct_enc_zz_k[8][8][8];
uint8_t gv_dct_enc_tc[4096];
_Alignas(16) uint16_t gv_dct_enc_tok_base[64];

static void init_kt(void)
{
    for (int i = 0; i < 8; i++)
        for (int u = 0; u < 8; u++)
            gv_dct_enc_kt[i][u] = (float)gv_dct_matrix[u][i];
    for (int g = 0; g < 8; g++)
        for (int p = 0; p < 8; p++) {
            const int zz = gv_dct_zigzag[8 * g + p];
            gv_dct_enc_zz_col[g][p] = zz % 8;
            for (int j = 0; j < 8; j++)
                gv_dct_enc_zz_k[g][j][p] = (float)gv_dct_matrix[zz / 8][j];
        }
}

static void init_tc(void)
{
    for (int q = -2048; q < 2048; q++) {
        int t = q == 0 ? 0 : (q > 0 && q <= 7) ? 2 * q - 1 :
                (q < 0 && q >= -7) ? -2 * q : GV_DCT_ESCAPE;
        gv_dct_enc_tc[q + 2048] = (uint8_t)(t | gv_dct_class(q) << 4);
    }
}

static void init_tok_base(void)
{
    for (int k = 0; k < 64; k++)
        gv_dct_enc_tok_base[k] =
            (uint16_t)(gv_dct_band_model[k] * GV_DCT_TOKEN_SYMBOLS);
}

/* The transform of a tile: residual, forward transform, the largest
 * coefficient and the energy of every block.  The same C compiled twice,
 * for the baseline (here) and for AVX2 (x86/tile_dct_encode_avx2.c: 8
 * lanes instead of 4; no FMA but where exact, so every rounding is the
 * same and so are the stores), chosen at run time. */
static void transform_tile_base(struct gv_dct_workspace *ws,
                                const uint8_t *orig, const uint8_t *pred,
                                int channels, uint32_t vw, uint32_t vh)
{
    transform_body(ws, orig, pred, channels, vw, vh, forward, residual_block);
}

typedef void transform_fn(struct gv_dct_workspace *, const uint8_t *,
                          const uint8_t *, int, uint32_t, uint32_t);
static transform_fn *transform_tile = transform_tile_base;

/* quantize_count_body compiled for the baseline (here) and for AVX2
 * (x86/tile_dct_encode_avx2.c), chosen at run time with the transform
 * (the same results). */
static double quantize_count_base(const struct gv_dct_workspace *ws,
                                  struct candidate *cd, int channels,
                                  const int *steps)
{
    return quantize_count_body(ws, cd, channels, steps, quantize_block);
}

typedef double quantize_count_fn(const struct gv_dct_workspace *,
                                 struct candidate *, int, const int *);
static quantize_count_fn *quantize_count = quantize_count_base;

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
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        const int k = gv_dct_model_symbols(m);
        uint32_t total = 0;
        for (int s = 0; s < k; s++)
            total += md->count[m][s];
        md->total[m] = total;
        if (!total)
            continue;
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

/* ceil(2^40 / f): x / f = x * freq_m40[f] >> 40 exactly for every
 * state x < f 2^24 (the bound after renormalization at 8 bits).  With
 * freq_m40[f] = (2^40 + r) / f, 0 <= r < f, the product exceeds x / f 2^40
 * by x r / f < (f - 1) 2^24, and f (f - 1) < 2^16 for f <= 256, so the
 * excess stays under 2^40 / f: too little to carry past the next
 * multiple of 1 / f, the least gap above a quotient's fraction.  The
 * product stays under 2^64 since f r < 2^16.  One 64-bit multiply
 * instead of gv_rans_rcp's 128-bit one, and no case for f = 1. */
static uint64_t freq_m40[257];

static void init_log2(void)
{
    for (int f = 1; f <= 256; f++) {
        log2_table[f] = log2(256.0 / f);
        freq_m40[f] = ((1ull << 40) + (uint64_t)f - 1) / (uint64_t)f;
    }
}

/* Estimated bytes of the buffer with these models. */
static double estimate_bytes(const struct models *md, size_t model_bytes)
{
    double bits = 6.0 * (double)md->uniform;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        if (!md->total[m])
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            if (md->count[m][s])
                bits += md->count[m][s] * log2_table[md->freq[m][s]];
    }
    return bits / 8 + (double)model_bytes + HEADER_BYTES + LENGTHS_BYTES +
           4.0 * GV_DCT_BLOCKS;
}

/* The first enc[] entry of model m. */
static inline int enc_at(int m)
{
    return m < GV_DCT_EOB_MODELS ? m * GV_DCT_EOB_SYMBOLS :
           GV_DCT_EOB_MODELS * GV_DCT_EOB_SYMBOLS +
           (m - GV_DCT_EOB_MODELS) * GV_DCT_TOKEN_SYMBOLS;
}

static void set_enc(struct enc_sym *e, uint32_t f, uint32_t c)
{
    e->m = freq_m40[f];
    e->thr = (uint32_t)(((uint64_t)f << 24) - 1);
    e->g = (uint16_t)(256 - f);
    e->c = (uint16_t)c;
}

/* gv_rans_put_rcp at 8 bits for symbol e: the same state and words, with
 * x - (x / f) f + (x / f) 2^8 written x + (x / f) g, and no branch: the
 * renormalized state and the other are both at hand and one is kept
 * (whether a word goes out follows the data and would be mispredicted
 * often; words[] has room for a store that the count then drops). */
static inline uint32_t put_sym(uint32_t x, const struct enc_sym *e,
                               uint16_t **w)
{
    const int out = x > e->thr;
    **w = (uint16_t)x;
    *w += out;
    const uint32_t xr = out ? x >> 16 : x;
    const uint32_t q = (uint32_t)((uint64_t)xr * e->m >> 40);
    return xr + q * e->g + e->c;
}

/* The symbols of block row `by` in stream order into sy, as enc[]
 * entries (FORMAT.md 4.3: per block, per channel, the eob, then each
 * token, an escape followed by its two uniform steps); returns their
 * number.  sy has room for 64 past the last. */
static int collect_row(const struct candidate *cd, int channels, int by,
                       uint16_t *sy)
{
    int k = 0, pe[3] = {0, 0, 0}, dcp[3] = {0, 0, 0};
    for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
        const int b = by * GV_DCT_BLOCKS + bx;
        for (int c = 0; c < channels; c++) {
            const int cc = c > 0, n = cd->eob[c][b];
            const int16_t *q = cd->q[c][b];
            sy[k++] = (uint16_t)(enc_at(3 * cc + pe[c]) + n);
            pe[c] = gv_dct_eob_class(n);
            if (!n) {
                dcp[c] = 0;
                continue;
            }
            const int tokens = enc_at(GV_DCT_EOB_MODELS) + TOKEN_SLOTS * cc;
            /* The last value's token, in its own model (layout D2). */
            const uint16_t last = (uint16_t)(enc_at(GV_DCT_LAST_MODEL + cc) +
                                             (gv_dct_enc_tc[q[n - 1] + 2048] & 15));
            if (!block_slots(q, n, dcp[c], tokens, sy + k)) {
                sy[k + n - 1] = last;
                k += n;
            } else {
                /* Escapes: their uniform steps go in after them. */
                _Alignas(16) uint16_t slot[64];
                block_slots(q, n, dcp[c], tokens, slot);
                slot[n - 1] = last;
                for (int j = 0; j < n; j++) {
                    sy[k++] = slot[j];
                    if (q[j] > 7 || q[j] < -7) {
                        const int e = q[j] + 2048;
                        sy[k++] = (uint16_t)(ENC_UNIFORM + (e >> 6));
                        sy[k++] = (uint16_t)(ENC_UNIFORM + (e & 63));
                    }
                }
            }
            dcp[c] = gv_dct_class(q[0]);
        }
    }
    return k;
}

/* Code the collected symbols of `rows` rows (at most LANES; left[r] of
 * row r, coded last to first) into their states x[] and words.  The
 * rows' states are independent chains of multiplies: coded in lockstep,
 * LANES at a time while every row has symbols left, then two, then
 * one, so that each chain's latency hides behind the others'. */
static void code_rows(struct gv_dct_workspace *ws, int rows, int *left,
                      uint32_t *x, int *n)
{
    const struct enc_sym *enc = ws->enc;
    uint16_t *w[LANES];
    for (int r = 0; r < rows; r++)
        w[r] = ws->words[r];
    _Static_assert(LANES == 4, "code_rows names four lanes");
    if (rows == LANES) {
        int common = left[0];
        for (int r = 1; r < LANES; r++)
            common = left[r] < common ? left[r] : common;
        /* Each row's last symbol first; the lanes in locals, so that
         * their states and pointers stay in registers. */
        const uint16_t *s0 = ws->syms[0] + left[0] - 1;
        const uint16_t *s1 = ws->syms[1] + left[1] - 1;
        const uint16_t *s2 = ws->syms[2] + left[2] - 1;
        const uint16_t *s3 = ws->syms[3] + left[3] - 1;
        uint32_t x0 = x[0], x1 = x[1], x2 = x[2], x3 = x[3];
        uint16_t *w0 = w[0], *w1 = w[1], *w2 = w[2], *w3 = w[3];
        for (int j = 0; j < common; j++) {
            x0 = put_sym(x0, &enc[s0[-j]], &w0);
            x1 = put_sym(x1, &enc[s1[-j]], &w1);
            x2 = put_sym(x2, &enc[s2[-j]], &w2);
            x3 = put_sym(x3, &enc[s3[-j]], &w3);
        }
        x[0] = x0, x[1] = x1, x[2] = x2, x[3] = x3;
        w[0] = w0, w[1] = w1, w[2] = w2, w[3] = w3;
        for (int r = 0; r < LANES; r++)
            left[r] -= common;
    }
    for (int a = 0; a < rows; a++) {
        if (!left[a])
            continue;
        int b = a + 1;
        while (b < rows && !left[b])
            b++;
        if (b < rows)
            for (; left[a] && left[b];) {
                x[a] = put_sym(x[a], &enc[ws->syms[a][--left[a]]], &w[a]);
                x[b] = put_sym(x[b], &enc[ws->syms[b][--left[b]]], &w[b]);
            }
        while (left[a])
            x[a] = put_sym(x[a], &enc[ws->syms[a][--left[a]]], &w[a]);
        /* Row b, if it still has symbols, pairs with the next. */
    }
    for (int r = 0; r < rows; r++)
        n[r] = (int)(w[r] - ws->words[r]);
}

/* The bytes of the stored models of a mask. */
static size_t mask_model_bytes(uint32_t mask)
{
    size_t bytes = 0;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++)
        if (mask >> m & 1)
            bytes += (size_t)gv_dct_model_symbols(m);
    return bytes;
}

/* Write the buffer of candidate cd (its models built, mask theirs).
 * Returns its length, or 0 past cap. */
static size_t write_buffer(struct gv_dct_workspace *ws,
                           const struct candidate *cd, int channels,
                           const int *steps, uint32_t mask, uint8_t *buf,
                           size_t cap)
{
    const struct models *md = &cd->md;
    size_t at = HEADER_BYTES + mask_model_bytes(mask);
    const size_t lengths = (at + 1) & ~(size_t)1;
    const size_t streams = lengths + LENGTHS_BYTES;
    if (streams > cap)
        return 0;
    memset(buf, 0, streams);
    buf[0] = GV_TILE_DCT2;
    for (int c = 0; c < channels && c < 3; c++)
        gv_put16(buf + 2 + 2 * c, (uint16_t)steps[c]);
    gv_put32(buf + 8, mask);
    at = HEADER_BYTES;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        if (!(mask >> m & 1))
            continue;
        for (int s = 0; s < gv_dct_model_symbols(m); s++)
            buf[at++] = (uint8_t)md->cum[m][s];
    }
    for (int m = 0; m < GV_DCT_MODELS_D2; m++)
        if (mask >> m & 1)
            for (int v = 0; v < gv_dct_model_symbols(m); v++)
                set_enc(&ws->enc[enc_at(m) + v], md->freq[m][v],
                        md->cum[m][v]);
    for (int v = 0; v < 64; v++)
        set_enc(&ws->enc[ENC_UNIFORM + v], 4, 4u * (uint32_t)v);
    at = streams;
    for (int by = 0; by < GV_DCT_BLOCKS; by += LANES) {
        const int rows = GV_DCT_BLOCKS - by < LANES ? GV_DCT_BLOCKS - by
                                                    : LANES;
        int left[LANES] = {0}, n[LANES] = {0};
        uint32_t x[LANES];
        for (int r = 0; r < rows; r++) {
            left[r] = collect_row(cd, channels, by + r, ws->syms[r]);
            x[r] = 1u << 16;     /* the initial and final state */
        }
        code_rows(ws, rows, left, x, n);
        for (int r = 0; r < rows; r++)
            if (!(at = gv_rans_put_stream(buf, lengths, by + r, at, x[r],
                                          ws->words[r], n[r], cap)))
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

static pthread_once_t tables_once = PTHREAD_ONCE_INIT;
static int rdo_tails = 1;   /* GIGAVIEW_RDO_TAILS=0: off (benchmarks) */

/* The kernels: AVX2 with FMA where gv_cpu_flags() (base/cpu.h) has both,
 * else the baseline (SSE2 where the compiler targets it); the same floats
 * either way. */
static struct gv_cpu_once kernels_once = GV_CPU_ONCE_INIT;

static void dct_encode_dsp_init(unsigned flags)
{
    transform_tile = transform_tile_base;
    quantize_count = quantize_count_base;
#if GV_HAVE_X86_SIMD
    if ((flags & (GV_CPU_AVX2 | GV_CPU_FMA)) == (GV_CPU_AVX2 | GV_CPU_FMA)) {
        transform_tile = gv_dct_transform_tile_avx2;
        quantize_count = gv_dct_quantize_count_avx2;
    }
#else
    (void)flags;
#endif
}

static void init_tables(void)
{
    const char *rt = getenv("GIGAVIEW_RDO_TAILS");
    rdo_tails = !(rt && !strcmp(rt, "0"));
    init_kt();
    init_tc();
    init_tok_base();
    init_log2();
}

/* The steps of candidate i: channel 0's s_opt * step_factor[i], in
 * 1 .. GV_DCT_MAX_STEP, and the chroma steps that follow from it. */
static void candidate_steps(double s_opt, int i, int channels, int *steps)
{
    int s0 = (int)lrint(s_opt * step_factor[i]);
    s0 = s0 < 1 ? 1 : (s0 > GV_DCT_MAX_STEP ? GV_DCT_MAX_STEP : s0);
    chroma_steps(s0, channels, steps);
}

/* The J of candidate i; its quantized values and models in cd. */
static double try_step(const struct gv_dct_workspace *ws,
                       struct candidate *cd, int channels, double s_opt,
                       double lambda, int i, uint32_t *mask)
{
    int steps[3];
    candidate_steps(s_opt, i, channels, steps);
    double err = quantize_count(ws, cd, channels, steps);
    size_t mb = build_models(&cd->md, mask);
    return err + lambda * 8.0 * estimate_bytes(&cd->md, mb);
}


/* Count the symbols of cd's q and eob into cd->md, as quantize_count
 * does, from the values instead of the coefficients.  Values past a
 * block's eob may be stale (truncate_tails has not cleared them yet):
 * block_slots reads up to the next multiple of 8, but they are of
 * magnitude 1 at most, so they add no escape, and their slots are not
 * counted. */
static void count_symbols(struct candidate *cd, int channels)
{
    struct models *md = &cd->md;
    memset(md->count, 0, sizeof md->count);
    uint32_t tokh[TOKEN_COUNTS];
    memset(tokh, 0, sizeof tokh);
    uint64_t uniform = 0;
    for (int c = 0; c < channels; c++) {
        const int cc = c > 0;
        uint32_t *eobc = md->count[3 * cc];
        uint32_t *tokc = tokh + TOKEN_SLOTS * cc, *lastc = tokh + LAST_SLOTS(cc);
        for (int by = 0; by < GV_DCT_BLOCKS; by++) {
            int pe = 0, dcp = 0;
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx, n = cd->eob[c][b];
                eobc[pe * GV_DCT_EOB_SYMBOLS + n]++;
                pe = gv_dct_eob_class(n);
                if (!n) {
                    dcp = 0;
                    continue;
                }
                const int16_t *q = cd->q[c][b];
                uniform += count_block(q, n, dcp, tokc, lastc);
                dcp = gv_dct_class(q[0]);
            }
        }
    }
    tokens_to_models(md, tokh, uniform);
}

/* Bits of symbol s in model m as the candidate's models code it; a symbol
 * the models do not have yet is priced as one of frequency 1/2 in 256. */
static inline double symbol_bits(const struct models *md, int m, int s)
{
    const uint32_t f = md->total[m] ? md->freq[m][s] : 0;
    return f ? log2_table[f] : 9.0;
}

/*
 * Rate-distortion truncation of each block's coded coefficients (the
 * encoder side of RDOQ, as in x264's and HM's "trellis"-lite): a block's
 * last nonzero values often cost more bits (the zero tokens before them,
 * the value, the longer count) than the error they remove.  For every
 * block, channel by channel in stream order, the count n' is chosen
 * among n and each shorter count that ends after a nonzero value (or is
 * 0), back to the last value of magnitude 2 or more, minimizing the added
 * squared error (transform domain, weighted as quantize_count weighs it)
 * plus lambda times the bits, priced by the candidate's models with the
 * contexts of the blocks already decided.  The symbols are then counted
 * again and the models rebuilt; if the estimated J did not fall, the
 * counts stay as they were.  Fewer coded coefficients also mean fewer
 * rANS steps for every decoder.  Plain C on every CPU (the same doubles
 * in the same order), so the stores do not depend on the path.  Returns
 * the (new) model mask in *mask.
 */
static void truncate_tails(const struct gv_dct_workspace *ws,
                           struct candidate *cd, int channels,
                           const int *steps, double lambda, uint32_t *mask)
{
    struct models *md = &cd->md;
    /* Each block cut: c * NB + b, and its count before the cut. */
    static _Thread_local struct {
        uint16_t block;
        uint8_t was;
    } cut[3 * NB];
    static _Thread_local double bits[GV_DCT_MODELS_D2][GV_DCT_EOB_SYMBOLS];
    int ncut = 0;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++)
        for (int v = 0; v < gv_dct_model_symbols(m); v++)
            bits[m][v] = symbol_bits(md, m, v);
    const double j_old = lambda * 8.0 * estimate_bytes(md, mask_model_bytes(*mask));
    double added = 0, added_at = 0;
    for (int c = 0; c < channels; c++) {
        const double s = (double)steps[c];
        const double w = (channels == 1 ? 1.0 : channel_weight[c]) / 64.0;
        const int cc = c > 0;
        const double *eob_bits = bits[3 * cc];
        const double(*tok_bits)[GV_DCT_EOB_SYMBOLS] = bits + GV_DCT_EOB_MODELS + 12 * cc;
        const double *last_bits = bits[GV_DCT_LAST_MODEL + cc];
        for (int by = 0; by < GV_DCT_BLOCKS; by++) {
            int pe = 0, dcp = 0;
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
                const int b = by * GV_DCT_BLOCKS + bx, n = cd->eob[c][b];
                if (!n) {
                    pe = dcp = 0;
                    continue;
                }
                const int16_t *q = cd->q[c][b];
                const float *x = ws->x[c][b];
                /* From the end: the bits of the tail's tokens and the
                 * error its values remove, J(n') - J(n) at each n' that
                 * ends on a nonzero value (or is 0).  The scan stops at
                 * the first value of magnitude 2 or more, whose removal
                 * does not pay.  y is value k's token and class. */
                const double *eob_pe = eob_bits + pe * GV_DCT_EOB_SYMBOLS;
                const double eob_n = eob_pe[n];
                double tail_bits = 0, tail_err = 0, best = 0;
                int best_n = n, y = gv_dct_enc_tc[q[n - 1] + 2048];
                for (int k = n - 1; k >= 0; k--) {
                    const int t = y & 15;
                    const int yp = k ? gv_dct_enc_tc[q[k - 1] + 2048] : dcp << 4;
                    tail_bits += k == n - 1 ? last_bits[t]
                               : tok_bits[gv_dct_band_model[k] + (yp >> 4)][t];
                    if (t == GV_DCT_ESCAPE)
                        tail_bits += 12.0;
                    y = yp;
                    if (q[k]) {
                        if (q[k] > 1 || q[k] < -1)
                            break;
                        const double xa = fabs((double)x[k]), r = xa - s;
                        tail_err += (xa * xa - r * r) * w;
                    }
                    if (k > 0 && !q[k - 1])
                        continue;
                    /* Cut to k values, value k - 1 becomes the last: its
                     * token moves from its band's model to the last
                     * value's. */
                    double relast = 0;
                    if (k > 0) {
                        const int tl = yp & 15;
                        const int ypp = k > 1 ? gv_dct_enc_tc[q[k - 2] + 2048] : dcp << 4;
                        relast = last_bits[tl] -
                                 tok_bits[gv_dct_band_model[k - 1] + (ypp >> 4)][tl];
                    }
                    const double j = tail_err +
                        lambda * (eob_pe[k] - eob_n - tail_bits + relast);
                    if (j < best) {
                        best = j;
                        best_n = k;
                        added_at = tail_err;
                    }
                }
                if (best_n < n) {
                    added += added_at;
                    cd->eob[c][b] = (uint8_t)best_n;
                    cut[ncut].block = (uint16_t)(c * NB + b);
                    cut[ncut++].was = (uint8_t)n;
                }
                const int m = cd->eob[c][b];
                pe = gv_dct_eob_class(m);
                dcp = m ? gv_dct_class(q[0]) : 0;
            }
        }
    }
    if (!ncut)
        return;
    struct models before = *md;
    uint32_t new_mask;
    count_symbols(cd, channels);
    const size_t mb = build_models(md, &new_mask);
    if (added + lambda * 8.0 * estimate_bytes(md, mb) < j_old) {
        /* Clear the values cut off, for the writer's block_slots, which
         * reads past the eob to a multiple of 8. */
        for (int i = 0; i < ncut; i++) {
            const int c = cut[i].block / NB, b = cut[i].block % NB;
            for (int k = cd->eob[c][b]; k < cut[i].was; k++)
                cd->q[c][b][k] = 0;
        }
        *mask = new_mask;
        return;
    }
    for (int i = 0; i < ncut; i++)
        cd->eob[cut[i].block / NB][cut[i].block % NB] = cut[i].was;
    *md = before;
}

size_t gv_dct_encode(struct gv_dct_workspace *ws, const uint8_t *orig,
                     const uint8_t *pred, int channels, uint32_t valid_w,
                     uint32_t valid_h, double lambda, uint8_t *buf,
                     size_t cap, uint8_t *recon, uint64_t *sse)
{
    pthread_once(&tables_once, init_tables);
    gv_cpu_once(&kernels_once, dct_encode_dsp_init);
    transform_tile(ws, orig, pred, channels, valid_w, valid_h);
    /* High-rate optimum for channel 0: step^2 = 6 lambda / (w ln 2) in
     * orthonormal units, 8 times that in the plane's. */
    const double w0 = channels == 1 ? 1.0 : channel_weight[0];
    const double s_opt = 8.0 * sqrt(6.0 * lambda / (w0 * LN2));
    /* Descent over quarter octaves from 2^-0.5 to 2^2.5 times the
     * high-rate optimum: from the commonest best (2^0.25), one step up,
     * then on in the direction J falls until it rises.  J is unimodal
     * apart from a plateau at the largest steps, where every block is
     * zero and the prediction alone is cheaper anyway.  3.6 candidates
     * on average instead of 9 for the half-then-quarter octave search
     * (bench/README.md, 2026-11-26 later). */
    int best = 0, cur = 1, best_i = STEP_START;
    uint32_t mask, cmask;
    double best_j = try_step(ws, &ws->cand[best], channels, s_opt, lambda,
                             STEP_START, &mask);
    for (int dir = 1, i = STEP_START + 1; i >= 0 && i < STEP_CANDIDATES;
         i += dir) {
        double j = try_step(ws, &ws->cand[cur], channels, s_opt, lambda, i,
                            &cmask);
        if (j < best_j) {
            best_j = j;
            best_i = i;
            mask = cmask;
            best = cur;
            cur = 1 - cur;
        } else if (dir > 0 && best_i == STEP_START) {
            dir = -1;       /* up did not help: try down */
            i = STEP_START;
        } else {
            break;
        }
    }
    int best_steps[3] = {0, 0, 0};
    candidate_steps(s_opt, best_i, channels, best_steps);
    if (rdo_tails)
        truncate_tails(ws, &ws->cand[best], channels, best_steps, lambda, &mask);
    size_t len = write_buffer(ws, &ws->cand[best], channels, best_steps, mask,
                              buf, cap);
    if (!len)
        return 0;
    /* What gv_dct_decode would give, from the values just coded. */
    gv_dct_rebuild((const int16_t (*)[NB][64])ws->cand[best].q,
                   (const uint8_t (*)[NB])ws->cand[best].eob, best_steps,
                   channels, pred, recon);
    *sse = gv_sse_u8(orig, recon, valid_w * (uint32_t)channels, valid_h,
                     (size_t)GV_TILE * channels);
    return len;
}
