/*
 * tile.h - the tile codec: prediction from the parent, the fig. 7.2 tile
 * buffer, the encoder, and the CPU reference decoder.
 *
 * A tile is 513x513 pixels of `channels` interleaved 8-bit samples.  It is
 * predicted from one quarter of its decoded parent tile by the separable
 * 4-tap Catmull-Rom cubic of docs/FORMAT.md section 3 (integer weights
 * -3, 29, 111, -9 in 128ths, one rounding; predict.c), and the residual
 * is coded as one index per 2x2 block into a per-tile signed 8-bit
 * codebook (FORMAT.md section 4):
 *
 *   byte 0          r, the index width in bits (0..GV_MAX_RATE), in bits
 *                   0-3; bit 7 is the layout flag E, bit 6 the flag X
 *                   (tile_rans.h)
 *   bytes 1..       2^r codevectors of 4*channels signed bytes
 *   then, E = 0     257*257 indices of r bits, LSB-first, then zero
 *                   padding to a multiple of 4 bytes
 *   then, E = 1     the indices as 257 rANS streams, one per block row
 *                   (FORMAT.md section 4.1)
 *   or, E = X = 1   (format version 2) bytes 1-3 hold the number of
 *                   context models and N, then N codevectors sorted by
 *                   use, then context-coded rANS streams (section 4.2)
 *
 * The decoder uses integer arithmetic only, so that every GPU decoder can
 * reproduce it bit for bit.  Every function is thread-safe.
 * gv_tilebuf_*, gv_predict and gv_tile_decode allocate nothing (their
 * scratch is on the stack, about 60 KiB); gv_tile_encode works in a
 * workspace the caller allocates once per thread.
 */
#ifndef GV_TILE_H
#define GV_TILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "codec/tile_layout.h"

/* The largest tile buffer: gv_tilebuf_size(GV_MAX_RATE, 3) (checked by
 * tests/test_tile.c).  Entropy-coded buffers are only ever written when
 * smaller than the fixed layout at the same rate. */
#define GV_TILEBUF_MAX 148228

/* Bytes of a fixed-layout tile buffer at index width `rate`
 * (0..GV_MAX_RATE).  Inline: the layout checks of tile_decode.c and
 * tile_rans.c both need it, and neither depends on the other for it. */
static inline size_t gv_tilebuf_size(int rate, int channels)
{
    if (rate <= 0)
        return 4;
    uint64_t bits = 8u * (1u + ((uint64_t)1 << rate) * 4u * (unsigned)channels) +
                    (uint64_t)GV_NBLOCKS * (unsigned)rate;
    return (size_t)((bits + 31) / 32 * 4);
}

/*
 * Predict a 513x513 tile from quadrant (qx,qy) in {0,1}^2 of the decoded
 * parent tile `parent` (513x513xC).  Writes 513x513xC bytes to `pred`.
 */
void gv_predict(const uint8_t *parent, int channels, int qx, int qy,
                uint8_t *pred);

/*
 * Check that buf[0..len) is a well-formed tile buffer for `channels`:
 * all of a fixed-layout buffer; the layout of an entropy-coded one (its
 * tables and stream lengths), whose streams gv_tile_decode validates as it
 * decodes them.  Returns its rate r, or -1 with *err filled.
 */
int gv_tilebuf_check(const uint8_t *buf, size_t len, int channels,
                     struct gv_error *err);

/*
 * Decode tile buffer `buf` (len bytes) against its decoded parent.  `out`
 * receives 513x513xC bytes.  Returns 0, or -1 with *err filled for a
 * malformed buffer (never reads outside buf); after a failure `out` holds
 * unspecified bytes (a damaged rANS stream is only found on the way).
 */
int gv_tile_decode(const uint8_t *buf, size_t len, int channels,
                   const uint8_t *parent, int qx, int qy, uint8_t *out,
                   struct gv_error *err);

/* Read index k (0..257^2-1) of a checked buffer at rate r >= 1. */
uint32_t gv_tilebuf_index(const uint8_t *buf, int rate, int channels,
                          uint32_t k);

/* The mean squared error per 8-bit sample that a PSNR of psnr_db decibels
 * allows: 255^2 / 10^(psnr_db / 10).  The one form of this conversion, so
 * that the encoder, its statistics and the merge of shards agree to the
 * bit. */
double gv_psnr_to_mse(double psnr_db);

/* The price of a bit, in squared error, at a target mean squared error
 * per sample: the slope 2 ln 2 * target_mse of the high-rate model
 * D(R) ~ 2^(-2R).  The lambda of the rate-distortion mode, and the one
 * the target mode's entropy-constrained VQ uses. */
double gv_rd_lambda(double target_mse);

/* Quality and rate controls for gv_tile_encode. */
struct gv_tile_params {
    double target_mse;   /* mean squared error per sample to reach */
    int max_rate;        /* cap on r, 1..GV_MAX_RATE */
    double lambda;       /* > 0: rate-distortion mode instead of a target:
                          * pick the r minimizing SSE + lambda * bits, with
                          * entropy-constrained VQ (every index chosen and
                          * every codebook trained by squared error +
                          * lambda * its code length) */
    int nearest_only;    /* either mode without entropy-constrained VQ
                          * (nearest codevector, LBG codebooks): the
                          * encoder before it, kept for comparisons */
    uint64_t seed;       /* deterministic sampling seed for this tile */
    int dct;             /* rate-distortion modes (lambda > 0, not
                          * nearest_only): GV_LAYOUTS_* */
};

/* Which layouts the rate-distortion modes may write: the VQ ones only
 * (format version 2); VQ and D, whichever has the lower SSE + lambda *
 * bits; or D and the prediction alone (r = 0), without the VQ search (on
 * eight photographs the VQ layouts won 3 tiles of 488, by 2.5 %, and cost
 * most of the encoding time). */
enum { GV_LAYOUTS_VQ = 0, GV_LAYOUTS_ALL = 1, GV_LAYOUTS_D = 2 };

/* gv_tile_stats.rate of a tile written in layout D. */
#define GV_RATE_DCT (GV_MAX_RATE + 1)

struct gv_tile_stats {
    int rate;            /* chosen r, or GV_RATE_DCT */
    uint64_t sse;        /* squared error over the valid samples */
    uint64_t samples;    /* valid pixels x channels */
};

struct gv_tile_workspace;

/* Allocate / free the scratch memory one encoding thread needs (~7 MiB).
 * gv_tile_workspace_free(NULL) does nothing. */
struct gv_tile_workspace *gv_tile_workspace_new(void);
void gv_tile_workspace_free(struct gv_tile_workspace *ws);

/*
 * Encode one tile.
 *   orig    513x513xC original pixels, already clamp-padded past the image
 *   parent  decoded parent tile; (qx,qy) the quadrant this tile covers
 *   valid_w, valid_h  how many columns/rows of the tile lie in the image;
 *           only those count in the error
 *   recon   receives the decoded tile (exactly what gv_tile_decode gives)
 *   buf     receives the tile buffer; it must hold
 *           gv_tilebuf_size(params->max_rate, channels) bytes, or
 *           GV_TILEBUF_MAX when params->dct is not GV_LAYOUTS_VQ
 * Returns the buffer length in bytes and fills *stats.  Cannot fail.
 */
size_t gv_tile_encode(struct gv_tile_workspace *ws, const uint8_t *orig,
                      const uint8_t *parent, int qx, int qy, int channels,
                      uint32_t valid_w, uint32_t valid_h,
                      const struct gv_tile_params *params, uint8_t *recon,
                      uint8_t *buf, struct gv_tile_stats *stats);

#endif
