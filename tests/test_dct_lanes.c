/*
 * test_dct_lanes.c - the rANS rows of layouts D and D2 in SIMD lanes
 * (lib/codec/tile_dct_lanes.c) against the scalar rows of tile_dct.c,
 * through gv_dct_decode with the lanes on and off: the same bytes on the
 * fixtures of tests/dct_fixture.h (escapes at both ends of their range,
 * steps of 4095, every coefficient coded, none), on tiles the encoder
 * wrote from synthetic and real photographs, and the same return and
 * message on damaged buffers (flipped bits, stream lengths moved, a model
 * the streams use left out).  On a CPU without AVX-512 VBMI the lanes do
 * not run and the comparisons are skipped.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_dct_lanes.h"
#include "codec/tile_layout.h"
#include "imageio/imageio.h"
#include "dct_fixture.h"
#include "util.h"

#define T GV_TILE
#define P GV_DCT_PLANE

static uint64_t rng = 0x2545f4914f6cdd1dull;
static uint8_t orig[T * T * 3], parent[T * T * 3], pred[T * T * 3],
    recon[T * T * 3], out0[T * T * 3], out1[T * T * 3];
static uint8_t buf[2u << 20], b[2u << 20];

/* Decode b (len bytes) with the scalar rows and with the lanes: returns
 * 1 when both give the same return, message and (on success) bytes, and
 * on success the lanes decoded all four groups of rows. */
static int same(const uint8_t *bb, size_t len, int C, int *rc_out)
{
    struct gv_error e0, e1;
    memset(&e0, 0, sizeof e0);
    memset(&e1, 0, sizeof e1);
    gv_cpu_set_mask(GV_CPU_LEVEL_AVX2);
    int rc0 = gv_dct_decode(bb, len, C, parent, 1, 0, out0, &e0);
    gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    unsigned long t0, r0, t1, r1;
    gv_dct_lanes_counts(&t0, &r0);
    int rc1 = gv_dct_decode(bb, len, C, parent, 1, 0, out1, &e1);
    gv_dct_lanes_counts(&t1, &r1);
    *rc_out = rc0;
    if (rc0 != rc1)
        return 0;
    if (rc0 < 0)
        return e0.code == e1.code && !strcmp(e0.text, e1.text);
    return !memcmp(out0, out1, (size_t)T * T * C) && t1 - t0 == 4 && r1 == r0;
}

static void make_tile(uint8_t *t, int C, int amp)
{
    dct_fixture_tile(t, T, C, amp, &rng);
}

static void test_fixtures(void)
{
    static int q[3 * P * P];
    uint64_t seed = 5;
    for (int C = 1; C <= 3; C += 2) {
        make_tile(parent, C, 30);
        for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
            int S[3], rc;
            dct_fixture_case(k, C, &seed, q, S);
            size_t len = dct_fixture_write(q, S, C, buf);
            check(same(buf, len, C, &rc) && rc == 0,
                  "C=%d fixture %d: the lanes give the scalar rows' tile", C, k);
        }
    }
}

/* Load a 513 x 513 crop of tests/data/picos-1100x700.jpg into orig (C
 * channels; C = 1 takes the green) and a parent whose top-left quadrant
 * is the crop halved, so that the prediction is close, as in a store. */
static int load_photo(int C)
{
    const char *data = getenv("TESTDATA") ? getenv("TESTDATA") : "tests/data";
    char path[512];
    snprintf(path, sizeof path, "%s/picos-1100x700.jpg", data);
    struct gv_image_info info;
    struct gv_error err = {0};
    struct gv_image_in *in = gv_image_open(path, 1u << 24, &info, &err);
    if (!in)
        return -1;
    uint8_t *img = malloc((size_t)info.width * info.height * info.channels);
    int ok = img && info.channels == 3 && info.width >= T && info.height >= T &&
             gv_image_read(in, info.height, img, &err) == 0;
    gv_image_close(in);
    if (!ok) {
        free(img);
        return -1;
    }
    for (int y = 0; y < T; y++)
        for (int x = 0; x < T; x++)
            for (int c = 0; c < C; c++)
                orig[((size_t)y * T + x) * C + c] =
                    img[((size_t)(y + 90) * info.width + x + 300) * 3 + (C == 1 ? 1 : c)];
    free(img);
    for (int y = 0; y < T; y++)
        for (int x = 0; x < T; x++)
            for (int c = 0; c < C; c++) {
                const int sx = 2 * (x < 256 ? x : 256), sy = 2 * (y < 256 ? y : 256);
                const int x1 = sx + 1 < T ? sx + 1 : sx, y1 = sy + 1 < T ? sy + 1 : sy;
                int s = orig[((size_t)sy * T + sx) * C + c] + orig[((size_t)sy * T + x1) * C + c] +
                        orig[((size_t)y1 * T + sx) * C + c] + orig[((size_t)y1 * T + x1) * C + c];
                parent[((size_t)y * T + x) * C + c] = (uint8_t)((s + 2) / 4);
            }
    return 0;
}

/* Tiles the encoder writes, synthetic and from a photograph, at several
 * prices; returns the length of the last (C = 3, photo) in buf. */
static size_t test_encoded(void)
{
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    static const double lambdas[] = {2, 10, 60};
    size_t len = 0;
    for (int photo = 0; photo < 2; photo++)
        for (int C = 1; C <= 3; C += 2)
            for (int i = 0; i < 3; i++) {
                if (photo) {
                    if (load_photo(C) < 0) {
                        fail("tests/data/picos-1100x700.jpg loads");
                        continue;
                    }
                } else {
                    make_tile(parent, C, 4);
                    make_tile(orig, C, 3 + 3 * i);
                }
                gv_predict(parent, C, photo ? 0 : 1, 0, pred);
                uint64_t sse;
                len = gv_dct_encode(ws, orig, pred, C, T, T, lambdas[i], buf,
                                    GV_TILEBUF_MAX, recon, &sse);
                int rc;
                /* same() decodes against quadrant (1, 0): predict that. */
                int ok = len > 0 && same(buf, len, C, &rc) && rc == 0;
                struct gv_error err = {0};
                gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
                ok = ok && gv_dct_decode(buf, len, C, parent, photo ? 0 : 1, 0,
                                         out1, &err) == 0 &&
                     !memcmp(out1, recon, (size_t)T * T * C);
                check(ok, "%s C=%d lambda %.0f (%zu bytes): the lanes give the "
                      "scalar rows' tile and the encoder's", photo ? "photo" : "synthetic",
                      C, lambdas[i], len);
            }
    gv_dct_workspace_free(ws);
    return len;
}

/* The models of a D or D2 buffer. */
static int models_of(const uint8_t *bb)
{
    return bb[0] == GV_TILE_DCT2 ? GV_DCT_MODELS_D2 : GV_DCT_MODELS;
}

/* The offsets of a D or D2 buffer's parts, as FORMAT.md 4.3 and 4.4 lay
 * them out. */
static size_t lengths_at(const uint8_t *bb, size_t model_size[GV_DCT_MODELS_D2])
{
    size_t at = 12;
    uint32_t mask = gv_get32(bb + 8);
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        model_size[m] = m < models_of(bb) && (mask >> m & 1)
                        ? (size_t)gv_dct_model_symbols(m) : 0;
        at += model_size[m];
    }
    return (at + 1) & ~(size_t)1;
}

/* buf without model m (its mask bit cleared), laid out again: the
 * streams then meet an absent model (frequency 0).  Returns its length. */
static size_t drop_model(const uint8_t *src, size_t len, int m, uint8_t *dst)
{
    size_t size[GV_DCT_MODELS_D2], at = 12, w = 12;
    const size_t lengths = lengths_at(src, size);
    memcpy(dst, src, 12);
    gv_put32(dst + 8, gv_get32(src + 8) & ~(1u << m));
    for (int i = 0; i < GV_DCT_MODELS_D2; i++) {
        if (i != m) {
            memcpy(dst + w, src + at, size[i]);
            w += size[i];
        }
        at += size[i];
    }
    if (w & 1)
        dst[w++] = 0;
    size_t words = 0;
    for (int i = 0; i < GV_DCT_BLOCKS; i++)
        words += gv_get16(src + lengths + 2 * i);
    const size_t n = 2 * GV_DCT_BLOCKS + 2 * words;
    (void)len;
    memcpy(dst + w, src + lengths, n);
    w += n;
    while (w & 3)
        dst[w++] = 0;
    return w;
}

static void test_damaged(const uint8_t *good, size_t len, int C)
{
    size_t size[GV_DCT_MODELS_D2];
    const size_t lengths = lengths_at(good, size);
    const size_t streams = lengths + 2 * GV_DCT_BLOCKS;
    int agree = 0, tries = 0, refused = 0, rc;
    /* A bit flipped every 97 bytes of the streams. */
    for (size_t k = streams; k < len; k += 97, tries++) {
        memcpy(b, good, len);
        b[k] ^= (uint8_t)(1u << (k % 8));
        agree += same(b, len, C, &rc);
        refused += rc < 0;
    }
    check(agree == tries && refused > tries / 2,
          "C=%d flipped stream bits: %d of %d agree (%d refused)", C, agree,
          tries, refused);
    /* A word moved from each stream to the next (truncated streams). */
    agree = tries = refused = 0;
    for (int i = 0; i + 1 < GV_DCT_BLOCKS; i++, tries++) {
        memcpy(b, good, len);
        gv_put16(b + lengths + 2 * i, gv_get16(good + lengths + 2 * i) - 1);
        gv_put16(b + lengths + 2 * i + 2, gv_get16(good + lengths + 2 * i + 2) + 1);
        agree += same(b, len, C, &rc);
        refused += rc < 0;
    }
    check(agree == tries && refused == tries,
          "C=%d stream lengths moved: %d of %d agree, %d refused", C, agree,
          tries, refused);
    /* Each model left out in turn. */
    agree = tries = refused = 0;
    for (int m = 0; m < GV_DCT_MODELS_D2; m++) {
        if (!size[m])
            continue;
        size_t n = drop_model(good, len, m, b);
        agree += same(b, n, C, &rc);
        refused += rc < 0;
        tries++;
    }
    check(tries > 0 && agree == tries && refused == tries,
          "C=%d models left out: %d of %d agree, %d refused", C, agree, tries,
          refused);
    /* Two streams damaged in one group, the later one earlier in its
     * stream: the message names the first, as the scalar rows do. */
    memcpy(b, good, len);
    size_t s5 = streams, s9;
    for (int i = 0; i < 5; i++)
        s5 += 2 * (size_t)gv_get16(good + lengths + 2 * i);
    s9 = s5;
    for (int i = 5; i < 9; i++)
        s9 += 2 * (size_t)gv_get16(good + lengths + 2 * i);
    const size_t e5 = s5 + 2 * (size_t)gv_get16(good + lengths + 10);
    b[e5 - 3] ^= 0x40;
    b[s9 + 5] ^= 0x40;
    struct gv_error err = {0};
    gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    int r = gv_dct_decode(b, len, C, parent, 1, 0, out1, &err);
    check(same(b, len, C, &rc) && r < 0 && strstr(err.text, "stream 5 ") != NULL,
          "C=%d streams 5 and 9 damaged: stream 5 named (%s)", C,
          r < 0 ? err.text : "decoded");
}

int main(void)
{
    gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    if (!gv_dct_lanes_usable()) {
        tap_skip("no AVX-512 VBMI on this CPU", "the rANS rows in lanes");
        return tap_done();
    }
    test_fixtures();
    size_t len = test_encoded();
    static uint8_t good[2u << 20];
    memcpy(good, buf, len);
    test_damaged(good, len, 3);
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    make_tile(parent, 1, 4);
    make_tile(orig, 1, 14);
    gv_predict(parent, 1, 1, 0, pred);
    uint64_t sse;
    len = gv_dct_encode(ws, orig, pred, 1, T, T, 6, good, GV_TILEBUF_MAX, recon, &sse);
    gv_dct_workspace_free(ws);
    test_damaged(good, len, 1);
    return tap_done();
}
