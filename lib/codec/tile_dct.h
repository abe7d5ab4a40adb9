/*
 * tile_dct.h - layouts D and D2 of a tile buffer (docs/FORMAT.md sections
 * 4.3 and 4.4, format versions 4 and 5; D2, which the encoder writes, is
 * D with a model for each block's last value): the residual coded
 * without a codebook, by a YCoCg-R
 * colour transform, an 8x8 integer DCT (the HEVC matrix), one uniform
 * quantizer step per channel and rANS-coded coefficients, one stream per
 * row of 8x8 blocks so that a GPU decodes a tile with 65 threads.
 *
 * VQ with a per-tile codebook runs out of bits at high rates: 2^12
 * codevectors at most, whose codebook alone takes 48 KiB.  A transform
 * coder has no codebook and codes each coefficient with a few bits or
 * fewer, so where detail is dense (textured photographs at 38 dB and
 * more) it needs far fewer bytes.  The encoder writes whichever of the VQ
 * layouts and this one costs less (tile_encode.c).
 *
 * Every function is thread-safe.  The decoder uses 32-bit integer
 * arithmetic only, so that the GLSL and WebGL2 decoders reproduce it bit
 * for bit.
 */
#ifndef GV_TILE_DCT_H
#define GV_TILE_DCT_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define GV_TILE_DCT 0x20        /* byte 0 of a layout D buffer */
#define GV_TILE_DCT2 0x21      /* byte 0 of a layout D2 buffer: D with a
                                 * model for each block's last value */
#define GV_DCT_BLOCKS 65        /* 8x8 blocks per tile edge: ceil(513 / 8) */
#define GV_DCT_PLANE 520        /* coefficient plane edge: 8 * 65 */
#define GV_DCT_EOB_MODELS 6     /* eob models: channel class x previous eob */
#define GV_DCT_MODELS 30        /* eob models, then 24 token models */
#define GV_DCT_MODELS_D2 32      /* layout D2: and the 2 last-value models */
#define GV_DCT_LAST_MODEL 30    /* layout D2: model 30 + cc codes a block's
                                 * last value (channel class cc) */
#define GV_DCT_EOB_SYMBOLS 65   /* an eob model codes 0..64 coefficients */
#define GV_DCT_TOKEN_SYMBOLS 16 /* 0, +-1..+-7, escape */
#define GV_DCT_ESCAPE 15
#define GV_DCT_MAX_STEP 4095

/* Whether byte 0 of a tile buffer names layout D or D2 (both decode
 * through this file and the same GPU passes). */
static inline int gv_tile_is_dct(uint8_t b0)
{
    return b0 == GV_TILE_DCT || b0 == GV_TILE_DCT2;
}

/* The zigzag order: zz[k] = 8 * v + u for coefficient k (row v, column u). */
extern const uint8_t gv_dct_zigzag[64];

/* 3 * the band of zigzag position k (0 for k = 0, 1 for 1..2, 2 for 3..9,
 * 3 for 10..63): the offset of its token models within a channel class. */
extern const uint8_t gv_dct_band_model[64];

/* The magnitude class of a quantized value: 0, 1, or 2 for |q| >= 2. */
static inline int gv_dct_class(int q)
{
    const int a = q < 0 ? -q : q;
    return a > 2 ? 2 : a;
}

/* The eob context a block's count n of coded coefficients gives the next
 * block of its channel in the row: 0 for none, 1 for 1..4, 2 above. */
static inline int gv_dct_eob_class(int n)
{
    return n == 0 ? 0 : (n <= 4 ? 1 : 2);
}

/* Symbols of model m: 65 for an eob model, 16 for a token model (the
 * last-value models included). */
static inline int gv_dct_model_symbols(int m)
{
    return m < GV_DCT_EOB_MODELS ? GV_DCT_EOB_SYMBOLS : GV_DCT_TOKEN_SYMBOLS;
}

/* The inverse transform's matrix K[u][i] (FORMAT.md 4.3). */
extern const int32_t gv_dct_matrix[8][8];

/*
 * Check the layout of a D buffer for `channels`: its steps, model mask,
 * models and stream lengths (the streams are checked while decoding).
 * Returns 0, or -1 with *err (GV_ECORRUPT).
 */
int gv_dct_check(const uint8_t *buf, size_t len, int channels,
                 struct gv_error *err);

/*
 * Decode the streams of a D buffer (checked here) into the coefficient
 * plane: coefs[4 * (Y * 520 + X) + c] is dequantized coefficient (v, u) =
 * (Y mod 8, X mod 8) of channel c of block (X div 8, Y div 8); components
 * past `channels` are 0.  coefs holds 520 * 520 * 4 int16.  This is the
 * texture a GPU decoder without compute shaders (WebGL2) uploads.  Returns
 * 0, or -1 with *err for a damaged buffer (coefs then partly written).
 */
int gv_dct_unpack(const uint8_t *buf, size_t len, int channels,
                  int16_t *coefs, struct gv_error *err);

/*
 * Decode a D buffer against its decoded parent, as gv_tile_decode does
 * (which calls this for D buffers).  Its scratch (about 110 KiB: two
 * rows of coefficients, the models' tables and the predictor's rows) is on
 * the stack; where the CPU has AVX-512 VBMI, a thread's first call also
 * allocates the 396 KiB that its rANS lanes keep until the thread ends
 * (tile_dct_lanes.h), and decodes with the scalar rows if that fails.
 * Returns 0 or -1 with *err.
 */
int gv_dct_decode(const uint8_t *buf, size_t len, int channels,
                  const uint8_t *parent, int qx, int qy, uint8_t *out,
                  struct gv_error *err);

/*
 * The tile that gv_dct_decode gives for a buffer whose quantized values
 * are already known, without its rANS streams or the prediction: q[c][b]
 * the values of block b = 65 * by + bx of channel c in zigzag order (only
 * the first eob[c][b] are read), steps[c] the buffer's steps, pred the
 * prediction from the parent (513 x 513 x channels).  Writes out, which
 * must not overlap pred.  For the encoder, which has all of these.
 */
void gv_dct_rebuild(const int16_t (*q)[GV_DCT_BLOCKS * GV_DCT_BLOCKS][64],
                    const uint8_t (*eob)[GV_DCT_BLOCKS * GV_DCT_BLOCKS],
                    const int *steps, int channels, const uint8_t *pred,
                    uint8_t *out);

/*
 * The inverse transform of one 8x8 block of one channel, d[8 * v + u]
 * dequantized coefficients, into e[8 * j + i] (FORMAT.md 4.3), exactly.
 */
void gv_dct_inverse(const int16_t *d, int32_t *e);

/* ---- encoding (tile_dct_encode.c) ---- */

struct gv_dct_workspace;

/* About 7 MiB of scratch for one encoding thread; _free(NULL) is a no-op. */
struct gv_dct_workspace *gv_dct_workspace_new(void);
void gv_dct_workspace_free(struct gv_dct_workspace *ws);

/*
 * Code tile `orig` (513x513xC, clamp-padded) against its prediction
 * `pred` (its prediction from the parent, section 3) in layout D,
 * choosing the quantizer steps that minimize
 * SSE + lambda * bits over the valid_w x valid_h pixels (lambda > 0).
 * Writes the buffer (at most cap bytes) and the decoded tile to recon
 * (exactly what gv_dct_decode gives).  Returns the buffer length, with
 * *sse, or 0 when the buffer would not fit in cap (recon then unspecified).
 */
size_t gv_dct_encode(struct gv_dct_workspace *ws, const uint8_t *orig,
                     const uint8_t *pred, int channels, uint32_t valid_w,
                     uint32_t valid_h, double lambda, uint8_t *buf,
                     size_t cap, uint8_t *recon, uint64_t *sse);

#endif
