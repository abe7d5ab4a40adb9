/*
 * tile_encode.c - hierarchical VQ encoding of one tile (section 7.4).
 *
 * The residual (original minus the prediction from the decoded parent) is
 * cut into 257x257 blocks of 2x2 pixels.  Rates are tried from r = 0 (the
 * prediction alone) upwards, each codebook grown from the previous one by a
 * PCA split followed by LBG (vq.c) on a random sample of the tile's blocks.
 * Blocks are coded with entropy-constrained VQ: indices and codebooks are
 * chosen by squared error + lambda * code length.  When the sample says a
 * rate may meet the target, every block is assigned and the true squared
 * error of the clamped reconstruction decides; the first rate that meets
 * the target (or the cap) wins.  So every tile the encoder writes meets
 * the target unless it is at the cap.  In rate-distortion mode
 * (params->lambda > 0) the rate with the least SSE + lambda * bits wins:
 * J is estimated for each rate on the sample, and only the rates around
 * the estimate's minimum are coded over the whole tile (encode_rd_ecvq).
 * Either way the buffer is written in the
 * smallest of the fixed, the entropy-coded and the context-coded layouts
 * (tile_rans.c), each sized exactly.
 *
 * Sampling uses a per-tile seed, and the search is exact, so the output
 * does not depend on thread count or CPU.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "codec/sse.h"
#include "codec/tile_layout.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_rans.h"
#include "codec/vq.h"

#define SAMPLE_MIN 4096   /* blocks sampled for training at small rates */
#define SAMPLE_PER_CELL 12 /* ... growing to this many per codevector */
#define TARGET_LBG_ITERS 12 /* LBG assignments per rate, target mode */

/* Rate-distortion mode (measured on four photographs, docs/FORMAT.md
 * section 8): LBG only seeds ECVQ there, so it stops early; more rounds
 * of either kind buy under 0.1 dB for 5 to 8 % more time each. */
#define RD_LBG_ITERS 3    /* LBG assignments per rate */
#define ECVQ_ROUNDS 3     /* entropy-constrained rounds on the sample */
#define POLISH_ROUNDS 3   /* whole-tile rounds at the chosen rate */
#define CONVEX_FROM 5     /* from this rate on, one rise of J ends the search */

struct gv_tile_workspace {
    uint8_t pred[GV_TILE * GV_TILE * 3];
    int16_t vecs[GV_NBLOCKS * VQ_STRIDE];
    uint8_t pblk[GV_NBLOCKS * VQ_STRIDE]; /* the prediction, laid out as vecs */
    int16_t wide[VQ_MAXK * VQ_STRIDE];    /* a codebook widened for block_sse */
    uint32_t order[GV_NBLOCKS];      /* shuffled valid blocks */
    int16_t sample[GV_NBLOCKS * VQ_STRIDE];
    uint16_t idx[GV_NBLOCKS];
    uint32_t dist[GV_NBLOCKS];
    uint16_t best_idx[GV_NBLOCKS];   /* rate-distortion mode: best so far */
    int8_t best_book[VQ_MAXK * VQ_MAXDIM];
    uint8_t scratch[GV_TILEBUF_MAX]; /* sizing candidate rates (--rd) */
    uint8_t alt[GV_TILEBUF_MAX];     /* pack_best: the second layout */
    uint8_t best_buf[GV_TILEBUF_MAX]; /* the best candidate, packed */
    struct vq_trainer trainer;
    struct vq_trainer ecvq;          /* --rd: the entropy-constrained book */
    /* Rate-distortion mode: each trained rate's sample ECVQ book and
     * biases (rate r at entry (2^r - 2)), and its estimated J. */
    int8_t rate_book[(2 * VQ_MAXK - 2) * VQ_MAXDIM];
    int32_t rate_bias[2 * VQ_MAXK - 2];
    double jest[GV_MAX_RATE + 1];
    struct gv_dct_workspace *dct;    /* layout D's encoder */
    uint8_t dct_recon[GV_TILE * GV_TILE * 3];
};

struct gv_tile_workspace *gv_tile_workspace_new(void)
{
    struct gv_tile_workspace *ws = calloc(1, sizeof(struct gv_tile_workspace));
    if (ws && !(ws->dct = gv_dct_workspace_new())) {
        free(ws);
        return NULL;
    }
    return ws;
}

void gv_tile_workspace_free(struct gv_tile_workspace *ws)
{
    if (ws)
        gv_dct_workspace_free(ws->dct);
    free(ws);
}

double gv_psnr_to_mse(double psnr_db)
{
    return 65025.0 / pow(10.0, psnr_db / 10.0);   /* 65025 = 255^2 */
}

double gv_rd_lambda(double target_mse)
{
    /* High-rate theory: D(R) ~ 2^(-2R), so dD/dR = -2 ln 2 D; at the
     * target distortion one bit is worth 2 ln 2 D* of squared error. */
    return 2.0 * log(2.0) * target_mse;
}

static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Residual vectors of all blocks; pixels past the tile edge (x or y = 513)
 * repeat pixel 512 so that they pull codevectors toward real content. */
static void make_vectors(struct gv_tile_workspace *ws, const uint8_t *orig,
                         int channels)
{
    const size_t row = (size_t)GV_TILE * channels;
    for (int by = 0; by < GV_BLOCKS; by++)
        for (int bx = 0; bx < GV_BLOCKS; bx++) {
            int16_t *v = ws->vecs + ((size_t)by * GV_BLOCKS + bx) * VQ_STRIDE;
            uint8_t *p = ws->pblk + ((size_t)by * GV_BLOCKS + bx) * VQ_STRIDE;
            memset(v, 0, VQ_STRIDE * sizeof *v);
            memset(p, 0, VQ_STRIDE);
            for (int j = 0; j < 4; j++) {
                int x = 2 * bx + (j & 1), y = 2 * by + (j >> 1);
                if (x > GV_TILE - 1) x = GV_TILE - 1;
                if (y > GV_TILE - 1) y = GV_TILE - 1;
                size_t o = (size_t)y * row + (size_t)x * channels;
                for (int c = 0; c < channels; c++) {
                    v[j * channels + c] = (int16_t)(orig[o + c] - ws->pred[o + c]);
                    p[j * channels + c] = ws->pred[o + c];
                }
            }
        }
}

static inline uint8_t clamp_u8(int v)
{
    return (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
}

/* Reconstruct into recon from pred + book[idx] and return the squared error
 * against orig over the valid region. */
static uint64_t reconstruct(const struct gv_tile_workspace *ws,
                            const uint8_t *orig, const int8_t *book, int rate,
                            int channels, uint32_t vw, uint32_t vh,
                            uint8_t *recon)
{
    const size_t row = (size_t)GV_TILE * channels;
    const int dim = 4 * channels;
    memcpy(recon, ws->pred, row * GV_TILE);
    if (rate > 0) {
        for (int y = 0; y < GV_TILE; y++) {
            const uint16_t *ir = ws->idx + (size_t)(y >> 1) * GV_BLOCKS;
            uint8_t *out = recon + (size_t)y * row;
            const int jy = (y & 1) * 2;
            for (int x = 0; x < GV_TILE; x++) {
                const int8_t *cv = book + (size_t)ir[x >> 1] * dim +
                                   (jy + (x & 1)) * channels;
                for (int c = 0; c < channels; c++)
                    out[x * channels + c] = clamp_u8(out[x * channels + c] + cv[c]);
            }
        }
    }
    return gv_sse_u8(orig, recon, vw * (uint32_t)channels, vh, row);
}

/* Squared error of one block coded with the widened codevector w: the
 * original (x + p) against the clamped reconstruction, lane by lane;
 * unused lanes are 0 in x, p and w.  Integer sums, so the SSE2 form (in
 * every x86-64) and the portable one agree exactly. */
#if defined(__SSE2__)
static inline uint32_t block_sse(const int16_t *x, const uint8_t *p,
                                 const int16_t *w)
{
    const __m128i zero = _mm_setzero_si128(), top = _mm_set1_epi16(255);
    const __m128i pb = _mm_loadu_si128((const __m128i *)p);
    __m128i acc = zero;
    for (int h = 0; h < 2; h++) {
        __m128i pw = h ? _mm_unpackhi_epi8(pb, zero) : _mm_unpacklo_epi8(pb, zero);
        __m128i xw = _mm_loadu_si128((const __m128i *)(x + 8 * h));
        __m128i ww = _mm_loadu_si128((const __m128i *)(w + 8 * h));
        __m128i r = _mm_min_epi16(_mm_max_epi16(_mm_add_epi16(pw, ww), zero), top);
        __m128i e = _mm_sub_epi16(_mm_add_epi16(xw, pw), r);
        acc = _mm_add_epi32(acc, _mm_madd_epi16(e, e));
    }
    acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, 0x4e));
    acc = _mm_add_epi32(acc, _mm_shuffle_epi32(acc, 0xb1));
    return (uint32_t)_mm_cvtsi128_si32(acc);
}
#else
static inline uint32_t block_sse(const int16_t *x, const uint8_t *p,
                                 const int16_t *w)
{
    uint32_t acc = 0;
    for (int l = 0; l < VQ_STRIDE; l++) {
        int r = p[l] + w[l];
        r = r < 0 ? 0 : (r > 255 ? 255 : r);
        int e = x[l] + p[l] - r;
        acc += (uint32_t)(e * e);
    }
    return acc;
}
#endif

/* What reconstruct() returns for `book` and ws->idx, without writing the
 * reconstruction: the same clamped sums, pixel by pixel, summed by
 * blocks (integers, so the order does not matter). */
static uint64_t coded_sse(struct gv_tile_workspace *ws, const int8_t *book,
                          int rate, int channels, uint32_t vw, uint32_t vh)
{
    const int dim = 4 * channels, k = 1 << rate;
    for (int c = 0; c < k; c++) {
        int16_t *w = ws->wide + (size_t)c * VQ_STRIDE;
        for (int d = 0; d < VQ_STRIDE; d++)
            w[d] = d < dim ? book[c * dim + d] : 0;
    }
    const uint32_t fbx = vw / 2, fby = vh / 2;        /* whole blocks */
    const uint32_t vbx = (vw + 1) / 2, vby = (vh + 1) / 2;
    uint64_t sse = 0;
    for (uint32_t by = 0; by < vby; by++) {
        const size_t b0 = (size_t)by * GV_BLOCKS;
        const uint32_t whole = by < fby ? fbx : 0;
        uint32_t row = 0;
        for (uint32_t bx = 0; bx < whole; bx++) {
            const size_t b = b0 + bx;
            row += block_sse(ws->vecs + b * VQ_STRIDE, ws->pblk + b * VQ_STRIDE,
                             ws->wide + (size_t)ws->idx[b] * VQ_STRIDE);
        }
        sse += row;
        /* Blocks the valid region cuts: their valid pixels only. */
        for (uint32_t bx = whole; bx < vbx; bx++) {
            const size_t b = b0 + bx;
            const int16_t *x = ws->vecs + b * VQ_STRIDE, *w = ws->wide +
                               (size_t)ws->idx[b] * VQ_STRIDE;
            const uint8_t *p = ws->pblk + b * VQ_STRIDE;
            for (int j = 0; j < 4; j++) {
                if (2 * bx + (j & 1) >= vw || 2 * by + (j >> 1) >= vh)
                    continue;
                for (int c = j * channels; c < (j + 1) * channels; c++) {
                    int r = p[c] + w[c];
                    r = r < 0 ? 0 : (r > 255 ? 255 : r);
                    int e = x[c] + p[c] - r;
                    sse += (uint64_t)(e * e);
                }
            }
        }
    }
    return sse;
}

static void pack_buffer(uint8_t *buf, size_t len, int rate, int channels,
                        const int8_t *book, const uint16_t *idx)
{
    memset(buf, 0, len);
    buf[0] = (uint8_t)rate;
    if (rate == 0)
        return;
    const size_t booklen = ((size_t)1 << rate) * 4 * channels;
    memcpy(buf + 1, book, booklen);
    uint64_t bit = 8 * (1 + booklen);
    for (uint32_t k = 0; k < GV_NBLOCKS; k++, bit += rate) {
        uint32_t v = (uint32_t)idx[k] << (bit & 7);
        uint8_t *p = buf + (bit >> 3);
        for (unsigned s = 0; s < (bit & 7) + (unsigned)rate; s += 8)
            p[s / 8] |= (uint8_t)(v >> s);
    }
}

/* Write the smallest layout of the indices into buf: context-coded (EX),
 * entropy-coded (E) or fixed; returns its length.  ws->alt holds the E
 * candidate while EX is in buf. */
static size_t pack_best(struct gv_tile_workspace *ws, uint8_t *buf, int rate,
                        int channels, const int8_t *book, const uint16_t *idx)
{
    size_t fixed = gv_tilebuf_size(rate, channels);
    if (rate > 0) {
        size_t ex = gv_rans_pack_ctx(idx, rate, channels, book, buf, fixed - 4);
        size_t e = gv_rans_pack(idx, rate, channels, book, ws->alt,
                                (ex ? ex : fixed) - 4);
        if (e) {
            memcpy(buf, ws->alt, e);
            return e;
        }
        if (ex)
            return ex;
    }
    pack_buffer(buf, fixed, rate, channels, book, idx);
    return fixed;
}

/* Shuffle the valid blocks once; training samples are a growing prefix. */
static uint32_t shuffle_valid(struct gv_tile_workspace *ws, uint32_t valid_w,
                              uint32_t valid_h, uint64_t seed)
{
    const uint32_t vbx = (valid_w + 1) / 2, vby = (valid_h + 1) / 2;
    uint32_t nvalid = 0;
    for (uint32_t by = 0; by < vby; by++)
        for (uint32_t bx = 0; bx < vbx; bx++)
            ws->order[nvalid++] = by * GV_BLOCKS + bx;
    for (uint32_t i = nvalid; i > 1; i--) {
        uint32_t j = (uint32_t)(splitmix(&seed) % i);
        uint32_t t = ws->order[i - 1];
        ws->order[i - 1] = ws->order[j];
        ws->order[j] = t;
    }
    return nvalid;
}

/* Grow the sample to the size training at `rate` wants. */
static size_t grow_sample(struct gv_tile_workspace *ws, size_t have, int rate,
                          uint32_t nvalid)
{
    size_t want = (size_t)SAMPLE_PER_CELL << rate;
    if (want < SAMPLE_MIN)
        want = SAMPLE_MIN;
    if (want > nvalid)
        want = nvalid;
    for (; have < want; have++)
        memcpy(ws->sample + have * VQ_STRIDE,
               ws->vecs + (size_t)ws->order[have] * VQ_STRIDE,
               VQ_STRIDE * sizeof(int16_t));
    return have;
}

/* Residual vectors of every block, and the valid blocks shuffled once:
 * what both modes train on.  Returns the number of valid blocks. */
static uint32_t start_training(struct gv_tile_workspace *ws, const uint8_t *orig,
                               int channels, uint32_t valid_w, uint32_t valid_h,
                               uint64_t seed)
{
    make_vectors(ws, orig, channels);
    return shuffle_valid(ws, valid_w, valid_h, seed);
}

/* Train the codebook for `rate` (2^rate entries): grow the sample, start
 * from its mean at rate 1, then split and refine.  Returns the sample's
 * squared error. */
static uint64_t train_rate(struct gv_tile_workspace *ws, int rate, int dim,
                           uint32_t nvalid, int lbg_iters, size_t *nsample)
{
    struct vq_trainer *t = &ws->trainer;
    *nsample = grow_sample(ws, *nsample, rate, nvalid);
    if (rate == 1)
        vq_train_init(t, dim, ws->sample, *nsample);
    return vq_train_double(t, ws->sample, *nsample, lbg_iters, ws->idx,
                           ws->dist);
}

/* Assign every block exactly to the trained codebook (ws->idx); returns
 * the squared error of the reconstruction over the valid region. */
static uint64_t code_all(struct gv_tile_workspace *ws, int rate, int channels,
                         uint32_t valid_w, uint32_t valid_h)
{
    struct vq_trainer *t = &ws->trainer;
    vq_search_prepare(&t->search, t->book, t->k, 4 * channels);
    vq_nearest(&t->search, ws->vecs, GV_NBLOCKS, ws->idx, NULL);
    return coded_sse(ws, t->book, rate, channels, valid_w, valid_h);
}

/* Blocks wholly outside the valid region cost only their index: give them
 * the cheapest one (the least bias, the lowest index among equals). */
static void cheapest_outside(uint16_t *idx, const int32_t *bias, int k,
                             uint32_t valid_w, uint32_t valid_h)
{
    int cheap = 0;
    for (int c = 1; c < k; c++)
        if (bias[c] < bias[cheap])
            cheap = c;
    const uint32_t vbx = (valid_w + 1) / 2, vby = (valid_h + 1) / 2;
    for (uint32_t by = 0; by < GV_BLOCKS; by++)
        for (uint32_t bx = by < vby ? vbx : 0; bx < GV_BLOCKS; bx++)
            idx[by * GV_BLOCKS + bx] = (uint16_t)cheap;
}

/* Move every used codevector of e to the rounded mean of the valid blocks
 * assigned to it by ws->idx.  The indices, hence the bits, stay, and the
 * error before the reconstruction's clamp cannot rise (the rounded,
 * clamped mean is the best signed 8-bit centre of a cell). */
static void refit_cells(struct gv_tile_workspace *ws, struct vq_trainer *e,
                        uint32_t valid_w, uint32_t valid_h)
{
    const int dim = e->dim;
    const uint32_t vbx = (valid_w + 1) / 2, vby = (valid_h + 1) / 2;
    memset(e->sum, 0, sizeof(int64_t) * (size_t)e->k * dim);
    memset(e->count, 0, sizeof(uint32_t) * (size_t)e->k);
    for (uint32_t by = 0; by < vby; by++)
        for (uint32_t bx = 0; bx < vbx; bx++) {
            const uint32_t b = by * GV_BLOCKS + bx;
            const int16_t *x = ws->vecs + (size_t)b * VQ_STRIDE;
            int64_t *sum = e->sum + (size_t)ws->idx[b] * dim;
            for (int d = 0; d < dim; d++)
                sum[d] += x[d];
            e->count[ws->idx[b]]++;
        }
    for (int c = 0; c < e->k; c++)
        if (e->count[c])
            for (int d = 0; d < dim; d++) {
                long v = lround((double)e->sum[c * dim + d] / e->count[c]);
                e->book[c * dim + d] = (int8_t)(v < -128 ? -128 : (v > 127 ? 127 : v));
            }
}

/* Assign every block by distortion + e's biases (ws->idx), the blocks
 * outside the image to the cheapest index, then refit e's book to the
 * whole tile. */
static void assign_all(struct gv_tile_workspace *ws, struct vq_trainer *e,
                       uint32_t valid_w, uint32_t valid_h, int warm)
{
    if (warm)
        vq_nearest_warm(&e->search, ws->vecs, GV_NBLOCKS, ws->idx, NULL);
    else
        vq_nearest(&e->search, ws->vecs, GV_NBLOCKS, ws->idx, NULL);
    cheapest_outside(ws->idx, e->bias, e->k, valid_w, valid_h);
    refit_cells(ws, e, valid_w, valid_h);
}

/* Entropy-constrained coding at `rate`: a copy of the LBG book of
 * ws->trainer is refined on the sample under J = distortion + lambda *
 * bits (ECVQ_ROUNDS rounds), every block is assigned by the same cost and
 * the book refit to the whole tile.  The book is left in ws->ecvq, the
 * indices in ws->idx; returns the squared error of the reconstruction
 * over the valid region. */
static uint64_t code_all_ecvq(struct gv_tile_workspace *ws, int rate,
                              int channels, uint32_t valid_w, uint32_t valid_h,
                              size_t nsample, double lambda)
{
    struct vq_trainer *e = &ws->ecvq;
    vq_train_from(e, ws->trainer.book, ws->trainer.k, 4 * channels);
    vq_train_ecvq(e, ws->sample, nsample, lambda, ECVQ_ROUNDS, 1, ws->idx,
                  ws->dist);
    assign_all(ws, e, valid_w, valid_h, 0);
    return coded_sse(ws, e->book, rate, channels, valid_w, valid_h);
}

/* The best candidate of the rate-distortion search so far. */
struct rd_best {
    int rate;
    uint64_t sse;
    double j;
    size_t bytes;   /* its buffer's length (ws->best_buf; rate > 0) */
};

/* Keep the current candidate (ws->idx and `book`, packed by pack_best
 * into ws->scratch in `bytes`) as the best. */
static void keep_best(struct gv_tile_workspace *ws, struct rd_best *best,
                      int rate, int dim, const int8_t *book, uint64_t sse,
                      double j, size_t bytes)
{
    best->rate = rate;
    best->sse = sse;
    best->j = j;
    best->bytes = bytes;
    memcpy(ws->best_idx, ws->idx, sizeof ws->idx);
    memcpy(ws->best_book, book, ((size_t)1 << rate) * dim);
    memcpy(ws->best_buf, ws->scratch, bytes);
}

/* The end of a rate-distortion search: the best candidate's indices back
 * in ws->idx, its reconstruction in recon, its rate and error in stats,
 * and its buffer (packed already when it was kept) written into buf;
 * returns the buffer's length. */
static size_t finish_best(struct gv_tile_workspace *ws, const uint8_t *orig,
                          const struct rd_best *best, int channels,
                          uint32_t valid_w, uint32_t valid_h, uint8_t *recon,
                          struct gv_tile_stats *stats, uint8_t *buf)
{
    memcpy(ws->idx, ws->best_idx, sizeof ws->idx);
    reconstruct(ws, orig, ws->best_book, best->rate, channels, valid_w, valid_h,
                recon);
    stats->rate = best->rate;
    stats->sse = best->sse;
    if (best->rate == 0) {
        size_t len = gv_tilebuf_size(0, channels);
        pack_buffer(buf, len, 0, channels, NULL, NULL);
        return len;
    }
    memcpy(buf, ws->best_buf, best->bytes);
    return best->bytes;
}

/* Whole-tile ECVQ rounds at the chosen rate: code lengths from the best
 * assignment's counts (every block, as the rANS model counts them),
 * biased assignment of every block, refit; a round is kept while J
 * falls, and the first that does not lower it ends the polish. */
static void polish(struct gv_tile_workspace *ws, int channels,
                   uint32_t valid_w, uint32_t valid_h, double lambda,
                   struct rd_best *best)
{
    struct vq_trainer *e = &ws->ecvq;
    const int dim = 4 * channels, k = 1 << best->rate;
    for (int round = 0; round < POLISH_ROUNDS && best->rate > 0; round++) {
        vq_train_from(e, ws->best_book, k, dim);
        vq_set_biases(e, ws->best_idx, GV_NBLOCKS, lambda);
        vq_search_prepare(&e->search, e->book, k, dim);
        vq_search_set_bias(&e->search, e->bias);
        memcpy(ws->idx, ws->best_idx, sizeof ws->idx);   /* the guesses */
        assign_all(ws, e, valid_w, valid_h, 1);
        uint64_t sse = coded_sse(ws, e->book, best->rate, channels, valid_w,
                                 valid_h);
        size_t bytes = pack_best(ws, ws->scratch, best->rate, channels, e->book,
                                 ws->idx);
        double j = (double)sse + lambda * 8.0 * (double)bytes;
        if (!(j < best->j))
            break;
        keep_best(ws, best, best->rate, dim, e->book, sse, j, bytes);
    }
}

/* Where rate r's book and biases start in ws->rate_book / rate_bias. */
static size_t rate_at(int rate)
{
    return ((size_t)1 << rate) - 2;
}

/* Train `rate` on the sample (LBG from the previous rate's book, then
 * ECVQ_ROUNDS entropy-constrained rounds), keep its book and biases for
 * code_rate, and estimate J over the tile: the sample's last biased cost
 * (squared error + lambda * code lengths) scaled to the valid blocks,
 * plus lambda times the codebook's bits. */
static double sample_rate(struct gv_tile_workspace *ws, int rate, int channels,
                          uint32_t nvalid, size_t *nsample, double lambda)
{
    const int dim = 4 * channels, k = 1 << rate;
    struct vq_trainer *e = &ws->ecvq;
    train_rate(ws, rate, dim, nvalid, RD_LBG_ITERS, nsample);
    vq_train_from(e, ws->trainer.book, ws->trainer.k, dim);
    /* ws->idx holds LBG's assignment of the sample: ECVQ starts from it. */
    uint64_t cost = vq_train_ecvq(e, ws->sample, *nsample, lambda, ECVQ_ROUNDS,
                                  1, ws->idx, ws->dist);
    memcpy(ws->rate_book + rate_at(rate) * dim, e->book, (size_t)k * dim);
    memcpy(ws->rate_bias + rate_at(rate), e->bias, sizeof(int32_t) * (size_t)k);
    return (double)cost * nvalid / (double)*nsample +
           lambda * 8.0 * (1.0 + (double)k * dim);
}

/* Code every block at a trained rate with the book and biases that
 * sample_rate kept: what code_all_ecvq gives, without training again.
 * Leaves the indices in ws->idx and the refit book in ws->ecvq; returns
 * the squared error.  With warm, ws->idx holds indices below 2^rate on
 * entry (the rate below's coding), which start the search. */
static uint64_t code_rate(struct gv_tile_workspace *ws, int rate, int channels,
                          uint32_t valid_w, uint32_t valid_h, int warm)
{
    const int dim = 4 * channels, k = 1 << rate;
    struct vq_trainer *e = &ws->ecvq;
    vq_train_from(e, ws->rate_book + rate_at(rate) * dim, k, dim);
    memcpy(e->bias, ws->rate_bias + rate_at(rate), sizeof(int32_t) * (size_t)k);
    vq_search_prepare(&e->search, e->book, k, dim);
    vq_search_set_bias(&e->search, e->bias);
    assign_all(ws, e, valid_w, valid_h, warm);
    return coded_sse(ws, e->book, rate, channels, valid_w, valid_h);
}

/* Code `rate` over the whole tile (it must be trained) and keep it if it
 * lowers J. */
static void try_rate(struct gv_tile_workspace *ws, int rate, int channels,
                     uint32_t valid_w, uint32_t valid_h, double lambda,
                     int warm, struct rd_best *best)
{
    uint64_t sse = code_rate(ws, rate, channels, valid_w, valid_h, warm);
    size_t bytes = pack_best(ws, ws->scratch, rate, channels, ws->ecvq.book,
                             ws->idx);
    double j = (double)sse + lambda * 8.0 * (double)bytes;
    if (j < best->j)
        keep_best(ws, best, rate, 4 * channels, ws->ecvq.book, sse, j, bytes);
}

/* The estimates of the rates trained so far, and how far. */
struct rd_sample {
    uint32_t nvalid;
    size_t nsample;
    int trained;
};

/* Train every rate up to `rate` that is not trained yet. */
static void train_up_to(struct gv_tile_workspace *ws, struct rd_sample *sm,
                        int rate, int channels, double lambda)
{
    while (sm->trained < rate) {
        sm->trained++;
        ws->jest[sm->trained] = sample_rate(ws, sm->trained, channels,
                                            sm->nvalid, &sm->nsample, lambda);
    }
}

/*
 * Rate-distortion mode with entropy-constrained VQ.  The codebooks grow
 * rate by rate (each split from the last), so every rate is trained on
 * the sample in turn, and J is estimated there (sample_rate), until the
 * estimate has risen twice in a row, or once from CONVEX_FROM on.  Only
 * the rates around the estimate's least J, r*, are coded over the whole
 * tile, the costly step: r* - 1 to r* + 1; then upwards while the exact J
 * has not risen twice since the best (once from CONVEX_FROM on: the
 * stopping rule of a search that codes every rate from 1), and downwards
 * while the best is the lowest rate coded.  The winner is then polished.
 * Consecutive rates are coded upwards, each search started from the
 * rate below's indices.
 */
static size_t encode_rd_ecvq(struct gv_tile_workspace *ws, const uint8_t *orig,
                             int channels, uint32_t valid_w, uint32_t valid_h,
                             const struct gv_tile_params *params, int max_rate,
                             uint64_t sse0, uint8_t *recon, uint8_t *buf,
                             struct gv_tile_stats *stats)
{
    const double lambda = params->lambda;
    struct rd_best best = {
        .rate = 0, .sse = sse0,
        .j = (double)sse0 + lambda * 8.0 * gv_tilebuf_size(0, channels),
    };
    struct rd_sample sm = {
        .nvalid = start_training(ws, orig, channels, valid_w, valid_h,
                                 params->seed),
    };
    int rstar = 0, rises = 0;
    double jmin = best.j;
    for (int rate = 1; rate <= max_rate; rate++) {
        train_up_to(ws, &sm, rate, channels, lambda);
        if (ws->jest[rate] < jmin) {
            jmin = ws->jest[rate];
            rstar = rate;
            rises = 0;
        } else if (++rises == 2 || rate >= CONVEX_FROM) {
            break;
        }
    }
    int lo = rstar > 1 ? rstar - 1 : 1;
    int hi = rstar + 1 < max_rate ? rstar + 1 : max_rate;
    for (int rate = lo; rate <= hi; rate++) {
        train_up_to(ws, &sm, rate, channels, lambda);
        try_rate(ws, rate, channels, valid_w, valid_h, lambda, rate > lo, &best);
    }
    rises = hi - (best.rate > lo - 1 ? best.rate : lo - 1);
    while (hi < max_rate && rises < 2 && !(rises == 1 && hi >= CONVEX_FROM)) {
        hi++;
        train_up_to(ws, &sm, hi, channels, lambda);
        try_rate(ws, hi, channels, valid_w, valid_h, lambda, 1, &best);
        rises = best.rate == hi ? 0 : rises + 1;
    }
    while (best.rate <= lo && lo > 1) {
        lo--;
        try_rate(ws, lo, channels, valid_w, valid_h, lambda, 0, &best);
    }
    polish(ws, channels, valid_w, valid_h, lambda, &best);
    return finish_best(ws, orig, &best, channels, valid_w, valid_h, recon,
                       stats, buf);
}

/*
 * Rate-distortion mode with params->nearest_only (LBG codebooks, nearest
 * assignment; the encoder before entropy-constrained VQ, kept for
 * comparisons): every rate is coded in turn and the one minimizing
 * J = SSE + lambda * bits wins; the search stops once J has risen for
 * two rates in a row.
 */
static size_t encode_rd_nearest(struct gv_tile_workspace *ws,
                                const uint8_t *orig, int channels,
                                uint32_t valid_w, uint32_t valid_h,
                                const struct gv_tile_params *params,
                                int max_rate, uint64_t sse0, uint8_t *recon,
                                uint8_t *buf, struct gv_tile_stats *stats)
{
    const int dim = 4 * channels;
    const double lambda = params->lambda;
    struct rd_best best = {
        .rate = 0, .sse = sse0,
        .j = (double)sse0 + lambda * 8.0 * gv_tilebuf_size(0, channels),
    };
    uint32_t nvalid = start_training(ws, orig, channels, valid_w, valid_h,
                                     params->seed);
    size_t nsample = 0;
    int rises = 0;
    for (int rate = 1; rate <= max_rate; rate++) {
        train_rate(ws, rate, dim, nvalid, TARGET_LBG_ITERS, &nsample);
        uint64_t sse = code_all(ws, rate, channels, valid_w, valid_h);
        size_t bytes = pack_best(ws, ws->scratch, rate, channels,
                                 ws->trainer.book, ws->idx);
        double j = (double)sse + lambda * 8.0 * (double)bytes;
        if (j < best.j) {
            keep_best(ws, &best, rate, dim, ws->trainer.book, sse, j, bytes);
            rises = 0;
        } else if (++rises == 2) {
            break;
        }
    }
    return finish_best(ws, orig, &best, channels, valid_w, valid_h, recon,
                       stats, buf);
}

/*
 * Target mode at the cap, when entropy-constrained coding (ws->idx, the
 * book in ws->ecvq, error ecvq_sse) misses the budget: nearest-codevector
 * coding has less error, and is taken if it meets the budget, so that no
 * tile misses a target the nearest codevectors would meet.  Otherwise the
 * entropy-constrained coding stays.  Returns the error of the coding left
 * in ws->idx and *book.
 */
static uint64_t nearest_at_cap(struct gv_tile_workspace *ws, int rate,
                               int channels, uint32_t valid_w,
                               uint32_t valid_h, double budget,
                               uint64_t ecvq_sse, const int8_t **book)
{
    memcpy(ws->best_idx, ws->idx, sizeof ws->idx);
    uint64_t sse = code_all(ws, rate, channels, valid_w, valid_h);
    if ((double)sse <= budget) {
        *book = ws->trainer.book;
        return sse;
    }
    memcpy(ws->idx, ws->best_idx, sizeof ws->idx);
    *book = ws->ecvq.book;
    return ecvq_sse;
}

/*
 * Target mode: the first rate whose exact error meets the budget (or the
 * cap).  A rate is coded exactly only when its training sample says it
 * may meet the target, since the exact assignment is the costly step.  It
 * is coded with entropy-constrained VQ at the slope of the rate-distortion
 * mode for the same target (fewer bits, more error at each rate), and at
 * the cap also with nearest codevectors if that is needed to meet it.
 */
static size_t encode_target(struct gv_tile_workspace *ws, const uint8_t *orig,
                            int channels, uint32_t valid_w, uint32_t valid_h,
                            const struct gv_tile_params *params, int max_rate,
                            double budget, uint8_t *recon, uint8_t *buf,
                            struct gv_tile_stats *stats)
{
    const int dim = 4 * channels, ecvq = !params->nearest_only;
    const double lambda = gv_rd_lambda(params->target_mse);
    uint32_t nvalid = start_training(ws, orig, channels, valid_w, valid_h,
                                     params->seed);
    size_t nsample = 0;
    for (int rate = 1;; rate++) {
        uint64_t est = train_rate(ws, rate, dim, nvalid, TARGET_LBG_ITERS,
                                  &nsample);
        /* The sample's error per sample, scaled to the valid region. */
        double est_mse = (double)est / ((double)nsample * dim);
        if (rate < max_rate && est_mse > params->target_mse)
            continue;
        uint64_t sse;
        const int8_t *book;
        if (ecvq) {
            sse = code_all_ecvq(ws, rate, channels, valid_w, valid_h, nsample,
                                lambda);
            book = ws->ecvq.book;
            if (rate == max_rate && (double)sse > budget)
                sse = nearest_at_cap(ws, rate, channels, valid_w, valid_h,
                                     budget, sse, &book);
        } else {
            sse = code_all(ws, rate, channels, valid_w, valid_h);
            book = ws->trainer.book;
        }
        if ((double)sse <= budget || rate == max_rate) {
            reconstruct(ws, orig, book, rate, channels, valid_w, valid_h, recon);
            stats->rate = rate;
            stats->sse = sse;
            return pack_best(ws, buf, rate, channels, book, ws->idx);
        }
    }
}

/* Whether a layout D buffer of dlen bytes (0: it did not fit in
 * GV_TILEBUF_MAX) with squared error dsse costs less than the other
 * layout's len bytes with sse: SSE + lambda * bits, D strictly lower. */
static int dct_wins(double lambda, uint64_t dsse, size_t dlen, uint64_t sse,
                    size_t len)
{
    return dlen && (double)dsse + lambda * 8.0 * (double)dlen <
                       (double)sse + lambda * 8.0 * (double)len;
}

/* Layout D for the same tile: kept instead of the VQ buffer (len bytes,
 * stats, recon) when dct_wins.  Returns the length kept. */
static size_t try_dct(struct gv_tile_workspace *ws, const uint8_t *orig,
                      int channels, uint32_t valid_w, uint32_t valid_h,
                      double lambda, size_t len, uint8_t *recon, uint8_t *buf,
                      struct gv_tile_stats *stats)
{
    uint64_t dsse;
    size_t dlen = gv_dct_encode(ws->dct, orig, ws->pred, channels, valid_w,
                                valid_h, lambda, ws->alt, GV_TILEBUF_MAX,
                                ws->dct_recon, &dsse);
    if (!dct_wins(lambda, dsse, dlen, stats->sse, len))
        return len;
    memcpy(buf, ws->alt, dlen);
    memcpy(recon, ws->dct_recon, (size_t)GV_TILE * GV_TILE * channels);
    stats->rate = GV_RATE_DCT;
    stats->sse = dsse;
    return dlen;
}

size_t gv_tile_encode(struct gv_tile_workspace *ws, const uint8_t *orig,
                      const uint8_t *parent, int qx, int qy, int channels,
                      uint32_t valid_w, uint32_t valid_h,
                      const struct gv_tile_params *params, uint8_t *recon,
                      uint8_t *buf, struct gv_tile_stats *stats)
{
    const uint64_t samples = (uint64_t)valid_w * valid_h * channels;
    const double budget = params->target_mse * (double)samples;
    const int max_rate = params->max_rate < 1 ? 1 :
                         (params->max_rate > GV_MAX_RATE ? GV_MAX_RATE : params->max_rate);

    gv_predict(parent, channels, qx, qy, ws->pred);
    stats->samples = samples;

    if (params->lambda > 0 && !params->nearest_only &&
        params->dct == GV_LAYOUTS_D) {
        /* The prediction alone (r = 0) or layout D, whichever costs less
         * (dct_wins); D is coded straight into buf and recon
         * (buf holds GV_TILEBUF_MAX bytes in this mode), which are
         * rewritten only when the prediction alone wins. */
        const size_t row = (size_t)GV_TILE * channels;
        const uint64_t sse = gv_sse_u8(orig, ws->pred,
                                       valid_w * (uint32_t)channels, valid_h,
                                       row);
        const size_t len = gv_tilebuf_size(0, channels);
        uint64_t dsse;
        const size_t dlen = gv_dct_encode(ws->dct, orig, ws->pred, channels,
                                          valid_w, valid_h, params->lambda,
                                          buf, GV_TILEBUF_MAX, recon, &dsse);
        if (dct_wins(params->lambda, dsse, dlen, sse, len)) {
            stats->rate = GV_RATE_DCT;
            stats->sse = dsse;
            return dlen;
        }
        memcpy(recon, ws->pred, row * GV_TILE);
        stats->rate = 0;
        stats->sse = sse;
        if (dlen) {
            pack_buffer(buf, len, 0, channels, NULL, NULL);
            return len;
        }
        /* Too fine for D's largest buffer: the VQ search instead. */
        return encode_rd_ecvq(ws, orig, channels, valid_w, valid_h, params,
                              max_rate, sse, recon, buf, stats);
    }
    uint64_t sse = reconstruct(ws, orig, NULL, 0, channels, valid_w, valid_h, recon);
    if (params->lambda > 0 && !params->nearest_only) {
        size_t len = encode_rd_ecvq(ws, orig, channels, valid_w, valid_h,
                                    params, max_rate, sse, recon, buf, stats);
        if (params->dct)
            len = try_dct(ws, orig, channels, valid_w, valid_h,
                          params->lambda, len, recon, buf, stats);
        return len;
    }
    if (params->lambda > 0)
        return encode_rd_nearest(ws, orig, channels, valid_w, valid_h, params, max_rate,
                         sse, recon, buf, stats);
    if ((double)sse <= budget) {
        stats->rate = 0;
        stats->sse = sse;
        size_t len = gv_tilebuf_size(0, channels);
        pack_buffer(buf, len, 0, channels, NULL, NULL);
        return len;
    }
    return encode_target(ws, orig, channels, valid_w, valid_h, params, max_rate,
                         budget, recon, buf, stats);
}
