/*
 * test_tile_dct.c - layout D (docs/FORMAT.md 4.3): the inverse transform
 * against the formula written out independently, the encoder against the
 * decoder, the coefficient plane (what GPU decoders read) against the
 * decoded pixels, the SIMD pixel path against the portable one, the
 * choice between D and VQ by cost, and hostile buffers.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_dct_pixels.h"
#include "codec/tile_layout.h"
#include "dct_fixture.h"
#include "util.h"

#define T GV_TILE
#define P GV_DCT_PLANE

static uint64_t rng = 0x9e3779b97f4a7c15ull;

/* floor(a / 2^s) without shifting a negative number. */
static long long floor_div(long long a, int s)
{
    long long d = 1ll << s;
    return a >= 0 ? a / d : -((-a + d - 1) / d);
}

/* FORMAT.md 4.3 written out: t[v] then e, with the matrix typed in
 * again here (not gv_dct_matrix). */
static void reference_inverse(const int16_t *d, long long *e)
{
    static const int K[8][8] = {
        {64, 64, 64, 64, 64, 64, 64, 64},
        {89, 75, 50, 18, -18, -50, -75, -89},
        {83, 36, -36, -83, -83, -36, 36, 83},
        {75, -18, -89, -50, 50, 89, 18, -75},
        {64, -64, -64, 64, 64, -64, -64, 64},
        {50, -89, 18, 75, -75, -18, 89, -50},
        {36, -83, 83, -36, -36, 83, -83, 36},
        {18, -50, 75, -89, 89, -75, 50, -18},
    };
    for (int j = 0; j < 8; j++)
        for (int i = 0; i < 8; i++) {
            long long s2 = 1024;
            for (int v = 0; v < 8; v++) {
                long long s1 = 64;
                for (int u = 0; u < 8; u++)
                    s1 += (long long)K[u][i] * d[8 * v + u];
                s2 += (long long)K[v][j] * floor_div(s1, 7);
            }
            e[8 * j + i] = floor_div(s2, 11);
        }
}

static void test_inverse(void)
{
    int bad = 0;
    for (int n = 0; n < 2000 && !bad; n++) {
        int16_t d[64];
        for (int k = 0; k < 64; k++) {
            uint32_t r = test_rand(&rng);
            /* mostly sparse, some full-range */
            d[k] = (int16_t)(r % 4 == 0 ? (int)(r >> 8) % 65536 - 32768
                             : (r % 4 == 1 ? (int)(r >> 8) % 201 - 100 : 0));
        }
        int32_t e[64];
        long long want[64];
        gv_dct_inverse(d, e);
        reference_inverse(d, want);
        for (int k = 0; k < 64; k++)
            bad += e[k] != want[k];
    }
    check(!bad, "inverse transform = FORMAT.md 4.3 on 2000 random blocks "
          "(%d samples differ)", bad);
    /* The matrix is near-orthogonal: a lone coefficient of 8 * c gives a
     * basis function of amplitude about c. */
    int16_t d[64] = {0};
    int32_t e[64];
    d[0] = 8 * 50;
    gv_dct_inverse(d, e);
    check(e[0] == 6 && e[63] == 6, "DC of 400 gives a flat 6.25 -> 6 "
          "(got %d, %d)", e[0], e[63]);
}

/* A textured tile, C channels: noise over gradients, with an edge. */
static void make_tile(uint8_t *t, int C, int amp)
{
    dct_fixture_tile(t, T, C, amp, &rng);
}

static uint8_t orig[T * T * 3], parent[T * T * 3], pred[T * T * 3],
    recon[T * T * 3], out[T * T * 3], buf[GV_TILEBUF_MAX];
static int16_t plane[P * P * 4];

static inline int asr(int a, int s)
{
    return (int)floor_div(a, s);
}

/* Rebuild the tile from the coefficient plane, as a GPU does: per pixel,
 * the inverse of its block, the colour transform, the prediction. */
static int from_plane(int C, const uint8_t *prediction, uint8_t *px)
{
    int bad = 0;
    for (int by = 0; by < GV_DCT_BLOCKS; by++)
        for (int bx = 0; bx < GV_DCT_BLOCKS; bx++) {
            int32_t e[3][64];
            for (int c = 0; c < C; c++) {
                int16_t d[64];
                for (int v = 0; v < 8; v++)
                    for (int u = 0; u < 8; u++)
                        d[8 * v + u] = plane[4 * ((size_t)(8 * by + v) * P + 8 * bx + u) + c];
                gv_dct_inverse(d, e[c]);
            }
            for (int j = 0; j < 8; j++)
                for (int i = 0; i < 8; i++) {
                    int x = 8 * bx + i, y = 8 * by + j;
                    if (x >= T || y >= T)
                        continue;
                    int res[3];
                    if (C == 1) {
                        res[0] = e[0][8 * j + i];
                    } else {
                        int Y = e[0][8 * j + i], co = e[1][8 * j + i], cg = e[2][8 * j + i];
                        int t = Y - asr(cg, 1);
                        res[1] = cg + t;
                        res[2] = t - asr(co, 1);
                        res[0] = res[2] + co;
                    }
                    for (int c = 0; c < C; c++) {
                        size_t at = ((size_t)y * T + x) * C + c;
                        int v = prediction[at] + res[c];
                        v = v < 0 ? 0 : v > 255 ? 255 : v;
                        px[at] = (uint8_t)v;
                    }
                }
        }
    for (size_t k = 0; k < (size_t)T * T * C; k++)
        bad += px[k] != out[k];
    return bad;
}

static void test_round_trip(int C, int amp, double lambda, uint32_t vw,
                            uint32_t vh, int gray_rgb)
{
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    struct gv_error err = {0};
    make_tile(parent, C, 4);
    make_tile(orig, C, amp);
    if (gray_rgb) {
        /* R = G = B: chroma residuals vanish, only Y is coded (the
         * decoder's shortcut for blocks without chroma). */
        for (size_t k = 0; k < (size_t)T * T; k++)
            parent[3 * k + 1] = parent[3 * k + 2] = parent[3 * k],
            orig[3 * k + 1] = orig[3 * k + 2] = orig[3 * k];
    }
    gv_predict(parent, C, 1, 0, pred);
    uint64_t sse = 0;
    size_t len = gv_dct_encode(ws, orig, pred, C, vw, vh, lambda,
                               buf, GV_TILEBUF_MAX, recon, &sse);
    check(len > 0 && len % 4 == 0 && gv_tile_is_dct(buf[0]),
          "C=%d amp %d lambda %.0f %ux%u: a D buffer of %zu bytes", C, amp,
          lambda, vw, vh, len);
    check(gv_tilebuf_check(buf, len, C, &err) == 0, "it passes the check");
    int rc = gv_tile_decode(buf, len, C, parent, 1, 0, out, &err);
    check(rc == 0 && !memcmp(out, recon, (size_t)T * T * C),
          "gv_tile_decode gives the encoder's reconstruction");
    uint64_t e = 0, n = 0;
    for (uint32_t y = 0; y < vh; y++)
        for (uint32_t x = 0; x < vw * (uint32_t)C; x++) {
            int d = orig[(size_t)y * T * C + x] - out[(size_t)y * T * C + x];
            e += (uint64_t)(d * d);
            n++;
        }
    check(e == sse, "the reported error is exact (%llu)", (unsigned long long)e);
    check(gv_dct_unpack(buf, len, C, plane, &err) == 0, "the streams unpack");
    static uint8_t px[T * T * 3];
    check(from_plane(C, pred, px) == 0, "the coefficient plane rebuilds the "
          "tile pixel by pixel, as a GPU does");
    /* Noise of amplitude a has a mean squared error of about a^2 / 3; the
     * coder must remove most of it at these prices. */
    double mse = (double)e / (double)n, noise = amp * (amp + 1) / 3.0;
    check(mse < noise / 2, "mse %.2f is well under the residual's %.1f", mse, noise);
    gv_dct_workspace_free(ws);
}

/* More bits for a lower price, fewer for a higher one. */
static void test_lambda_order(void)
{
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    make_tile(parent, 3, 4);
    make_tile(orig, 3, 10);
    gv_predict(parent, 3, 0, 1, pred);
    uint64_t s1, s2;
    size_t l1 = gv_dct_encode(ws, orig, pred, 3, T, T, 15,
                              buf, GV_TILEBUF_MAX, recon, &s1);
    size_t l2 = gv_dct_encode(ws, orig, pred, 3, T, T, 80,
                              buf, GV_TILEBUF_MAX, recon, &s2);
    check(l1 > l2 && s1 < s2, "lambda 15: %zu bytes, sse %llu; lambda 80: "
          "%zu bytes, sse %llu", l1, (unsigned long long)s1, l2,
          (unsigned long long)s2);
    check(gv_dct_encode(ws, orig, pred, 3, T, T, 5, buf, 64,
                        recon, &s1) == 0, "a cap too small gives 0");
    gv_dct_workspace_free(ws);
}

/* The tile encoder keeps D only when it costs less, and only if asked. */
static void test_choice(void)
{
    struct gv_tile_workspace *ws = gv_tile_workspace_new();
    struct gv_error err = {0};
    make_tile(parent, 3, 3);
    make_tile(orig, 3, 6);
    struct gv_tile_params p = {.target_mse = gv_psnr_to_mse(40), .max_rate = 10,
                               .lambda = 20, .seed = 7};
    struct gv_tile_stats st;
    size_t vq = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &p, recon, buf, &st);
    check(!gv_tile_is_dct(buf[0]) && st.rate <= GV_MAX_RATE,
          "without .dct the buffer is VQ (rate %d, %zu bytes)", st.rate, vq);
    double jvq = (double)st.sse + 20 * 8.0 * (double)vq;
    p.dct = 1;
    size_t d = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &p, recon, buf, &st);
    double jd = (double)st.sse + 20 * 8.0 * (double)d;
    check(jd <= jvq, "with .dct the cost is no higher (%.0f vs %.0f)", jd, jvq);
    check(gv_tile_is_dct(buf[0]) && st.rate == GV_RATE_DCT,
          "noise is cheaper as a transform (%zu bytes against %zu)", d, vq);
    check(gv_tile_decode(buf, d, 3, parent, 0, 0, out, &err) == 0 &&
          !memcmp(out, recon, sizeof out), "and decodes to its reconstruction");
    /* D and the prediction alone, no VQ search (the default layouts). */
    p.dct = GV_LAYOUTS_D;
    make_tile(orig, 3, 6);
    d = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &p, recon, buf, &st);
    check(gv_tile_is_dct(buf[0]) && st.rate == GV_RATE_DCT &&
          gv_tile_decode(buf, d, 3, parent, 0, 0, out, &err) == 0 &&
          !memcmp(out, recon, sizeof out), "layouts D: a D buffer, decoded "
          "to its reconstruction (%zu bytes)", d);
    /* Noise of +-40 at a price this low needs more than GV_TILEBUF_MAX
     * in D: the VQ search codes it instead of the prediction alone. */
    make_tile(orig, 3, 40);
    struct gv_tile_params fine = p;
    fine.lambda = 0.5;
    d = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &fine, recon, buf, &st);
    check(!gv_tile_is_dct(buf[0]) && st.rate >= 1 && st.rate <= GV_MAX_RATE &&
          gv_tile_decode(buf, d, 3, parent, 0, 0, out, &err) == 0 &&
          !memcmp(out, recon, sizeof out), "layouts D, too fine for D: VQ "
          "at rate %d (%zu bytes), decoded to its reconstruction", st.rate, d);
    p.dct = GV_LAYOUTS_ALL;
    /* A smooth tile the prediction already gets: nothing to code. */
    memcpy(orig, parent, sizeof orig);
    gv_predict(parent, 3, 0, 0, orig);
    d = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &p, recon, buf, &st);
    check(st.rate == 0 && d == 4, "a predicted tile stays rate 0 (%d, %zu)",
          st.rate, d);
    gv_tile_workspace_free(ws);
}

static void expect_refused(const uint8_t *b, size_t len, int C, const char *what)
{
    struct gv_error err = {0};
    int c1 = gv_tilebuf_check(b, len, C, &err);
    int c2 = gv_tile_decode(b, len, C, parent, 0, 0, out, &err);
    int c3 = gv_dct_unpack(b, len, C, plane, &err);
    check(c2 < 0 && c3 < 0 && err.code == GV_ECORRUPT,
          "%s: refused (check %d, decode %d, unpack %d: %s)", what, c1, c2, c3,
          err.text);
}

static void test_hostile(void)
{
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    make_tile(parent, 3, 4);
    make_tile(orig, 3, 10);
    gv_predict(parent, 3, 0, 0, pred);
    uint64_t sse;
    size_t len = gv_dct_encode(ws, orig, pred, 3, T, T, 10, buf,
                               GV_TILEBUF_MAX, recon, &sse);
    static uint8_t b[GV_TILEBUF_MAX];
#define MUTATE(stmt, what)                                                    \
    do {                                                                      \
        memcpy(b, buf, len);                                                  \
        size_t n = len;                                                       \
        stmt;                                                                 \
        expect_refused(b, n, 3, what);                                        \
    } while (0)
    MUTATE(b[1] = 1, "byte 1 set");
    MUTATE(gv_put16(b + 2, 0), "step 0");
    MUTATE(gv_put16(b + 4, 4096), "step 4096");
    /* The buffer is layout D2, whose last-value models are bits 30 and
     * 31 of the mask: named layout D, it has models D does not know. */
    check(buf[0] == GV_TILE_DCT2 && gv_get32(buf + 8) >> 30,
          "the encoder writes layout D2 with last-value models");
    MUTATE(b[0] = GV_TILE_DCT, "mask bit 30 or 31 in layout D");
    MUTATE(b[0] = GV_TILE_DCT2 + 1, "byte 0 past layout D2");
    MUTATE(b[12] = 5, "a model not starting at 0");
    MUTATE(b[13] = 200; b[14] = 100, "a decreasing model");
    MUTATE(n = len - 4, "four bytes short");
    MUTATE(n = len + 4; memset(b + len, 0, 4), "four bytes long");
    MUTATE(n = 11, "shorter than the header");
    MUTATE(n = len - 2, "not a multiple of 4");
    /* Streams: every length moved by one word between two streams. */
    size_t at = 12;
    uint32_t mask = gv_get32(buf + 8);
    for (int m = 0; m < GV_DCT_MODELS_D2; m++)
        if (mask >> m & 1)
            at += m < GV_DCT_EOB_MODELS ? 65 : 16;
    at = (at + 1) & ~(size_t)1;
    MUTATE(gv_put16(b + at, gv_get16(b + at) + 1);
           gv_put16(b + at + 2, gv_get16(b + at + 2) - 1), "stream lengths shifted");
    MUTATE(gv_put16(b + at + 20, 1), "a stream of one word");
    /* Streams 2 and 3 damaged, 3 near its start and 2 near its end: the
     * decoder reads them in lockstep, yet names stream 2, the first in
     * stream order, as decoding one stream at a time does. */
    {
        size_t s2 = at + 2 * GV_DCT_BLOCKS;
        s2 += 2 * (size_t)(gv_get16(buf + at) + gv_get16(buf + at + 2));
        const size_t s3 = s2 + 2 * (size_t)gv_get16(buf + at + 4);
        memcpy(b, buf, len);
        b[s3 - 3] ^= 0x40;
        b[s3 + 5] ^= 0x40;
        struct gv_error err = {0};
        int rc = gv_tile_decode(b, len, 3, parent, 0, 0, out, &err);
        check(rc < 0 && strstr(err.text, "stream 2 ") != NULL,
              "two damaged streams of a pair: the first named (%s)", err.text);
        rc = gv_dct_unpack(b, len, 3, plane, &err);
        check(rc < 0 && strstr(err.text, "stream 2 ") != NULL,
              "and by the unpacking too (%s)", err.text);
    }
    /* Clearing a model the streams use. */
    int used = -1;
    for (int m = GV_DCT_MODELS_D2 - 1; m >= 0 && used < 0; m--)
        if (mask >> m & 1)
            used = m;
    (void)used;
    /* Damage inside the streams: any flipped bit must be refused or decode
     * to something (never crash); most are refused. */
    int refused = 0, tries = 0;
    for (size_t k = at + 2 * GV_DCT_BLOCKS; k < len - 4; k += 499, tries++) {
        memcpy(b, buf, len);
        b[k] ^= 0x10;
        struct gv_error err = {0};
        int r1 = gv_tile_decode(b, len, 3, parent, 0, 0, out, &err);
        int r2 = gv_dct_unpack(b, len, 3, plane, &err);
        if (r1 != r2) {
            refused = -1000000;
            break;
        }
        refused += r1 < 0;
    }
    check(refused >= tries * 9 / 10, "flipped stream bits: %d of %d refused, "
          "unpack and decode agree", refused, tries);
    gv_dct_workspace_free(ws);
}

/* The AVX2 pixel path and the portable one give the same tile, and the
 * pixel-by-pixel rebuild's, on the fixtures of tests/dct_fixture.h:
 * escapes at both ends of their range, products clamped to 16 bits
 * (steps of 4095: first passes that leave the 16-bit range, which the
 * AVX2 path hands to the portable one), every coefficient of every block
 * coded, none at all. */
static void test_simd_paths(void)
{
    static int q[3 * P * P];
    static uint8_t fb[2u << 20];
    uint64_t seed = 11;
    if (!(gv_cpu_set_mask(GV_CPU_LEVEL_MAX) & GV_CPU_AVX2)) {
        tap_skip("no AVX2 on this CPU", "the AVX2 pixel path against the portable one");
        return;
    }
    for (int C = 1; C <= 3; C += 2) {
        make_tile(parent, C, 40);
        gv_predict(parent, C, 0, 1, pred);
        for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
            int S[3];
            struct gv_error err = {0};
            dct_fixture_case(k, C, &seed, q, S);
            size_t len = dct_fixture_write(q, S, C, fb);
            gv_cpu_set_mask(GV_CPU_LEVEL_C);
            int rc0 = gv_dct_decode(fb, len, C, parent, 0, 1, recon, &err);
            gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
            int rc1 = gv_dct_decode(fb, len, C, parent, 0, 1, out, &err);
            check(rc0 == 0 && rc1 == 0 &&
                  !memcmp(out, recon, (size_t)T * T * C),
                  "C=%d fixture %d: the AVX2 and portable pixel paths agree", C, k);
            check(gv_dct_unpack(fb, len, C, plane, &err) == 0 &&
                  from_plane(C, pred, recon) == 0,
                  "C=%d fixture %d: and equal the pixel-by-pixel rebuild", C, k);
        }
    }
}

int main(void)
{
    test_inverse();
    test_round_trip(3, 12, 10, T, T, 0);
    test_round_trip(3, 20, 60, T, T, 0);
    test_round_trip(1, 12, 4, T, T, 0);
    test_round_trip(3, 12, 10, 200, 77, 0);   /* a tile at the image's corner */
    test_round_trip(1, 20, 10, 1, 513, 0);
    test_round_trip(3, 12, 10, T, T, 1);
    test_lambda_order();
    test_choice();
    test_hostile();
    test_simd_paths();
    return tap_done();
}
