/*
 * dct_fixture.h - layout-D tile buffers (docs/FORMAT.md section 4.3) made
 * from given quantized coefficients, written from the format's text and
 * nothing of lib/codec, so that a test can feed decoders the buffers an
 * encoder rarely writes: escapes at both ends of their range, products
 * clamped to 16 bits, steps of 4095, every coefficient of every block
 * coded.  The models are the symbols' own counts scaled to 256 (the last
 * symbol of each kept at 1 or more, since cum[] holds bytes); the streams
 * are rANS-coded backwards as in Duda's "Asymmetric numeral systems"
 * (2013), section 3.
 */
#ifndef GV_TESTS_DCT_FIXTURE_H
#define GV_TESTS_DCT_FIXTURE_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "util.h"

/* JPEG's zigzag order: 8 v + u of coefficient k. */
static const int dct_fixture_zz[64] = {
     0,  1,  8, 16,  9,  2,  3, 10, 17, 24, 32, 25, 18, 11,  4,  5,
    12, 19, 26, 33, 40, 48, 41, 34, 27, 20, 13,  6,  7, 14, 21, 28,
    35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51,
    58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63};

static inline int dct_fixture_class(int q)
{
    q = abs(q);
    return q > 2 ? 2 : q;
}

/* One coded symbol: its model m (< 30), or 255 for a uniform 6-bit step. */
struct dct_fixture_sym {
    uint8_t model, s;
};

/* cum[0..k) of the counts cnt[0..k) scaled to a total of 256, every
 * counted symbol and the last one with a frequency of 1 or more. */
static inline void dct_fixture_model(const long *cnt, int k, uint8_t *cum)
{
    long total = 0;
    int f[65], sum = 0;
    for (int s = 0; s < k; s++)
        total += cnt[s];
    for (int s = 0; s < k; s++) {
        f[s] = (int)(cnt[s] * 256 / total);
        if (f[s] == 0 && (cnt[s] || s == k - 1))
            f[s] = 1;
        sum += f[s];
    }
    while (sum != 256) {
        int big = 0;
        for (int s = 1; s < k; s++)
            if (f[s] > f[big])
                big = s;
        f[big] += sum > 256 ? -1 : 1;
        sum += sum > 256 ? -1 : 1;
    }
    for (int s = 0, c = 0; s < k; c += f[s], s++)
        cum[s] = (uint8_t)c;
}

/*
 * Write the layout-D buffer of the quantized coefficients q (channel c's
 * 520x520 plane at q + c * 520 * 520, coefficient (v,u) of block (bx,by)
 * at X = 8 bx + u, Y = 8 by + v; each in -2048..2047) with quantizer steps
 * S[c] to out (room for 2 MiB).  Returns its length in bytes.
 */
static inline size_t dct_fixture_write(const int *q, const int S[3], int channels,
                                       uint8_t *out)
{
    const size_t cap = (size_t)65 * 65 * 3 * (1 + 64 * 3);
    struct dct_fixture_sym *sym = malloc(cap * sizeof *sym);
    uint16_t *words = malloc(sizeof *words * 65536);
    size_t first[66], n = 0;
    long cnt[30][65];
    memset(cnt, 0, sizeof cnt);
    if (!sym || !words)
        fail("dct fixture: out of memory");
    /* The symbols of each stream, in decoding order, and their counts. */
    for (int by = 0; by < 65; by++) {
        first[by] = n;
        int pe[3] = {0, 0, 0}, dcp[3] = {0, 0, 0};
        for (int bx = 0; bx < 65; bx++)
            for (int c = 0; c < channels; c++) {
                const int cc = c ? 1 : 0;
                int zz[64], last = 0;
                for (int k = 0; k < 64; k++) {
                    const int z = dct_fixture_zz[k];
                    zz[k] = q[(size_t)c * 520 * 520 + (size_t)(8 * by + z / 8) * 520 +
                              8 * bx + z % 8];
                    if (zz[k])
                        last = k + 1;
                }
                const int m = 3 * cc + pe[c];
                cnt[m][last]++;
                sym[n++] = (struct dct_fixture_sym){(uint8_t)m, (uint8_t)last};
                for (int k = 0; k < last; k++) {
                    const int band = k == 0 ? 0 : k <= 2 ? 1 : k <= 9 ? 2 : 3;
                    const int p = k == 0 ? dcp[c] : dct_fixture_class(zz[k - 1]);
                    const int tm = 6 + 3 * (4 * cc + band) + p, v = zz[k];
                    const int t = v == 0 ? 0 : v > 0 && v <= 7 ? 2 * v - 1 :
                                  v < 0 && v >= -7 ? -2 * v : 15;
                    cnt[tm][t]++;
                    sym[n++] = (struct dct_fixture_sym){(uint8_t)tm, (uint8_t)t};
                    if (t == 15) {
                        sym[n++] = (struct dct_fixture_sym){255, (uint8_t)((v + 2048) >> 6)};
                        sym[n++] = (struct dct_fixture_sym){255, (uint8_t)((v + 2048) & 63)};
                    }
                }
                pe[c] = last == 0 ? 0 : last <= 4 ? 1 : 2;
                dcp[c] = last == 0 ? 0 : dct_fixture_class(zz[0]);
            }
    }
    first[65] = n;
    /* Header and the models that are used. */
    memset(out, 0, 12);
    out[0] = 0x20;
    for (int c = 0; c < 3; c++) {
        const int s = c < channels ? S[c] : 0;
        out[2 + 2 * c] = (uint8_t)s;
        out[3 + 2 * c] = (uint8_t)(s >> 8);
    }
    uint8_t cum[30][65];
    uint32_t mask = 0;
    size_t at = 12;
    for (int m = 0; m < 30; m++) {
        const int k = m < 6 ? 65 : 16;
        long total = 0;
        for (int s = 0; s < k; s++)
            total += cnt[m][s];
        if (total == 0)
            continue;
        mask |= 1u << m;
        dct_fixture_model(cnt[m], k, cum[m]);
        memcpy(out + at, cum[m], (size_t)k);
        at += (size_t)k;
    }
    for (int i = 0; i < 4; i++)
        out[8 + i] = (uint8_t)(mask >> 8 * i);
    if (at & 1)
        out[at++] = 0;
    const size_t lengths = at;
    at += 130;
    /* Each stream backwards from the final state 65536: the words come out
     * last first, after the two words of the state the decoder starts at. */
    for (int by = 0; by < 65; by++) {
        size_t nw = 0;
        uint32_t x = 65536;
        for (size_t i = first[by + 1]; i-- > first[by];) {
            const int s = sym[i].s, m = sym[i].model;
            uint32_t c, f;
            if (m == 255) {
                c = 4u * (uint32_t)s;
                f = 4;
            } else {
                const int k = m < 6 ? 65 : 16;
                c = cum[m][s];
                f = (s + 1 < k ? cum[m][s + 1] : 256u) - c;
            }
            if ((uint64_t)x >= (uint64_t)f << 24) {
                words[nw++] = (uint16_t)x;
                x >>= 16;
            }
            x = ((x / f) << 8) + x % f + c;
        }
        if (nw + 2 > 65535)
            fail("dct fixture: stream %d too long", by);
        uint8_t *p = out + at;
        for (int b = 0; b < 4; b++)
            p[b] = (uint8_t)(x >> 8 * b);
        for (size_t i = 0; i < nw; i++) {
            p[4 + 2 * i] = (uint8_t)words[nw - 1 - i];
            p[5 + 2 * i] = (uint8_t)(words[nw - 1 - i] >> 8);
        }
        out[lengths + 2 * by] = (uint8_t)(nw + 2);
        out[lengths + 2 * by + 1] = (uint8_t)((nw + 2) >> 8);
        at += 2 * (nw + 2);
    }
    while (at & 3)
        out[at++] = 0;
    free(sym);
    free(words);
    return at;
}

/* How many synthetic cases dct_fixture_case makes. */
enum { DCT_FIXTURE_CASES = 4 };

/* Quantized coefficients q (3 planes of 520 x 520, zeroed first) and steps
 * S of synthetic case k (0 .. DCT_FIXTURE_CASES - 1) for `channels`:
 * 0 sparse with escapes, 1 the same with steps of 4095 and the ends of
 * the escape range, 2 all 64 coefficients of every block, 3 none. */
static inline void dct_fixture_case(int k, int channels, uint64_t *seed,
                                    int *q, int S[3])
{
    static const int steps[DCT_FIXTURE_CASES][3] = {
        {12, 7, 30}, {4095, 4095, 4095}, {3, 5, 9}, {1, 1, 1}};
    memcpy(S, steps[k], sizeof steps[k]);
    memset(q, 0, sizeof *q * 3 * 520 * 520);
    for (int c = 0; c < channels; c++)
        for (int i = 0; i < 520 * 520; i++) {
            const int uv = i % 520 % 8 + i / 520 % 8;
            const uint32_t r = test_rand(seed);
            int v = 0;
            if (k < 2) {                          /* sparse, with escapes */
                if (uv == 0)
                    v = (int)(r % 41) - 20;
                else if (r % 256 < 60u / (unsigned)(1 + uv))
                    v = (int)(r / 256 % 7) - 3;
                if (r / 4096 % 300 == 0)          /* escapes, -2048..2047 */
                    v = (int)(r / 256 % 4096) - 2048;
                if (k == 1 && r % 97 == 0)        /* the ends of the range */
                    v = r / 97 % 2 ? 2047 : -2048;
            } else if (k == 2) {
                v = r % 2 ? 1 : -1;               /* all 64 of every block */
            }
            q[(size_t)c * 520 * 520 + i] = v;
        }
}

/* A textured n x n tile of C channels, the encoders' test input: noise of
 * amplitude amp (from test_rand(rng)) over gradients, with an edge at
 * x = 250. */
static inline void dct_fixture_tile(uint8_t *t, int n, int C, int amp,
                                    uint64_t *rng)
{
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++)
            for (int c = 0; c < C; c++) {
                int v = 60 + (x + 2 * y) / 8 + 30 * c + (x > 250 ? 60 : 0);
                v += (int)(test_rand(rng) % (2 * amp + 1)) - amp;
                t[((size_t)y * n + x) * C + c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
}

#endif
