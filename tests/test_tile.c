/*
 * test_tile.c - the tile codec: the prediction formula, index packing at
 * every rate, encoder/decoder agreement, quality targets and hostile
 * buffers.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "store/geometry.h"
#include "codec/tile.h"
#include "util.h"

#define T GV_TILE

static uint64_t rng = 88172645463325252ull;
static uint32_t next_rand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (uint32_t)rng;
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

int main(void)
{
    const size_t tb = gv_tile_bytes(3);
    uint8_t *parent = malloc(tb), *pred = malloc(tb), *orig = malloc(tb);
    uint8_t *recon = malloc(tb), *dec = malloc(tb);
    uint8_t *buf = malloc(gv_tilebuf_size(GV_MAX_RATE, 3));
    struct gv_tile_workspace *ws = gv_tile_workspace_new();
    struct gv_error err;
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

    /* Entropy-coded buffers under attack: a single-byte change (every 7th
     * byte after the codebook: padding, cumulative frequencies, stream
     * lengths, streams) is refused - by the table and length checks, or
     * because a stream then ends early or not in its final state.  The
     * streams carry no checksum, so a changed stream word can still end
     * cleanly and decode, in bounds, to other indices: of this
     * (deterministic) tile's 6238 damaged copies exactly one does, the
     * word 33 of row 15's 81 at byte 3968. */
    {
        make_tile(orig, 3, 6);
        struct gv_tile_params prm = {.target_mse = 0.01, .max_rate = 6, .seed = 3};
        struct gv_tile_stats st;
        size_t len = gv_tile_encode(ws, orig, parent, 0, 0, 3, T, T, &prm, recon, buf, &st);
        uint8_t *copy = malloc(len);
        int refused = 0, decoded = 0;
        size_t decoded_at = 0, decoded_differ = 0;
        for (size_t pos = 1 + 64 * 12; pos < len; pos += 7) {
            memcpy(copy, buf, len);
            copy[pos] ^= 0x24;
            if (gv_tile_decode(copy, len, 3, parent, 0, 0, dec, &err) < 0) {
                refused++;
                continue;
            }
            decoded++;
            decoded_at = pos;
            decoded_differ = 0;
            for (size_t i = 0; i < tb; i++)
                decoded_differ += dec[i] != recon[i];
        }
        check((buf[0] & 0x80) && len == 44432 && refused == 6237 && decoded == 1,
              "damaged entropy-coded buffers (%zu bytes): %d refused, %d decoded",
              len, refused, decoded);
        check(decoded_at == 3968 && decoded_differ == 696,
              "the one that decodes is the stream word at byte 3968 (got %zu), "
              "to other indices (%zu samples differ)", decoded_at, decoded_differ);
        check_str(refusal(gv_tile_decode(buf, len - 4, 3, parent, 0, 0, dec, &err), &err),
                  "tile: streams need 43016 bytes, the buffer has 43012",
                  "a truncated entropy-coded buffer is refused");
        memcpy(copy, buf, len);
        copy[0] = 0x80;
        check_str(refusal(gv_tilebuf_check(copy, len, 3, &err), &err),
                  "tile: bad rate byte 0x80", "entropy flag at rate 0 is refused");
        copy[0] = 0x96;
        check_str(refusal(gv_tilebuf_check(copy, len, 3, &err), &err),
                  "tile: bad rate byte 0x96", "reserved bits are refused");
        free(copy);
    }
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
    check_str(refusal(gv_tilebuf_check(buf, gv_tilebuf_size(12, 3), 3, &err), &err),
              "tile: bad rate byte 0x0d", "rate 13 refused");
    buf[0] = 5;
    check_str(refusal(gv_tile_decode(buf, gv_tilebuf_size(5, 3) - 4, 3, parent, 0, 0,
                                     dec, &err), &err),
              "tile: 41664 bytes where rate 5 needs 41668", "short buffer refused");
    check_str(refusal(gv_tilebuf_check(buf, 6, 3, &err), &err),
              "tile: buffer of 6 bytes is not a positive multiple of 4",
              "odd length refused");
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
