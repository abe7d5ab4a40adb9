/*
 * test_simd.c - every SIMD kernel under every CPU mask this machine
 * allows, against the portable C (in the spirit of dav1d's checkasm).
 *
 * Each kernel group is run through its public functions on random and
 * edge inputs (zeros, 255s, extreme codevectors and biases, lengths just
 * around the vector widths, steps of 4095, tiles with every coefficient
 * coded), first under GV_CPU_LEVEL_C, then under each mask in masks[];
 * every result is reduced to one 64-bit hash per case, and the hashes of
 * a mask must equal the portable ones case by case.  A mask whose flags
 * this CPU does not have is reported as skipped, by name, so a run shows
 * what it could not test here.  The inputs come from fixed seeds: every
 * run and every mask sees the same ones.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/sse.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_layout.h"
#include "codec/vq.h"
#include "encode/lambda_model.h"
#include "edt_cpu.h"
#include "dct_fixture.h"
#include "util.h"

#define MAXCASES 512
#define T GV_TILE

/* The masks to test, each against the portable C; needs: the flags that
 * make it differ from the mask before it (absent: not testable here). */
static const struct {
    const char *name;
    unsigned mask, needs;
} masks[] = {
    {"sse2+ssse3", GV_CPU_SSE2 | GV_CPU_SSSE3, GV_CPU_SSE2 | GV_CPU_SSSE3},
    {"avx2", GV_CPU_LEVEL_AVX2, GV_CPU_AVX2 | GV_CPU_FMA},
    {"avx512 without VBMI, VNNI",
     GV_CPU_LEVEL_AVX512 & ~(unsigned)(GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI),
     GV_CPU_AVX512},
    {"avx512 without VNNI", GV_CPU_LEVEL_AVX512 & ~(unsigned)GV_CPU_AVX512VNNI,
     GV_CPU_AVX512 | GV_CPU_AVX512VBMI},
    {"avx512", GV_CPU_LEVEL_AVX512,
     GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI},
};
#define NMASKS (sizeof masks / sizeof masks[0])

/* FNV-1a, 64 bits. */
static uint64_t hash(uint64_t h, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}
#define H0 0xcbf29ce484222325ull

/* Fill n bytes: kind 0 random, 1 all 0, 2 all 255, 3 alternating 0 and
 * 255, 4 a gradient. */
static void fill(uint8_t *p, size_t n, int kind, uint64_t *rng)
{
    for (size_t i = 0; i < n; i++)
        p[i] = kind == 0 ? (uint8_t)test_rand(rng) : kind == 1 ? 0 :
               kind == 2 ? 255 : kind == 3 ? (uint8_t)(i & 1 ? 255 : 0) :
               (uint8_t)(i * 7 / 13);
}

/* ------------------------------------------------------------- the groups */

/* gv_sse_u8: lengths around the 16-sample step, up to its limit of 2^15. */
static int run_sse(uint64_t *h)
{
    static const uint32_t ns[] = {0, 1, 15, 16, 17, 31, 32, 33, 100, 1539, 32768};
    static uint8_t a[3 * 32800], b[3 * 32800];
    uint64_t rng = 1;
    int c = 0;
    for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++)
        for (int kind = 0; kind < 4; kind++) {
            const size_t stride = ns[i] + 7;
            fill(a, sizeof a, kind == 3 ? 1 : 0, &rng);
            fill(b, sizeof b, kind == 3 ? 2 : kind, &rng);
            h[c++] = gv_sse_u8(a, b, ns[i], 3, stride);
            h[c++] = gv_sse_u8(a + 1, b + 3, ns[i], 1, stride);
        }
    return c;
}

/* gv_predict on parents of every kind, both channel counts and every
 * quadrant; gv_add_residual_row on random books and rows. */
static int run_predict(uint64_t *h)
{
    const size_t max = gv_tile_bytes(3);
    uint8_t *P = malloc(max), *out = malloc(max);
    int8_t *book = malloc(((size_t)1 << GV_MAX_RATE) * 12);
    uint16_t ids[GV_BLOCKS];
    uint8_t row[T * 3];
    uint64_t rng = 2;
    int c = 0;
    if (!P || !out || !book)
        fail("out of memory");
    for (int C = 1; C <= 3; C += 2)
        for (int kind = 0; kind < 5; kind++) {
            fill(P, gv_tile_bytes(C), kind, &rng);
            for (int q = 0; q < 4; q++) {
                gv_predict(P, C, q & 1, q >> 1, out);
                h[c++] = hash(H0, out, gv_tile_bytes(C));
            }
            /* rows out of order: the rings refill what they dropped */
            struct gv_predictor pr;
            gv_predictor_init(&pr, P, C, kind & 1, kind >> 1 & 1);
            uint64_t x = H0;
            for (int i = 0; i < 50; i++) {
                gv_predictor_row(&pr, (int)(test_rand(&rng) % T), row);
                x = hash(x, row, (size_t)T * C);
            }
            h[c++] = x;
        }
    for (int t = 0; t < 24; t++) {
        const int C = t & 1 ? 3 : 1, half = t >> 1 & 1;
        const uint32_t k = 1u << (1 + test_rand(&rng) % GV_MAX_RATE);
        fill((uint8_t *)book, (size_t)k * 12, t % 6 == 4 ? 2 : 0, &rng);
        for (int i = 0; i < GV_BLOCKS; i++)
            ids[i] = (uint16_t)(test_rand(&rng) % k);
        fill(row, sizeof row, t / 4 % 5, &rng);
        gv_add_residual_row(row, book, ids, C, half);
        h[c++] = hash(H0, row, (size_t)T * C);
    }
    free(P);
    free(out);
    free(book);
    return c;
}

/* Layout D decoded (the inverse transform, YCoCg-R and the addition, the
 * rANS rows in lanes, the prediction): the fixtures of dct_fixture.h,
 * escapes at both ends, steps of 4095, every coefficient coded, none. */
static int run_dct_decode(uint64_t *h)
{
    static int q[3 * 520 * 520];
    static uint8_t fb[2u << 20];
    const size_t max = gv_tile_bytes(3);
    uint8_t *P = malloc(max), *out = malloc(max);
    uint64_t seed = 11, rng = 3;
    int c = 0;
    if (!P || !out)
        fail("out of memory");
    for (int C = 1; C <= 3; C += 2)
        for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
            int S[3];
            struct gv_error err = {0};
            dct_fixture_case(k, C, &seed, q, S);
            const size_t len = dct_fixture_write(q, S, C, fb);
            fill(P, gv_tile_bytes(C), k, &rng);
            const int rc = gv_dct_decode(fb, len, C, P, k & 1, 1, out, &err);
            h[c++] = rc == 0 ? hash(H0, out, gv_tile_bytes(C)) : (uint64_t)rc;
        }
    free(P);
    free(out);
    return c;
}

/* Layout D encoded (the forward transform, quantization and the step
 * search, the squared errors) and decoded again. */
static int run_dct_encode(uint64_t *h)
{
    static const double lambdas[] = {8.0, 40.0, 900.0};
    static uint8_t buf[GV_TILEBUF_MAX];
    const size_t max = gv_tile_bytes(3);
    uint8_t *P = malloc(max), *orig = malloc(max), *pred = malloc(max);
    uint8_t *recon = malloc(max), *out = malloc(max);
    struct gv_dct_workspace *ws = gv_dct_workspace_new();
    uint64_t rng = 4;
    int c = 0;
    if (!P || !orig || !pred || !recon || !out || !ws)
        fail("out of memory");
    for (int C = 1; C <= 3; C += 2)
        for (int i = 0; i < 4; i++) {
            dct_fixture_tile(P, T, C, 20, &rng);
            dct_fixture_tile(orig, T, C, 40 * (i % 3), &rng);
            gv_predict(P, C, 1, 0, pred);
            if (i == 3) {
                /* The edge: 0/255 blocks against their complement, at a
                 * lambda that takes step 1, so that the coefficients pass
                 * the quantizer's cap of 2047 (YCoCg's Co reaches 510). */
                for (size_t k = 0; k < gv_tile_bytes(C); k++) {
                    const size_t px = k / (size_t)C, x = px % T, y = px / T;
                    const int on = ((x / 8 + y / 8) & 1) ^ (int)(k % (size_t)C == 2);
                    orig[k] = on ? 255 : 0;
                    pred[k] = on ? 0 : 255;
                }
            }
            /* the whole tile, and a part of it (an image's edge) */
            for (int part = 0; part < 2; part++) {
                const uint32_t vw = part ? 300 : T, vh = part ? 77 : T;
                uint64_t sse = 0;
                const size_t len = gv_dct_encode(ws, orig, pred, C, vw, vh,
                                                 i < 3 ? lambdas[i] : 0.01,
                                                 buf, sizeof buf,
                                                 recon, &sse);
                /* 0: it does not fit (recon and sse are then undefined) */
                uint64_t x = hash(H0, &len, sizeof len);
                if (len) {
                    x = hash(hash(x, buf, len), recon, gv_tile_bytes(C));
                    x = hash(x, &sse, sizeof sse);
                }
                h[c++] = x;
                struct gv_error err = {0};
                const int rc = len ? gv_dct_decode(buf, len, C, P, 1, 0, out, &err) : -2;
                h[c++] = rc == 0 ? hash(H0, out, gv_tile_bytes(C)) : (uint64_t)rc;
            }
        }
    gv_dct_workspace_free(ws);
    free(P);
    free(orig);
    free(pred);
    free(recon);
    free(out);
    return c;
}

/* vq_nearest and vq_nearest_warm: codebook sizes on both sides of the
 * small-codebook kernel (32) and of a run (16), duplicated codevectors
 * (ties), books of three distinct codevectors repeated (ties between runs
 * in the same lane), biases at 0, VQ_BIAS_MAX and beyond, residuals at
 * +-255. */
static int run_vq(uint64_t *h)
{
    static const int ks[] = {1, 5, 16, 17, 32, 33, 256, 1000};
    struct vq_search *s = malloc(sizeof *s);
    int8_t *book = malloc(1000 * VQ_MAXDIM);
    int32_t *bias = malloc(1000 * sizeof *bias);
    const size_t n = 200;
    int16_t *vecs = calloc(n * VQ_STRIDE, sizeof *vecs);
    uint16_t *idx = malloc(n * sizeof *idx);
    uint32_t *dist = malloc(n * sizeof *dist);
    uint64_t rng = 5;
    int c = 0;
    if (!s || !book || !bias || !vecs || !idx || !dist)
        fail("out of memory");
    for (int clustered = 0; clustered < 3; clustered++)
        for (int dim = 4; dim <= 12; dim += 8)
            for (size_t ki = 0; ki < sizeof ks / sizeof ks[0]; ki++) {
                const int k = ks[ki];
                for (int i = 0; i < k * dim; i++) {
                    const uint32_t r = test_rand(&rng);
                    book[i] = (int8_t)(r % 16 == 0 ? -128 : r % 16 == 1 ? 127 : (int)(r >> 8) % 256 - 128);
                }
                for (int j = 0; j < k; j++) {
                    const uint32_t r = test_rand(&rng) % 8;
                    bias[j] = r == 0 ? 0 : r == 1 ? VQ_BIAS_MAX : r == 2 ? INT32_MAX :
                              r == 3 ? -5 : (int32_t)(test_rand(&rng) % 200000);
                }
                for (int j = 1; j < k; j += 3) {
                    memcpy(book + j * dim, book + (j - 1) * dim, (size_t)dim);
                    bias[j] = bias[j - 1];
                }
                for (int j = 3; clustered == 2 && j < k; j++) {
                    memcpy(book + j * dim, book + j % 3 * dim, (size_t)dim);
                    bias[j] = bias[j % 3];
                }
                for (size_t i = 0; i < n; i++) {
                    const int j = (int)(test_rand(&rng) % (uint32_t)k);
                    for (int d = 0; d < dim; d++) {
                        const uint32_t r = test_rand(&rng) % 16;
                        vecs[i * VQ_STRIDE + d] = (int16_t)(
                            clustered == 1 ? book[j * dim + d] + (int)(test_rand(&rng) % 7) - 3 :
                            r == 0 ? 255 : r == 1 ? -255 : (int)(test_rand(&rng) % 161) - 80);
                    }
                }
                vq_search_prepare(s, book, k, dim);
                vq_search_set_bias(s, ki % 3 == 2 ? NULL : bias);
                vq_nearest(s, vecs, n, idx, dist);
                h[c++] = hash(hash(H0, idx, n * sizeof *idx), dist, n * sizeof *dist);
                for (size_t i = 0; i < n; i++)   /* guesses: answers or random */
                    idx[i] = i % 2 ? idx[i] : (uint16_t)(test_rand(&rng) % (uint32_t)k);
                vq_nearest_warm(s, vecs, n, idx, dist);
                h[c++] = hash(hash(H0, idx, n * sizeof *idx), dist, n * sizeof *dist);
            }
    free(s);
    free(book);
    free(bias);
    free(vecs);
    free(idx);
    free(dist);
    return c;
}

/* The lambda model's histogram (its RGB rows split by SSSE3), widths
 * around the four-block step. */
static int run_lambda_model(uint64_t *h)
{
    static const uint32_t widths[] = {1, 2, 7, 8, 9, 16, 17, 101, 1000};
    static uint8_t r0[3 * 1000], r1[3 * 1000], red[3 * 500];
    uint64_t rng = 6;
    int c = 0;
    for (size_t wi = 0; wi < sizeof widths / sizeof widths[0]; wi++)
        for (int C = 1; C <= 3; C += 2) {
            const uint32_t w = widths[wi];
            struct gv_lambda_model m;
            if (gv_lambda_model_init(&m, w, C) < 0)
                fail("out of memory");
            for (int y = 0; y < 9; y++) {
                fill(r0, (size_t)w * C, y % 5, &rng);
                fill(r1, (size_t)w * C, (y + 1) % 5, &rng);
                fill(red, (size_t)(w + 1) / 2 * C, 0, &rng);
                gv_lambda_model_rows(&m, r0, r1, red);
            }
            gv_lambda_model_finish(&m);
            uint64_t x = hash(H0, m.count, sizeof m.count);
            x = hash(x, m.sum, sizeof m.sum);
            h[c++] = hash(x, &m.blocks, sizeof m.blocks);
            gv_lambda_model_free(&m);
        }
    return c;
}

/* The CPU distance transform's line kernels (filters/edt_kernel.h). */
static int run_edt(uint64_t *h)
{
    static const uint32_t sizes[][2] = {{1, 1}, {17, 5}, {64, 64}, {130, 70}, {301, 203}};
    uint64_t rng = 7;
    int c = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (int density = 1; density <= 64; density *= 8) {
            const uint32_t w = sizes[i][0], hh = sizes[i][1];
            const size_t n = (size_t)w * hh;
            uint32_t *ids = calloc(n, sizeof *ids), *sid = malloc(n * sizeof *sid);
            int32_t *sx = malloc(n * sizeof *sx), *sy = malloc(n * sizeof *sy);
            float *dist = malloc(n * sizeof *dist);
            if (!ids || !sid || !sx || !sy || !dist)
                fail("out of memory");
            for (size_t p = 0; p < n; p++)
                ids[p] = test_rand(&rng) % (uint32_t)(density * 16) == 0 ? 1 + p % 5 : 0;
            struct gv_edt_out out = {sx, sy, sid, dist};
            struct gv_error err = {0};
            const int rc = gv_edt_cpu(ids, w, hh, 1, &out, &err);
            uint64_t x = hash(H0, &rc, sizeof rc);
            if (rc == 0) {
                x = hash(x, sx, n * sizeof *sx);
                x = hash(x, sy, n * sizeof *sy);
                x = hash(x, sid, n * sizeof *sid);
                x = hash(x, dist, n * sizeof *dist);
            }
            h[c++] = x;
            free(ids);
            free(sid);
            free(sx);
            free(sy);
            free(dist);
        }
    return c;
}

static const struct {
    const char *name;
    int (*run)(uint64_t *h);
} groups[] = {
    {"sse (gv_sse_u8)", run_sse},
    {"prediction and residual rows", run_predict},
    {"layout D decode (pixels, rANS lanes)", run_dct_decode},
    {"layout D encode (transform, quantization)", run_dct_encode},
    {"VQ search", run_vq},
    {"lambda model rows", run_lambda_model},
    {"distance transform lines", run_edt},
};
#define NGROUPS (sizeof groups / sizeof groups[0])

int main(void)
{
    static uint64_t want[MAXCASES], got[MAXCASES];
    const unsigned raw = gv_cpu_flags_raw();
    printf("# CPU flags 0x%x, GIGAVIEW_SIMD's 0x%x\n", raw, gv_cpu_flags());
    int testable[NMASKS], ntestable = 0;
    for (size_t m = 0; m < NMASKS; m++) {
        testable[m] = (raw & masks[m].needs) == masks[m].needs;
        ntestable += testable[m];
        if (!testable[m])
            tap_skip("this CPU lacks its flags", "mask %s", masks[m].name);
    }
    for (size_t g = 0; g < NGROUPS; g++) {
        gv_cpu_set_mask(GV_CPU_LEVEL_C);
        const int n = groups[g].run(want);
        if (n > MAXCASES)
            fail("%s: %d cases, room for %d", groups[g].name, n, MAXCASES);
        for (size_t m = 0; m < NMASKS; m++) {
            if (!testable[m])
                continue;
            gv_cpu_set_mask(masks[m].mask);
            const int n2 = groups[g].run(got);
            int first = -1, bad = 0;
            for (int i = 0; i < n && i < n2; i++)
                if (got[i] != want[i]) {
                    bad++;
                    first = first < 0 ? i : first;
                }
            check(n2 == n && bad == 0, "%s, mask %s: %d cases as the portable C "
                  "(%d differ, the first: case %d)", groups[g].name,
                  masks[m].name, n, bad, first);
        }
    }
    gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    printf("# %d of %zu masks tested on this CPU\n", ntestable, NMASKS);
    return tap_done();
}
