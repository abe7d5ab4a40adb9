/*
 * test_predict.c - the fast tile reconstruction (codec/predict.h: the
 * separable 16-bit prediction by rows, SIMD where the CPU has it, and the
 * row-wise residual addition) against a straightforward implementation of
 * docs/FORMAT.md sections 3 and 4 written here: the double sum with every
 * tap clamped, then codevector plus prediction clamped per sample.
 *
 * Parents are random bytes, extremes (0/255 patterns that drive the sum
 * past both ends of the clamp) and smooth ramps; every quadrant, 1 and 3
 * channels, fixed-layout and entropy-coded buffers at random rates, on
 * every SIMD path the CPU has and on the portable one.  Every sample must
 * be identical.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/byteorder.h"
#include "base/cpu.h"
#include "codec/predict.h"
#include "codec/tile.h"
#include "codec/tile_rans.h"
#include "util.h"

#define T GV_TILE

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static uint32_t next_rand(void)
{
    return test_rand(&rng);
}

static int clampi(int v, int lo, int hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* FORMAT.md section 3, sample by sample. */
static int reference_pred(const uint8_t *P, int C, int qx, int qy, int u,
                          int v, int c)
{
    static const int even[4] = {-3, 29, 111, -9}, odd[4] = {-9, 111, 29, -3};
    const int p = 256 * qx + (u >> 1), q = 256 * qy + (v >> 1);
    const int col0 = (u & 1) ? p - 1 : p - 2, row0 = (v & 1) ? q - 1 : q - 2;
    const int *wx = (u & 1) ? odd : even, *wy = (v & 1) ? odd : even;
    long long s = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            s += (long long)wy[j] * wx[i] *
                 P[((size_t)clampi(row0 + j, 0, T - 1) * T +
                    (size_t)clampi(col0 + i, 0, T - 1)) * C + c];
    long long t = s + 8192;
    t = t < 0 ? 0 : (t > 255 * 16384 + 16383 ? 255 * 16384 + 16383 : t);
    return (int)(t >> 14);
}

/* FORMAT.md section 4: decoded = clamp(pred + codevector sample). */
static void reference_decode(const uint8_t *P, int C, int qx, int qy,
                             const int8_t *book, const uint16_t *idx,
                             uint8_t *out)
{
    for (int v = 0; v < T; v++)
        for (int u = 0; u < T; u++) {
            const int k = (v / 2) * GV_BLOCKS + u / 2;
            const int pix = (u & 1) + 2 * (v & 1);
            for (int c = 0; c < C; c++) {
                int pred = reference_pred(P, C, qx, qy, u, v, c);
                int r = book ? book[(size_t)idx[k] * 4 * C + pix * C + c] : 0;
                out[((size_t)v * T + u) * C + c] = (uint8_t)clampi(pred + r, 0, 255);
            }
        }
}

enum parent_kind { NOISE, EXTREME, RAMP, NKINDS };
static const char *kind_name[NKINDS] = {"noise", "0/255 extremes", "ramps"};

static void make_parent(enum parent_kind kind, int C, uint8_t *P)
{
    for (int y = 0; y < T; y++)
        for (int x = 0; x < T; x++)
            for (int c = 0; c < C; c++) {
                uint8_t *s = &P[((size_t)y * T + x) * C + c];
                if (kind == NOISE)
                    *s = (uint8_t)next_rand();
                else if (kind == EXTREME)  /* isolated peaks and pits */
                    *s = ((x + 2 * y + c) % 3 == 0) ^ (next_rand() % 7 == 0) ? 255 : 0;
                else
                    *s = (uint8_t)(x / 2 + y / 3 + 40 * c);
            }
}

/* A fixed-layout buffer with a random codebook and random indices. */
static size_t make_fixed(int rate, int C, uint8_t *buf, int8_t *book,
                         uint16_t *idx)
{
    const size_t len = gv_tilebuf_size(rate, C);
    memset(buf, 0, len);
    buf[0] = (uint8_t)rate;
    const size_t dim = (size_t)4 * C, nbook = ((size_t)1 << rate) * dim;
    for (size_t i = 0; i < nbook; i++)
        book[i] = (int8_t)next_rand();
    memcpy(buf + 1, book, nbook);
    uint64_t bit = 8 * (1 + nbook);
    for (int k = 0; k < GV_NBLOCKS; k++) {
        idx[k] = (uint16_t)(next_rand() & ((1u << rate) - 1));
        for (int b = 0; b < rate; b++, bit++)
            if (idx[k] >> b & 1)
                buf[bit >> 3] |= (uint8_t)(1u << (bit & 7));
    }
    return len;
}

static int count_diff(const uint8_t *a, const uint8_t *b, size_t n)
{
    int d = 0;
    for (size_t i = 0; i < n; i++)
        d += a[i] != b[i];
    return d;
}

/* Mask the CPU's flags (base/cpu.h) down to the prediction's level 0
 * (portable), 1 (AVX2), 2 (AVX-512BW) or 3 (AVX-512 VBMI and VNNI);
 * returns the level that the flags granted now give. */
static int predict_level(int level)
{
    static const unsigned masks[4] = {
        GV_CPU_LEVEL_C, GV_CPU_LEVEL_AVX2,
        GV_CPU_LEVEL_AVX512 & ~(unsigned)(GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI),
        GV_CPU_LEVEL_AVX512};
    const unsigned f = gv_cpu_set_mask(masks[level]);
    const unsigned l3 = GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI;
    return !(f & GV_CPU_AVX2) ? 0 : (f & l3) == l3 ? 3 : (f & GV_CPU_AVX512) ? 2 : 1;
}

int main(void)
{
    const size_t max = gv_tile_bytes(3);
    uint8_t *P = malloc(max), *want = malloc(max), *got = malloc(max);
    uint8_t *buf = malloc(GV_TILEBUF_MAX);
    int8_t *book = malloc(((size_t)1 << GV_MAX_RATE) * 12);
    uint16_t *idx = malloc(GV_NBLOCKS * sizeof *idx);
    struct gv_error err = {0};
    /* The paths this CPU has, widest first, down to the portable one. */
    static const char *path_name[4] = {"portable", "AVX2", "AVX-512BW",
                                       "AVX-512 VBMI"};
    int paths[4], npaths = 0;
    for (int level = 3; level >= 0; level--)
        if (predict_level(level) == level)
            paths[npaths++] = level;
    printf("# paths on this CPU:");
    for (int i = 0; i < npaths; i++)
        printf(" %s", path_name[paths[i]]);
    printf("\n");

    for (int C = 1; C <= 3; C += 2)
        for (int kind = 0; kind < NKINDS; kind++) {
            make_parent(kind, C, P);
            const size_t n = gv_tile_bytes(C);
            for (int q = 0; q < 4; q++) {
                const int qx = q & 1, qy = q >> 1;
                reference_decode(P, C, qx, qy, NULL, NULL, want);
                for (int i = 0; i < npaths; i++) {
                    predict_level(paths[i]);
                    gv_predict(P, C, qx, qy, got);
                    check(count_diff(got, want, n) == 0,
                          "gv_predict, %d channel(s), %s parent, quadrant (%d,%d), "
                          "%s path: %d samples differ", C, kind_name[kind], qx, qy,
                          path_name[paths[i]], count_diff(got, want, n));
                }
                /* Rows out of order: the ring of filtered parent rows must
                 * refilter what it dropped. */
                struct gv_predictor pr;
                gv_predictor_init(&pr, P, C, qx, qy);
                int bad = 0;
                for (int i = 0; i < 200; i++) {
                    int v = (int)(next_rand() % T);
                    gv_predictor_row(&pr, v, got);
                    bad += count_diff(got, want + (size_t)v * T * C, (size_t)T * C);
                }
                check(bad == 0, "200 rows in random order, %d channel(s), %s parent, "
                      "quadrant (%d,%d): %d samples differ", C, kind_name[kind],
                      qx, qy, bad);
                gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
            }
        }

    /* Whole tiles: prediction plus residual, both layouts, random rates,
     * both paths, against the reference. */
    int layouts[2] = {0, 0};
    for (int t = 0; t < 16; t++) {
        const int C = t & 1 ? 3 : 1, qx = t >> 1 & 1, qy = t >> 2 & 1;
        const int rate = 1 + (int)(next_rand() % GV_MAX_RATE);
        make_parent(t % NKINDS, C, P);
        size_t len = make_fixed(rate, C, buf, book, idx);
        if (t >= 8) {
            /* Skewed indices so that the entropy-coded layout is smaller. */
            for (int k = 0; k < GV_NBLOCKS; k++)
                idx[k] = (uint16_t)(next_rand() % 3 ? 0 : idx[k]);
            size_t e = gv_rans_pack(idx, rate, C, book, buf, GV_TILEBUF_MAX);
            if (e)
                len = e;
            else
                len = make_fixed(rate, C, buf, book, idx);
        }
        const int entropy = (buf[0] & GV_TILE_ENTROPY) != 0;
        layouts[entropy]++;
        reference_decode(P, C, qx, qy, book, idx, want);
        const size_t n = gv_tile_bytes(C);
        for (int i = 0; i < npaths; i++) {
            predict_level(paths[i]);
            int rc = gv_tile_decode(buf, len, C, P, qx, qy, got, &err);
            check(rc == 0 && count_diff(got, want, n) == 0,
                  "tile %d: %d channel(s), rate %d, %s layout, quadrant (%d,%d), "
                  "%s path: decode == reference (%d samples differ)", t, C, rate,
                  entropy ? "entropy-coded" : "fixed", qx, qy,
                  path_name[paths[i]], rc == 0 ? count_diff(got, want, n) : -1);
        }
        gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    }
    check(layouts[0] > 0 && layouts[1] > 0, "both layouts tested (%d fixed, %d "
          "entropy-coded)", layouts[0], layouts[1]);
    free(P);
    free(want);
    free(got);
    free(buf);
    free(book);
    free(idx);
    return tap_done();
}
