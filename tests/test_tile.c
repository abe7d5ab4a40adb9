/*
 * test_tile.c - the tile codec: the prediction formula, index packing at
 * every rate, encoder/decoder agreement, quality targets, hostile
 * buffers, the biased codevector search on every SIMD path, and the
 * entropy-constrained rate-distortion mode on a photograph.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "store/geometry.h"
#include "base/byteorder.h"
#include "base/cpu.h"
#include "codec/tile.h"
#include "codec/sse.h"
#include "codec/tile_rans.h"
#include "codec/vq.h"
#include "encode/source.h"
#include "util.h"

#define T GV_TILE

static uint64_t rng = 88172645463325252ull;
static uint32_t next_rand(void)
{
    return test_rand(&rng);
}

/* The prediction written out from docs/FORMAT.md, independently: the
 * double sum with clamped taps, in 64-bit, one rounding. */
static int reference_pred(const uint8_t *P, int C, int qx, int qy, int u, int v,
                          int c)
{
    static const int even[4] = {-3, 29, 111, -9}, odd[4] = {-9, 111, 29, -3};
    int p = 256 * qx + u / 2, q = 256 * qy + v / 2;
    int px0 = u % 2 ? p - 1 : p - 2, qy0 = v % 2 ? q - 1 : q - 2;
    const int *wx = u % 2 ? odd : even, *wy = v % 2 ? odd : even;
    long long s = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            int x = px0 + i, y = qy0 + j;
            x = x < 0 ? 0 : x > 512 ? 512 : x;
            y = y < 0 ? 0 : y > 512 ? 512 : y;
            s += (long long)wx[i] * wy[j] * P[((size_t)y * T + x) * C + c];
        }
    s += 8192;
    if (s < 0)
        s = 0;
    if (s > 255 * 16384 + 16383)
        s = 255 * 16384 + 16383;
    return (int)(s / 16384);
}

/* A natural-looking tile: smooth gradient plus texture plus an edge. */
static void make_tile(uint8_t *t, int C, int noise)
{
    for (int y = 0; y < T; y++)
        for (int x = 0; x < T; x++)
            for (int c = 0; c < C; c++) {
                int v = (x / 3 + y / 5 + 40 * c) % 200;
                if (x > 300 && y < 200)
                    v += 50;
                v += noise ? (int)(next_rand() % (unsigned)noise) - noise / 2 : 0;
                t[(y * T + x) * C + c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
}

/* The message of a call that returned RC: NULL unless it failed (RC < 0),
 * so that check_str() also checks the refusal itself. */
static const char *refusal(int rc, const struct gv_error *err)
{
    return rc < 0 ? err->text : NULL;
}

static double psnr(const uint8_t *a, const uint8_t *b, size_t n)
{
    double sse = 0;
    for (size_t i = 0; i < n; i++)
        sse += (double)(a[i] - b[i]) * (a[i] - b[i]);
    return sse == 0 ? 99.0 : 10 * log10(65025.0 * n / sse);
}

/* The biased search written out: squared distance plus the bias clamped
 * to 0 .. VQ_BIAS_MAX, in 64 bits, the lowest index among equal costs. */
static void reference_nearest(const int8_t *book, const int32_t *bias, int k,
                              int dim, const int16_t *x, uint16_t *idx,
                              uint32_t *cost)
{
    int64_t best = INT64_MAX;
    *idx = 0;
    for (int c = 0; c < k; c++) {
        int64_t b = bias[c] < 0 ? 0 : bias[c] > VQ_BIAS_MAX ? VQ_BIAS_MAX : bias[c];
        for (int d = 0; d < dim; d++)
            b += (int64_t)(x[d] - book[c * dim + d]) * (x[d] - book[c * dim + d]);
        if (b < best) {
            best = b;
            *idx = (uint16_t)c;
        }
    }
    *cost = (uint32_t)best;
}

/* Every search path against reference_nearest on random codebooks, biases
 * (some out of range, some equal over duplicated codevectors, so that
 * ties occur) and residuals (some at +-255, the extremes), and on
 * residuals close to the codevectors (clustered), where the SIMD paths
 * skip most runs of their search (vq.c: pruning by component sums).
 * The paths are chosen by gv_cpu_set_mask (base/cpu.h).  Each is also
 * started from guesses (vq_nearest_warm): the
 * answer itself, a random index, and an equal-cost duplicate of higher
 * index than the answer, which must not win the tie. */
static void check_biased_search(void)
{
    static const int ks[] = {1, 5, 16, 37, 256, 1000};
    static const char *names[] = {"portable", "AVX2", "AVX-512"};
    struct vq_search *s = malloc(sizeof *s);
    int8_t *book = malloc(1000 * VQ_MAXDIM);
    int32_t *bias = malloc(1000 * sizeof *bias);
    const size_t n = 300;
    int16_t *vecs = calloc(n * VQ_STRIDE, sizeof *vecs);
    uint16_t *idx = malloc(n * sizeof *idx), ridx;
    uint32_t *dist = malloc(n * sizeof *dist), rcost;
    if (!s || !book || !bias || !vecs || !idx || !dist)
        fail("out of memory");
    static const unsigned masks[] = {GV_CPU_LEVEL_C, GV_CPU_LEVEL_AVX2,
                                     GV_CPU_LEVEL_AVX512};
    static const unsigned needs[] = {0, GV_CPU_AVX2, GV_CPU_AVX512};
    for (int path = 0; path < 3; path++) {
        const unsigned granted = gv_cpu_set_mask(masks[path]);
        int wrong = 0, ties = 0, runs = 0, wrong_warm = 0, tie_guesses = 0;
        int have = (granted & needs[path]) == needs[path];
        for (int clustered = 0; clustered < 2 && have; clustered++)
        for (int dim = 4; dim <= 12 && have; dim += 8)
            for (size_t ki = 0; ki < sizeof ks / sizeof ks[0] && have; ki++) {
                const int k = ks[ki];
                for (int i = 0; i < k * dim; i++)
                    book[i] = (int8_t)(next_rand() % 256 - 128);
                for (int c = 0; c < k; c++) {
                    uint32_t r = next_rand() % 8;
                    bias[c] = r == 0 ? 0 : r == 1 ? VQ_BIAS_MAX : r == 2 ? INT32_MAX :
                              r == 3 ? -5 : (int32_t)(next_rand() % 200000);
                }
                for (int c = 1; c < k; c += 3) {   /* duplicates: ties */
                    memcpy(book + c * dim, book + (c - 1) * dim, (size_t)dim);
                    bias[c] = bias[c - 1];
                }
                for (size_t i = 0; i < n; i++) {
                    const int c = (int)(next_rand() % (uint32_t)k);
                    for (int d = 0; d < dim; d++) {
                        uint32_t r = next_rand() % 16;
                        vecs[i * VQ_STRIDE + d] = (int16_t)(
                            clustered ? book[c * dim + d] + (int)(next_rand() % 7) - 3 :
                            r == 0 ? 255 : r == 1 ? -255 : (int)(next_rand() % 161) - 80);
                    }
                }
                for (int d = 0; d < dim && !clustered; d++) {   /* sums beyond any codevector's */
                    vecs[d] = 255;
                    vecs[VQ_STRIDE + d] = -255;
                }
                vq_search_prepare(s, book, k, dim);
                vq_search_set_bias(s, bias);
                vq_nearest(s, vecs, n, idx, dist);
                runs++;
                for (size_t i = 0; i < n; i++) {
                    reference_nearest(book, bias, k, dim, vecs + i * VQ_STRIDE, &ridx, &rcost);
                    wrong += idx[i] != ridx || dist[i] != rcost;
                    ties += ridx % 3 == 0 && ridx + 1 < k;
                }
                /* Warm starts: guesses from the reference answers. */
                for (size_t i = 0; i < n; i++) {
                    reference_nearest(book, bias, k, dim, vecs + i * VQ_STRIDE, &ridx, &rcost);
                    if (i % 3 == 0 && ridx % 3 == 0 && ridx + 1 < k) {
                        idx[i] = (uint16_t)(ridx + 1);   /* its duplicate */
                        tie_guesses++;
                    } else {
                        idx[i] = i % 3 == 1 ? ridx : (uint16_t)(next_rand() % (uint32_t)k);
                    }
                }
                vq_nearest_warm(s, vecs, n, idx, dist);
                for (size_t i = 0; i < n; i++) {
                    reference_nearest(book, bias, k, dim, vecs + i * VQ_STRIDE, &ridx, &rcost);
                    wrong_warm += idx[i] != ridx || dist[i] != rcost;
                }
            }
        if (!have) {
            check(1, "biased search, %s path # SKIP not on this CPU", names[path]);
            continue;
        }
        check(wrong == 0 && ties > 0, "biased search, %s path: %d of %zu answers differ from "
              "the reference (%d could tie)", names[path], wrong, runs * n, ties);
        check(wrong_warm == 0 && tie_guesses > 0, "biased search from guesses, %s path: %d of "
              "%zu answers differ from the reference (%d guesses tie the answer from above)",
              names[path], wrong_warm, runs * n, tie_guesses);
    }
    gv_cpu_set_mask(GV_CPU_LEVEL_MAX);
    /* NULL biases: the plain nearest search, the same on the dispatched path. */
    vq_search_set_bias(s, NULL);
    vq_nearest(s, vecs, n, idx, dist);
    int wrong = 0;
    memset(bias, 0, 1000 * sizeof *bias);
    for (size_t i = 0; i < n; i++) {
        reference_nearest(book, bias, s->k, s->dim, vecs + i * VQ_STRIDE, &ridx, &rcost);
        wrong += idx[i] != ridx || dist[i] != rcost;
    }
    check(wrong == 0, "no biases: the squared distance to the nearest codevector");
    free(s);
    free(book);
    free(bias);
    free(vecs);
    free(idx);
    free(dist);
}

/* Offset of the stream lengths n[] of an entropy-coded buffer, read from
 * its header as docs/FORMAT.md lays it out (sections 4.1 and 4.2). */
static size_t lengths_offset(const uint8_t *buf, int channels)
{
    const int rate = buf[0] & 15, dim = 4 * channels;
    if (!(buf[0] & 0x40))
        return ((1 + ((size_t)dim << rate) + 3) & ~(size_t)3) + ((size_t)2 << rate);
    const size_t n = gv_get16(buf + 2), contexts = buf[1];
    const size_t map = (4 + n * dim + 2 * n + 3) & ~(size_t)3;
    return map + 8 + 16 * contexts;
}

/* Single-byte changes (every 7th byte after the codebook) to one
 * entropy-coded buffer.  A change to the tables, the context map or the
 * stream lengths is refused by the layout check, or (EX) touches a byte
 * no block uses (a map entry of a class pair that never occurs, a model
 * nothing is coded with) and decodes to the same pixels.  A change inside
 * the streams is refused when a stream then ends early or not in its
 * final state; the streams carry no checksum, so a changed word can still
 * end cleanly and decode, in bounds (ASan checks), to other indices: only
 * a few may.  Then truncation, and byte 0 with reserved bits. */
static void attack(const uint8_t *buf, size_t len, const uint8_t *parent,
                   const char *name)
{
    const size_t tb = gv_tile_bytes(3);
    struct gv_error err = {0};
    uint8_t *copy = malloc(len), *dec = malloc(tb), *want_px = malloc(tb);
    if (!copy || !dec || !want_px)
        fail("out of memory");
    if (gv_tile_decode(buf, len, 3, parent, 0, 0, want_px, &err) < 0)
        fail("%s: %s", name, err.text);
    const int rate = buf[0] & 15;
    const size_t book = buf[0] & 0x40 ? 4 + (size_t)12 * gv_get16(buf + 2)
                                      : 1 + ((size_t)12 << rate);
    const size_t lengths = lengths_offset(buf, 3);
    const size_t streams = lengths + ((2 * GV_BLOCKS + 3) & ~(size_t)3);
    size_t words = 0;
    for (int row = 0; row < GV_BLOCKS; row++)
        words += gv_get16(buf + lengths + 2 * (size_t)row);
    int tables_changed = 0, tables_refused = 0, tables_same = 0,
        streams_changed = 0, streams_refused = 0;
    for (size_t pos = book; pos < len; pos += 7) {
        memcpy(copy, buf, len);
        copy[pos] ^= 0x24;
        int refused = gv_tile_decode(copy, len, 3, parent, 0, 0, dec, &err) < 0;
        if (pos < streams) {
            tables_changed++;
            tables_refused += refused;
            tables_same += !refused && memcmp(dec, want_px, tb) == 0;
        } else {
            streams_changed++;
            streams_refused += refused;
        }
    }
    check(tables_changed > 0 && tables_refused + tables_same == tables_changed &&
          (buf[0] & 0x40 || tables_same == 0),
          "%s: every damaged table or stream length is refused (%d of %d; %d touch "
          "nothing used)", name, tables_refused, tables_changed, tables_same);
    check(streams_changed > 1000 && streams_changed - streams_refused <= streams_changed / 100,
          "%s: damaged streams: at most 1%% decode (%d of %d)", name,
          streams_changed - streams_refused, streams_changed);
    char want[128];
    snprintf(want, sizeof want, "tile: streams need %zu bytes, the buffer has %zu",
             2 * words, len - 4 - streams);
    gv_error_clear(&err);
    check_str(refusal(gv_tile_decode(buf, len - 4, 3, parent, 0, 0, dec, &err), &err),
              want, "%s: a truncated buffer is refused", name);
    memcpy(copy, buf, len);
    copy[0] = (uint8_t)(buf[0] & 0xc0);
    snprintf(want, sizeof want, "tile: bad rate byte 0x%02x", copy[0]);
    gv_error_clear(&err);
    check_str(refusal(gv_tilebuf_check(copy, len, 3, &err), &err), want,
              "%s: entropy flag at rate 0 is refused", name);
    copy[0] = (uint8_t)(buf[0] | 0x10);
    snprintf(want, sizeof want, "tile: bad rate byte 0x%02x", copy[0]);
    gv_error_clear(&err);
    check_str(refusal(gv_tilebuf_check(copy, len, 3, &err), &err), want,
              "%s: reserved bits are refused", name);
    free(copy);
    free(dec);
    free(want_px);
}

/* The encoder's buffer for a smooth tile with a little noise is context-
 * coded (EX); the same indices and codebook packed in the E layout decode
 * to the same pixels.  Both are attacked. */
static void check_attacks(struct gv_tile_workspace *ws, const uint8_t *orig,
                          const uint8_t *parent, uint8_t *buf)
{
    const size_t tb = gv_tile_bytes(3);
    struct gv_error err = {0};
    struct gv_tile_params prm = {.target_mse = 0.01, .max_rate = 6, .seed = 3};
    struct gv_tile_stats st;
    uint8_t *recon = malloc(tb), *dec = malloc(tb), *e = malloc(GV_TILEBUF_MAX);
    uint16_t *idx = malloc(sizeof *idx * GV_NBLOCKS);
    int8_t book[64 * 12];
    if (!recon || !dec || !e || !idx)
        fail("out of memory");
    size_t len = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &prm, recon, buf, &st);
    const uint32_t n = gv_get16(buf + 2);
    check(buf[0] == 0xc6 && st.rate == 6 && n >= 8 && n <= 64 && buf[1] >= 1 && buf[1] <= 8,
          "the attacked tile is context-coded at rate 6 (byte 0: 0x%02x, %u codevectors, "
          "%d context models)", buf[0], n, buf[1]);
    memset(book, 0, sizeof book);
    memcpy(book, buf + 4, (size_t)n * 12);
    int unpacked = gv_rans_unpack(buf, len, 6, 3, idx, &err) == 0;
    size_t elen = gv_rans_pack(idx, 6, 3, book, e, GV_TILEBUF_MAX);
    check(unpacked && elen > len && gv_tile_decode(e, elen, 3, parent, 0, 0, dec, &err) == 0 &&
          memcmp(dec, recon, tb) == 0, "the same indices in the E layout: %zu bytes rather "
          "than %zu, the same pixels", elen, len);
    attack(buf, len, parent, "EX");
    attack(e, elen, parent, "E");
    free(recon);
    free(dec);
    free(e);
    free(idx);
}

/* Pack and unpack indices of chosen statistics in both entropy-coded
 * layouts: every index the same (a model of one certain symbol, whose
 * frequency is the whole 2^15), a skewed run, and every fourth block row
 * uniform at rate 12 (escapes: two coding steps a block).  Uniform
 * indices in every row make longer buffers than the fixed layout, which
 * the check refuses.  Then hostile EX headers. */
static void check_context_layout(const uint8_t *parent)
{
    struct gv_error err = {0};
    const size_t cap = 2 * GV_TILEBUF_MAX;
    uint16_t *idx = malloc(sizeof *idx * GV_NBLOCKS), *back = malloc(sizeof *back * GV_NBLOCKS);
    uint8_t *buf = malloc(cap), *copy = malloc(cap), *dec = malloc(gv_tile_bytes(3));
    int8_t *book = malloc((size_t)12 << GV_MAX_RATE);
    if (!idx || !back || !buf || !copy || !dec || !book)
        fail("out of memory");
    for (size_t i = 0; i < ((size_t)12 << GV_MAX_RATE); i++)
        book[i] = (int8_t)(i * 37 % 251 - 125);
    static const struct { int rate; const char *what; } cases[] = {
        {3, "every index 5"}, {8, "skewed"}, {12, "uniform rows"},
    };
    for (int c = 0; c < 3; c++) {
        const int rate = cases[c].rate;
        for (uint32_t i = 0; i < GV_NBLOCKS; i++) {
            uint32_t r = next_rand();
            idx[i] = c == 0 ? 5 : c == 1 ? (uint16_t)((r % 16 ? r % 4 : r % 256) ^ 3)
                                        : (uint16_t)(i / GV_BLOCKS % 4 ? 0 : r % 4096);
        }
        for (int ctx = 0; ctx < 2; ctx++) {
            size_t len = ctx ? gv_rans_pack_ctx(idx, rate, 3, book, buf, cap)
                             : gv_rans_pack(idx, rate, 3, book, buf, cap);
            int ok = len > 0 && gv_rans_unpack(buf, len, rate, 3, back, &err) == 0;
            /* EX reorders the codebook: compare codevectors, not indices. */
            const size_t bo = ctx ? 4 : 1;
            for (uint32_t i = 0; ok && i < GV_NBLOCKS; i++)
                ok = memcmp(buf + bo + (size_t)back[i] * 12, book + (size_t)idx[i] * 12, 12) == 0;
            check(ok && gv_tile_decode(buf, len, 3, parent, 1, 0, dec, &err) == 0,
                  "%s, rate %d, %s layout: %zu bytes, every block's codevector comes back",
                  cases[c].what, rate, ctx ? "EX" : "E", len);
        }
    }
    for (uint32_t i = 0; i < GV_NBLOCKS; i++)
        idx[i] = (uint16_t)(next_rand() % 4096);
    for (int ctx = 0; ctx < 2; ctx++) {
        size_t len = ctx ? gv_rans_pack_ctx(idx, 12, 3, book, buf, cap)
                         : gv_rans_pack(idx, 12, 3, book, buf, cap);
        char want[128];
        snprintf(want, sizeof want, "tile: entropy-coded buffer of %zu bytes, longer than "
                 "the fixed layout's %d", len, GV_TILEBUF_MAX);
        gv_error_clear(&err);
        check_str(refusal(gv_tilebuf_check(buf, len, 3, &err), &err), want,
                  "uniform indices at rate 12, %s layout: refused", ctx ? "EX" : "E");
    }
    /* The commonest codevector first: index 0 of the skewed case. */
    for (uint32_t i = 0; i < GV_NBLOCKS; i++)
        idx[i] = (uint16_t)(i % 9 == 0 ? 200 + i % 50 : 77);
    size_t len = gv_rans_pack_ctx(idx, 8, 3, book, buf, cap);
    int zero = gv_rans_unpack(buf, len, 8, 3, back, &err) == 0;
    for (uint32_t i = 0; zero && i < GV_NBLOCKS; i++)
        zero = (back[i] == 0) == (idx[i] == 77);
    check(zero && gv_get16(buf + 2) == 51 && memcmp(buf + 4, book + 77 * 12, 12) == 0,
          "EX: the commonest codevector is index 0, the 51 used ones are kept (N = %u)",
          gv_get16(buf + 2));
    check(gv_rans_pack_ctx(idx, 2, 3, book, buf, cap) == 0, "EX needs rate 3 or more");
    /* Hostile headers of that buffer. */
    len = gv_rans_pack_ctx(idx, 8, 3, book, buf, cap);
    const size_t map = (4 + 51 * 12 + 2 * 51 + 3) & ~(size_t)3;
    static const struct { size_t at; uint8_t val; const char *want; } bad[] = {
        {0, 0x42, "tile: bad rate byte 0x42"},
        {0, 0xc2, "tile: context-coded indices at rate 2 (3 is the least)"},
        {2, 7, "tile: 7 codevectors at rate 8"},
        {3, 1, "tile: 307 codevectors at rate 8"},
        {1, 0, "tile: 0 context models"},
        {1, 9, "tile: 9 context models"},
        {map, 0xff, NULL},
    };
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        char want[128];
        if (bad[b].want)
            snprintf(want, sizeof want, "%s", bad[b].want);
        else
            snprintf(want, sizeof want, "tile: context map entry 0 is 15 of %d models", buf[1]);
        memcpy(copy, buf, len);
        copy[bad[b].at] = bad[b].val;
        gv_error_clear(&err);
        check_str(refusal(gv_tilebuf_check(copy, len, 3, &err), &err), want,
                  "EX, hostile header: %s", want);
    }
    free(idx);
    free(back);
    free(buf);
    free(copy);
    free(dec);
    free(book);
}

/* Code lengths: vq_log2_q16 is log2 in 16.16 fixed point, to one unit. */
/* Offset of the stream lengths n[] of an entropy-coded buffer
 * (FORMAT.md 4.1, 4.2). */
static size_t lengths_at(const uint8_t *buf, int channels)
{
    const size_t tables = gv_rans_tables_at(buf, channels);
    if (!(buf[0] & GV_TILE_CONTEXT))
        return tables + 2 * ((size_t)1 << (buf[0] & 0x0f));
    const size_t n = gv_get16(buf + 2);
    const size_t map = (tables + 2 * n + 3) & ~(size_t)3;
    return map + 8 + 2 * GV_RANS_SYMBOLS * (size_t)buf[1];
}

/* Start of row r's stream: after n[] (padded to 4 bytes), the streams of
 * the rows before, n[row] 16-bit words each. */
static size_t stream_at(const uint8_t *buf, int channels, int r)
{
    const size_t lengths = lengths_at(buf, channels);
    size_t at = lengths + ((2 * GV_BLOCKS + 3) & ~(size_t)3);
    for (int row = 0; row < r; row++)
        at += 2 * (size_t)gv_get16(buf + lengths + 2 * row);
    return at;
}

/* The block rows' streams are independent: a damaged stream is reported
 * as its own row, and every row before it decodes as it was (a decoder
 * that works on several rows at once must keep both). */
static void check_damaged_rows(void)
{
    struct gv_error err = {0};
    const size_t cap = 2 * GV_TILEBUF_MAX;
    uint16_t *idx = malloc(sizeof *idx * GV_NBLOCKS), *want = malloc(sizeof *want * GV_NBLOCKS),
             *back = malloc(sizeof *back * GV_NBLOCKS);
    uint8_t *buf = malloc(cap), *copy = malloc(cap);
    int8_t *book = malloc((size_t)12 << 8);
    if (!idx || !want || !back || !buf || !copy || !book)
        fail("out of memory");
    for (size_t i = 0; i < ((size_t)12 << 8); i++)
        book[i] = (int8_t)(i * 37 % 251 - 125);
    for (uint32_t i = 0; i < GV_NBLOCKS; i++) {
        uint32_t r = next_rand();
        idx[i] = (uint16_t)(r % 8 ? r % 5 : r % 256);
    }
    static const int rows[] = {0, 1, 2, 3, 4, 6, 127, 254, 255, 256};
    for (int ctx = 0; ctx < 2; ctx++) {
        const size_t len = ctx ? gv_rans_pack_ctx(idx, 8, 3, book, buf, cap)
                               : gv_rans_pack(idx, 8, 3, book, buf, cap);
        if (len == 0 || gv_rans_unpack(buf, len, 8, 3, want, &err) < 0)
            fail("pack/unpack: %s", err.text);
        int wrong = 0;
        for (size_t k = 0; k < sizeof rows / sizeof rows[0]; k++) {
            const int r = rows[k];
            memcpy(copy, buf, len);
            const size_t at = stream_at(copy, 3, r);
            const uint32_t n = gv_get16(copy + lengths_at(copy, 3) + 2 * (size_t)r);
            copy[at + 2 * (n / 2)] ^= 0x5a;
            copy[at + 2 * (n / 2) + 1] ^= 0xa5;
            memset(back, 0xff, sizeof *back * GV_NBLOCKS);
            char named[32];
            snprintf(named, sizeof named, "tile: stream %d ", r);
            gv_error_clear(&err);
            const int rc = gv_rans_unpack(copy, len, 8, 3, back, &err);
            const int same = memcmp(back, want, sizeof *back * GV_BLOCKS * (size_t)r) == 0;
            if (rc == 0 || strncmp(err.text, named, strlen(named)) != 0 || !same) {
                wrong++;
                printf("# %s, row %d damaged: rc %d, \"%s\", rows before %s\n",
                       ctx ? "EX" : "E", r, rc, rc ? err.text : "", same ? "same" : "differ");
            }
        }
        check(wrong == 0, "%s layout: a damaged stream is reported as its own row (%zu rows "
              "tried), the rows before it decoded unchanged", ctx ? "EX" : "E", sizeof rows / sizeof rows[0]);
    }
    free(idx);
    free(want);
    free(back);
    free(buf);
    free(copy);
    free(book);
}

static void check_log2(void)
{
    int wrong = 0;
    for (uint64_t x = 1; x < (1ull << 62); x = x < 70000 ? x + 1 : x * 3 + 1) {
        double d = log2((double)x) * 65536.0 - vq_log2_q16(x);
        wrong += d < 0 || d >= 1.01;
    }
    check(wrong == 0 && vq_log2_q16(1) == 0 && vq_log2_q16(65536) == 16u << 16,
          "fixed-point log2 within one unit (%d wrong)", wrong);
}

/* The 2x2 box average of a w x h RGB image (odd edges replicated). */
static uint8_t *box_half(const uint8_t *img, uint32_t w, uint32_t h,
                         uint32_t *hw, uint32_t *hh)
{
    *hw = (w + 1) / 2;
    *hh = (h + 1) / 2;
    uint8_t *out = malloc((size_t)*hw * *hh * 3);
    if (!out)
        fail("out of memory");
    for (uint32_t y = 0; y < *hh; y++)
        for (uint32_t x = 0; x < *hw; x++)
            for (int c = 0; c < 3; c++) {
                uint32_t x1 = 2 * x + 1 < w ? 2 * x + 1 : w - 1;
                uint32_t y1 = 2 * y + 1 < h ? 2 * y + 1 : h - 1;
                int s = img[((size_t)2 * y * w + 2 * x) * 3 + c] +
                        img[((size_t)2 * y * w + x1) * 3 + c] +
                        img[((size_t)y1 * w + 2 * x) * 3 + c] +
                        img[((size_t)y1 * w + x1) * 3 + c];
                out[((size_t)y * *hw + x) * 3 + c] = (uint8_t)((s + 2) >> 2);
            }
    return out;
}

/* Tile (tx, ty) of a w x h RGB image, clamp-padded past its edges. */
static void cut(const uint8_t *img, uint32_t w, uint32_t h, uint32_t tx,
                uint32_t ty, uint8_t *tile)
{
    for (uint32_t v = 0; v < T; v++)
        for (uint32_t u = 0; u < T; u++) {
            uint32_t x = tx * GV_STEP + u, y = ty * GV_STEP + v;
            x = x < w ? x : w - 1;
            y = y < h ? y : h - 1;
            memcpy(tile + ((size_t)v * T + u) * 3, img + ((size_t)y * w + x) * 3, 3);
        }
}

/* Rate-distortion mode on tiles of a photograph: what the encoder
 * reconstructs is what the decoder gives, and at the same lambda the
 * entropy-constrained encoder's J = SSE + lambda * bits is below that of
 * nearest-codevector coding.  Then the target mode on one of them. */
static void check_rd_photo(struct gv_tile_workspace *ws)
{
    const char *data = getenv("TESTDATA");
    char path[1024];
    snprintf(path, sizeof path, "%s/picos-1100x700.jpg", data ? data : "tests/data");
    const char *in[1] = {path};
    struct gv_source_info info;
    struct gv_error err = {0};
    struct gv_source *src = gv_source_open(in, 1, NULL, &info, &err);
    if (!src || info.channels != 3)
        fail("cannot read %s: %s", path, src ? "not RGB" : err.text);
    uint8_t *img = malloc((size_t)info.width * info.height * 3);
    if (!img || gv_source_read(src, info.height, img, &err) < 0)
        fail("cannot read %s", path);
    gv_source_free(src);
    uint32_t pw, ph;
    uint8_t *half = box_half(img, info.width, info.height, &pw, &ph);

    const size_t tb = gv_tile_bytes(3);
    uint8_t *parent = malloc(tb), *orig = malloc(tb), *recon = malloc(tb);
    uint8_t *dec = malloc(tb), *buf = malloc(GV_TILEBUF_MAX);
    uint8_t *first = malloc(GV_TILEBUF_MAX);
    if (!parent || !orig || !recon || !dec || !buf || !first)
        fail("out of memory");
    const double lambda = 2.0 * log(2.0) * gv_psnr_to_mse(36.0);
    /* A whole tile, then the image's corner tile (76 x 188 valid pixels),
     * coded with and without entropy-constrained VQ. */
    static const uint32_t tiles[2][2] = {{0, 0}, {2, 1}};
    size_t first_len = 0;
    for (int t = 0; t < 2; t++) {
        const uint32_t tx = tiles[t][0], ty = tiles[t][1];
        const uint32_t vw = info.width - tx * GV_STEP < T ? info.width - tx * GV_STEP : T;
        const uint32_t vh = info.height - ty * GV_STEP < T ? info.height - ty * GV_STEP : T;
        cut(img, info.width, info.height, tx, ty, orig);
        cut(half, pw, ph, tx / 2, ty / 2, parent);
        double j[2];
        int rate[2];
        size_t len[2];
        for (int plain = 0; plain < 2; plain++) {
            struct gv_tile_params prm = {.target_mse = gv_psnr_to_mse(36.0), .max_rate = 10,
                                         .lambda = lambda, .nearest_only = plain, .seed = 5};
            struct gv_tile_stats st;
            len[plain] = gv_tile_encode(ws, orig, parent, (int)(tx & 1), (int)(ty & 1), 3,
                                        vw, vh, &prm, recon, buf, &st);
            int same = gv_tile_decode(buf, len[plain], 3, parent, (int)(tx & 1), (int)(ty & 1),
                                      dec, &err) == 0 && memcmp(dec, recon, tb) == 0;
            double sse = 0;
            for (uint32_t y = 0; y < vh; y++)
                for (uint32_t x = 0; x < vw * 3; x++) {
                    double d = orig[(size_t)y * T * 3 + x] - recon[(size_t)y * T * 3 + x];
                    sse += d * d;
                }
            j[plain] = sse + lambda * 8.0 * (double)len[plain];
            rate[plain] = st.rate;
            check(same && (uint64_t)sse == st.sse, "photo tile (%u,%u), %s: decode == encoder "
                  "reconstruction (r=%d, %zu bytes, %.2f dB)", tx, ty,
                  plain ? "nearest codevector" : "entropy-constrained", st.rate, len[plain],
                  10 * log10(65025.0 * vw * vh * 3 / (sse > 0 ? sse : 1)));
            if (t == 0 && !plain) {
                memcpy(first, buf, len[0]);
                first_len = len[0];
            }
        }
        check(j[0] < j[1], "photo tile (%u,%u): entropy-constrained J %.4g (r=%d, %zu bytes) "
              "< nearest-codevector J %.4g (r=%d, %zu bytes)", tx, ty, j[0], rate[0], len[0],
              j[1], rate[1], len[1]);
    }
    /* Target mode: 36 dB met with and without entropy-constrained VQ, in
     * fewer bytes with it. */
    cut(img, info.width, info.height, 0, 0, orig);
    cut(half, pw, ph, 0, 0, parent);
    {
        size_t len[2];
        int met = 1, same = 1;
        const double budget = gv_psnr_to_mse(36.0) * T * T * 3;
        for (int plain = 0; plain < 2; plain++) {
            struct gv_tile_params prm = {.target_mse = gv_psnr_to_mse(36.0), .max_rate = 10,
                                         .nearest_only = plain, .seed = 5};
            struct gv_tile_stats st;
            len[plain] = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &prm, recon, buf, &st);
            met &= (double)st.sse <= budget && st.rate < 10;
            same &= gv_tile_decode(buf, len[plain], 3, parent, 0, 0, dec, &err) == 0 &&
                    memcmp(dec, recon, tb) == 0;
        }
        check(met && same && len[0] < len[1], "photo tile (0,0), 36 dB target: met in %zu bytes "
              "entropy-constrained, %zu nearest-codevector; decode == encoder reconstruction",
              len[0], len[1]);
    }
    /* The workspace keeps nothing from one tile to the next. */
    struct gv_tile_params prm = {.target_mse = 1.0, .max_rate = 10, .lambda = lambda, .seed = 5};
    struct gv_tile_stats st;
    size_t again = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &prm, recon, buf, &st);
    check(again == first_len && memcmp(buf, first, again) == 0,
          "the same tile coded again gives the same bytes");
    free(img);
    free(half);
    free(parent);
    free(orig);
    free(recon);
    free(dec);
    free(buf);
    free(first);
}

/* gv_rans_put_rcp against gv_rans_put (the same state and words) for
 * every frequency of 8- and 12-bit models, at the states where a quotient
 * changes (multiples of f and one below), at each renormalization bound
 * and below it, and at random states under the bound. */
static void check_rans_rcp(void)
{
    long bad = 0, tried = 0;
    for (int bits = 8; bits <= 12; bits += 4)
        for (uint32_t f = 1; f <= (1u << bits); f++) {
            const uint64_t rcp = gv_rans_rcp(f);
            const uint64_t x_max = (uint64_t)(((1u << 16) >> bits) << 16) * f;
            uint32_t xs[16 + 64];
            int k = 0;
            const uint32_t top = x_max > UINT32_MAX ? UINT32_MAX : (uint32_t)x_max;
            xs[k++] = 1u << 16;
            xs[k++] = top - 1;
            xs[k++] = top;
            xs[k++] = UINT32_MAX;
            for (uint32_t m = 1; m <= 6; m++) {
                uint64_t a = (uint64_t)top / f * f / m / f * f;
                xs[k++] = (uint32_t)(a > 0 ? a : f);
                xs[k++] = (uint32_t)(a > 0 ? a - 1 : f - 1);
            }
            while (k < 16 + 64)
                xs[k++] = (1u << 16) + next_rand() % (top - (1u << 16));
            for (int i = 0; i < k; i++) {
                uint16_t w1[2], w2[2];
                int n1 = 0, n2 = 0;
                const uint32_t c = f < (1u << bits) ? (1u << bits) - f : 0;
                uint32_t a = gv_rans_put(xs[i], f, c, bits, w1, &n1);
                uint32_t b = gv_rans_put_rcp(xs[i], f, rcp, c, bits, w2, &n2);
                bad += a != b || n1 != n2 || (n1 && w1[0] != w2[0]);
                tried++;
            }
        }
    check(bad == 0, "the rANS step by reciprocal equals the step by division "
          "(%ld of %ld states differ)", bad, tried);
    /* The bound is tight: a reciprocal one too small gives a wrong state. */
    uint16_t w[2];
    int n = 0;
    check(gv_rans_put_rcp(255u * 1000, 255, gv_rans_rcp(255) - 1, 0, 8, w, &n) !=
              gv_rans_put(255u * 1000, 255, 0, 8, w, &n),
          "a reciprocal one too small changes the state (negative control)");
}

int main(void)
{
    const size_t tb = gv_tile_bytes(3);
    uint8_t *parent = malloc(tb), *pred = malloc(tb), *orig = malloc(tb);
    uint8_t *recon = malloc(tb), *dec = malloc(tb);
    uint8_t *buf = malloc(gv_tilebuf_size(GV_MAX_RATE, 3));
    struct gv_tile_workspace *ws = gv_tile_workspace_new();
    struct gv_error err = {0};
    if (!parent || !pred || !orig || !recon || !dec || !buf || !ws)
        fail("out of memory");

    /* 1. Prediction formula, all four quadrants, random parent. */
    for (size_t i = 0; i < tb; i++)
        parent[i] = (uint8_t)next_rand();
    int bad = 0;
    for (int q = 0; q < 4; q++) {
        gv_predict(parent, 3, q & 1, q >> 1, pred);
        for (int v = 0; v < T; v += 7)
            for (int u = 0; u < T; u++)
                for (int c = 0; c < 3; c++)
                    bad += pred[(v * T + u) * 3 + c] !=
                           reference_pred(parent, 3, q & 1, q >> 1, u, v, c);
        for (int u = 0; u < T; u++)   /* the last row, always */
            bad += pred[(512 * T + u) * 3] != reference_pred(parent, 3, q & 1, q >> 1, u, 512, 0);
    }
    check(bad == 0, "prediction matches the written formula (%d mismatches)", bad);
    /* The taps of each 1-D filter sum to 128, so a flat parent predicts the
     * same value in every sample of every quadrant. */
    memset(parent, 77, tb);
    size_t not_flat = 0;
    for (int q = 0; q < 4; q++) {
        gv_predict(parent, 3, q & 1, q >> 1, pred);
        for (size_t i = 0; i < tb; i++)
            not_flat += pred[i] != 77;
    }
    check(not_flat == 0, "a flat parent (77) predicts 77 in every sample of "
          "all four quadrants (%zu differ)", not_flat);

    /* 2. Index packing: an independent LSB-first packer, read back at every
     *    rate through gv_tilebuf_index. */
    for (int r = 1; r <= GV_MAX_RATE; r++) {
        size_t len = gv_tilebuf_size(r, 3);
        memset(buf, 0, len);
        buf[0] = (uint8_t)r;
        uint64_t base = 8 * (1 + ((uint64_t)12 << r));
        for (uint32_t k = 0; k < GV_NBLOCKS; k++) {
            uint32_t val = (k * 2654435761u) & ((1u << r) - 1);
            for (int b = 0; b < r; b++)
                if (val >> b & 1) {
                    uint64_t bit = base + (uint64_t)k * r + b;
                    buf[bit >> 3] |= (uint8_t)(1u << (bit & 7));
                }
        }
        int wrong = gv_tilebuf_check(buf, len, 3, &err) != r;
        for (uint32_t k = 0; k < GV_NBLOCKS; k++)
            wrong += gv_tilebuf_index(buf, r, 3, k) != ((k * 2654435761u) & ((1u << r) - 1));
        check(wrong == 0 && len % 4 == 0 && len * 8 >= base + (uint64_t)GV_NBLOCKS * r &&
              len * 8 < base + (uint64_t)GV_NBLOCKS * r + 32,
              "rate %2d: %zu bytes, every index reads back", r, len);
    }

    check(GV_TILEBUF_MAX == gv_tilebuf_size(GV_MAX_RATE, 3), "GV_TILEBUF_MAX is right");

    /* 3. Encoder and decoder agree at capped rates, in both layouts: noise
     *    gives flat index histograms (fixed layout), a smooth tile with a
     *    little noise skewed ones (entropy-coded). */
    make_tile(parent, 3, 0);
    int rates[] = {1, 3, 6, 8, 10};
    int noises[] = {40, 6};
    int entropy_seen = 0, fixed_seen = 0;
    for (size_t ni = 0; ni < 2; ni++) {
        make_tile(orig, 3, noises[ni]);
        for (size_t i = 0; i < sizeof rates / sizeof rates[0]; i++) {
            struct gv_tile_params prm = {.target_mse = 0.01, .max_rate = rates[i], .seed = 1};
            struct gv_tile_stats st;
            size_t len = gv_tile_encode(ws, orig, parent, 1, 1, 3, T, T, &prm, recon, buf, &st);
            int okdec = gv_tile_decode(buf, len, 3, parent, 1, 1, dec, &err) == 0;
            int entropy = (buf[0] & 0x80) != 0;
            entropy_seen += entropy;
            fixed_seen += !entropy;
            check(okdec && st.rate == rates[i] && memcmp(dec, recon, tb) == 0 &&
                  (buf[0] & 0x0f) == rates[i] &&
                  len <= gv_tilebuf_size(rates[i], 3),
                  "rate %d, noise %d, %s layout, %zu bytes: decode == encoder "
                  "reconstruction (%.2f dB)", rates[i], noises[ni],
                  entropy ? "entropy-coded" : "fixed", len, psnr(orig, dec, tb));
        }
    }
    check(entropy_seen > 0 && fixed_seen > 0, "both layouts occur (%d entropy-coded, %d fixed)",
          entropy_seen, fixed_seen);

    /* Entropy-coded buffers under attack, in both layouts. */
    make_tile(orig, 3, 6);
    check_attacks(ws, orig, parent, buf);
    check_context_layout(parent);
    check_damaged_rows();
    gv_predict(parent, 3, 0, 1, orig);
    {
        struct gv_tile_params prm = {.target_mse = 1.0, .max_rate = 8, .seed = 1};
        struct gv_tile_stats st;
        size_t len = gv_tile_encode(ws, orig, parent, 0, 1, 3, T, T, &prm, recon, buf, &st);
        check(st.rate == 0 && len == 4 && st.sse == 0 &&
              gv_tile_decode(buf, len, 3, parent, 0, 1, dec, &err) == 0 &&
              memcmp(dec, orig, tb) == 0, "a predictable tile takes rate 0 (4 bytes)");
    }

    /* 4. The quality target holds on the valid region of an edge tile. */
    make_tile(orig, 3, 24);
    {
        struct gv_tile_params prm = {.target_mse = 65025.0 / pow(10, 3.3), .max_rate = 12, .seed = 7};
        struct gv_tile_stats st;
        size_t len = gv_tile_encode(ws, orig, parent, 0, 0, 3, 300, 200, &prm, recon, buf, &st);
        double sse = 0;
        for (int y = 0; y < 200; y++)
            for (int x = 0; x < 300 * 3; x++) {
                double d = orig[y * T * 3 + x] - recon[y * T * 3 + x];
                sse += d * d;
            }
        double p = 10 * log10(65025.0 * 300 * 200 * 3 / sse);
        check(gv_tile_decode(buf, len, 3, parent, 0, 0, dec, &err) == 0 &&
              st.samples == 300 * 200 * 3 && (uint64_t)sse == st.sse && p >= 33.0 &&
              st.rate < 12, "33 dB target met on a 300x200 valid region: %.2f dB at r=%d",
              p, st.rate);
    }

    /* 5. Hostile buffers are refused, not read past. */
    buf[0] = 13;
    gv_error_clear(&err);
    check_str(refusal(gv_tilebuf_check(buf, gv_tilebuf_size(12, 3), 3, &err), &err),
              "tile: bad rate byte 0x0d", "rate 13 refused");
    buf[0] = 5;
    gv_error_clear(&err);
    check_str(refusal(gv_tile_decode(buf, gv_tilebuf_size(5, 3) - 4, 3, parent, 0, 0,
                                     dec, &err), &err),
              "tile: 41664 bytes where rate 5 needs 41668", "short buffer refused");
    gv_error_clear(&err);
    check_str(refusal(gv_tilebuf_check(buf, 6, 3, &err), &err),
              "tile: buffer of 6 bytes is not a positive multiple of 4",
              "odd length refused");
    gv_error_clear(&err);
    check_str(refusal(gv_tilebuf_check(buf, 0, 3, &err), &err),
              "tile: buffer of 0 bytes is not a positive multiple of 4",
              "empty buffer refused");
    uint8_t *exact = malloc(gv_tilebuf_size(5, 1));
    memset(exact, 0xff, gv_tilebuf_size(5, 1));
    exact[0] = 5;
    uint8_t *g1 = calloc(1, gv_tile_bytes(1)), *g2 = malloc(gv_tile_bytes(1));
    check(gv_tile_decode(exact, gv_tilebuf_size(5, 1), 1, g1, 0, 0, g2, &err) == 0,
          "an exact-size gray buffer of all ones decodes in bounds");
    free(exact);
    free(g1);
    free(g2);

    /* 6. The biased search, code lengths, rate-distortion on a photo. */
    check_biased_search();
    check_log2();
    check_rd_photo(ws);

    /* 7. The rANS step by reciprocal equals the one by division. */
    check_rans_rcp();

    /* 8. The squared error (SIMD where the CPU has it) against a plain
     *    loop, with rows of every length mod 16 and the extreme values. */
    {
        enum { W = 1539, H = 5 };
        uint8_t *a = malloc(W * H), *b = malloc(W * H);
        for (int i = 0; i < W * H; i++) {
            a[i] = (uint8_t)next_rand();
            b[i] = i % 7 == 0 ? (uint8_t)(255 - a[i]) : (uint8_t)next_rand();
        }
        a[0] = 255;
        b[0] = 0;
        int wrong = 0;
        for (uint32_t n = 0; n <= 40; n++) {
            const uint32_t len = n < 33 ? n : W - (40 - n);
            uint64_t want = 0;
            for (int y = 0; y < H; y++)
                for (uint32_t i = 0; i < len; i++) {
                    const int d = a[y * W + i] - b[y * W + i];
                    want += (uint64_t)(d * d);
                }
            wrong += gv_sse_u8(a, b, len, H, W) != want;
        }
        check(wrong == 0, "gv_sse_u8 equals the plain sum for 41 row lengths "
              "(%d differ)", wrong);
        free(a);
        free(b);
    }

    gv_tile_workspace_free(ws);
    gv_tile_workspace_free(NULL);
    free(parent);
    free(pred);
    free(orig);
    free(recon);
    free(dec);
    free(buf);
    return tap_done();
}
