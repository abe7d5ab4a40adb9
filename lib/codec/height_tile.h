/*
 * height_tile.h - the tile codec of height stores: 513x513 tiles of 16-bit
 * codes, predicted from the decoded parent tile and coded with a
 * guaranteed maximum error (docs/FORMAT.md section 9).
 *
 * Prediction is the separable Catmull-Rom cubic of the image tiles
 * (FORMAT.md section 3, weights -3, 29, 111, -9 in 128ths, one rounding)
 * on 16-bit codes, in exact 32-bit integers.  The residual r = orig - pred
 * is quantized with step 2e+1 (q = r / (2e+1) rounded half away from
 * zero), so that the decoded code clamp(pred + q(2e+1), 0, 65535) is
 * within e of the original.  The q are rANS-coded in 65 independent
 * streams of 8 rows each; each q is a token (small values direct, larger
 * ones a bit length plus uniformly coded extra bits) under one of 12
 * static tables chosen by the context bitlen(|q left| + |q above|)
 * (neighbours in the same stream, 0 past its edge): entropy decoding
 * needs only the buffer, prediction only the parent, so a GPU or a
 * browser may do either on its own.  The decoder is integer-only, so
 * every GPU decoder reproduces it bit for bit.
 *
 * Buffer (little-endian, length a multiple of 4):
 *
 *   0    u8   mode: 0 prediction only (the buffer is 4 bytes), 1 coded
 *   1    u8   0
 *   2    u16  e, the half-step in codes (residual step 2e+1), <= 32767
 *   4    u16  mask: bit c set when context c (0..11) has a table
 *   6    u16  n[65] stream lengths in 16-bit words
 *   136  u16  cum[29] cumulative frequencies (15 bits) of each context in
 *             the mask, in order; zero padding to 4 bytes
 *   S    u16  the streams, one after another; zero padding to 4 bytes
 *
 * All functions are thread-safe and allocate nothing but what they say.
 */
#ifndef GV_HEIGHT_TILE_H
#define GV_HEIGHT_TILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define GV_HT_SIDE 513          /* samples per tile edge */
#define GV_HT_SAMPLES (513 * 513)
#define GV_HT_TOKENS 29         /* 16 direct values + 13 bit lengths 5..17 */
#define GV_HT_DIRECT 16         /* zigzag values coded as one token */
#define GV_HT_ROWS 8            /* rows per rANS stream */
#define GV_HT_STREAMS 65        /* ceil(513 / 8) */
#define GV_HT_CONTEXTS 12       /* bitlen(|left| + |above|), capped at 11 */
#define GV_HT_MASK_AT 4
#define GV_HT_LEN_AT 6
#define GV_HT_CUM_AT 136
#define GV_HT_DATA_AT (GV_HT_CUM_AT + GV_HT_CONTEXTS * 2 * GV_HT_TOKENS + 4)
#define GV_HT_MAX_E 32767
/* Worst case: every sample a 17-bit value (token + two chunks, at most
 * 15 + 12 + 4 bits, under 2 words) plus the tables. */
#define GV_HT_BUF_MAX (GV_HT_DATA_AT + 4 * GV_HT_SAMPLES + 4 * GV_HT_STREAMS + 4)

/* Predict a tile (513x513 codes) from quadrant (qx,qy) of the decoded
 * parent tile.  0, or -1 when its 535 KB of scratch cannot be had. */
int gv_height_predict(const uint16_t *parent, int qx, int qy, uint16_t *pred);

/*
 * Encode tile `orig` (513x513 codes) against the decoded `parent` at
 * quadrant (qx,qy) with half-step e (0 = lossless).  Only the first
 * valid_w columns and valid_h rows lie inside the level: the others are
 * coded as the prediction itself (q = 0), and decoders never show them.  Writes the buffer to out (GV_HT_BUF_MAX bytes) and the
 * decoded tile, as every decoder will produce it, to `dec`.  Returns the
 * buffer's length (a multiple of 4), or 0 on allocation failure.
 */
size_t gv_height_tile_encode(const uint16_t *orig, const uint16_t *parent,
                             int qx, int qy, int e, int valid_w, int valid_h,
                             uint8_t *out, uint16_t *dec);

/* The length of the one tile buffer that starts at buf (of len bytes
 * available), read from its header (mode, mask, stream lengths): what
 * splits a sample store's tile into its channels (samples_tile.h).  0 when
 * the header is malformed or the buffer runs past len; the rest is
 * checked by gv_height_tile_check. */
size_t gv_height_tile_span(const uint8_t *buf, size_t len);

/* Check the layout of a tile buffer (mode, e, tables, stream lengths);
 * the streams themselves are checked while decoding.  0 or -1. */
int gv_height_tile_check(const uint8_t *buf, size_t len, struct gv_error *err);

/*
 * Decode buffer buf against the decoded parent at quadrant (qx,qy) into
 * out (513x513 codes).  Checks everything: a damaged buffer fails with
 * GV_ECORRUPT.  0 or -1.
 */
int gv_height_tile_decode(const uint8_t *buf, size_t len,
                          const uint16_t *parent, int qx, int qy,
                          uint16_t *out, struct gv_error *err);

/*
 * Entropy-decode only: the quantized residuals q (signed, 513x513) of a
 * checked buffer, for decoders that reconstruct elsewhere (WebGL2, tests).
 * *e receives the half-step.  0 or -1 (GV_ECORRUPT).
 */
int gv_height_tile_residuals(const uint8_t *buf, size_t len, int32_t *q,
                             int *e, struct gv_error *err);

#endif
