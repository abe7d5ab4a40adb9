/*
 * test_lambda_model.c - the encoder's model of level 0's detail
 * (lib/encode/lambda_model.c) against the histogram written out here
 * independently: every 2x2 block's V = sum over channels and pixels of
 * (16 x - (9 a + 3 b + 3 c + d))^2 (lambda_model.h's definition, the
 * edges repeated), binned at 8 per octave of V + 1, on random rows of
 * odd and even widths and heights, gray and RGB.
 */
#include <stdlib.h>
#include <string.h>

#include "encode/lambda_model.h"
#include "util.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;

static int ref_bin(uint64_t v)
{
    int b = 0;
    uint64_t x = v + 1;
    int oct = 0;
    while (x >> (oct + 1))
        oct++;
    /* The three bits after the leading one (zeros past the end). */
    int frac = 0;
    for (int i = 1; i <= 3; i++)
        frac = 2 * frac + (oct - i >= 0 ? (int)(x >> (oct - i) & 1) : 0);
    b = oct * 8 + frac;
    return b < GV_LM_BINS ? b : GV_LM_BINS - 1;
}

/* Block row j's blocks into count/sum: rows L0[2j], L0[2j + 1] of width w,
 * level-1 rows L1[j - 1 .. j + 1] (clamped) of (w + 1) / 2 pixels. */
static void ref_row(uint8_t **L0, uint8_t **L1, int nb, int j, uint32_t w,
                    int c, uint64_t *count, uint64_t *sum, uint64_t *blocks)
{
    const int mw = (int)(w + 1) / 2;
    const uint8_t *at = L1[j], *above = L1[j > 0 ? j - 1 : 0],
                  *below = L1[j + 1 < nb ? j + 1 : nb - 1];
    for (int bx = 0; bx < (int)w / 2; bx++) {
        uint64_t v = 0;
        for (int dy = 0; dy < 2; dy++)
            for (int dx = 0; dx < 2; dx++) {
                int side = dx ? bx + 1 : bx - 1;
                if (side < 0)
                    side = 0;
                if (side >= mw)
                    side = mw - 1;
                const uint8_t *vert = dy ? below : above;
                for (int ch = 0; ch < c; ch++) {
                    long p = 9L * at[bx * c + ch] + 3L * at[side * c + ch] +
                             3L * vert[bx * c + ch] + vert[side * c + ch];
                    long e = 16L * L0[2 * j + dy][(2 * bx + dx) * c + ch] - p;
                    v += (uint64_t)(e * e);
                }
            }
        count[ref_bin(v)]++;
        sum[ref_bin(v)] += v;
        (*blocks)++;
    }
}

int main(void)
{
    static const uint32_t widths[] = {1, 2, 3, 4, 5, 17, 64, 101, 1000};
    static const int heights[] = {1, 2, 3, 5, 8};
    int cases = 0, bad = 0;
    for (size_t wi = 0; wi < sizeof widths / sizeof *widths; wi++)
        for (size_t hi = 0; hi < sizeof heights / sizeof *heights; hi++)
            for (int c = 1; c <= 3; c += 2)
                for (int smooth = 0; smooth < 2; smooth++) {
                    const uint32_t w = widths[wi];
                    const int nb = heights[hi];    /* block rows */
                    const size_t rb = (size_t)w * c, mb = (size_t)((w + 1) / 2) * c;
                    uint8_t **L0 = malloc(2 * nb * sizeof *L0);
                    uint8_t **L1 = malloc(nb * sizeof *L1);
                    for (int r = 0; r < 2 * nb; r++) {
                        L0[r] = malloc(rb);
                        for (size_t i = 0; i < rb; i++)   /* noise, or a ramp with a little */
                            L0[r][i] = (uint8_t)(smooth ? (i / c + r) * 3 % 256 + test_rand(&rng) % 3
                                                        : test_rand(&rng));
                    }
                    for (int r = 0; r < nb; r++) {
                        L1[r] = malloc(mb);
                        for (size_t i = 0; i < mb; i++)
                            L1[r][i] = (uint8_t)(smooth ? (2 * (i / c) + 2 * r) * 3 % 256
                                                        : test_rand(&rng));
                    }
                    struct gv_lambda_model m;
                    if (gv_lambda_model_init(&m, w, c) < 0)
                        fail("out of memory");
                    for (int r = 0; r < nb; r++)
                        gv_lambda_model_rows(&m, L0[2 * r], L0[2 * r + 1], L1[r]);
                    gv_lambda_model_finish(&m);
                    uint64_t count[GV_LM_BINS] = {0}, sum[GV_LM_BINS] = {0}, blocks = 0;
                    for (int r = 0; r < nb; r++)
                        ref_row(L0, L1, nb, r, w, c, count, sum, &blocks);
                    bad += memcmp(count, m.count, sizeof count) != 0 ||
                           memcmp(sum, m.sum, sizeof sum) != 0 || blocks != m.blocks;
                    cases++;
                    gv_lambda_model_free(&m);
                    for (int r = 0; r < 2 * nb; r++)
                        free(L0[r]);
                    for (int r = 0; r < nb; r++)
                        free(L1[r]);
                    free(L0);
                    free(L1);
                }
    check(bad == 0, "the model's histogram equals the definition's on %d "
          "images (%d differ)", cases, bad);

    /* Negative control: the comparison can fail; one level-1 pixel
     * changed changes the sums. */
    {
        const uint32_t w = 6;
        uint8_t r0[18], r1[18], red[9];
        for (int i = 0; i < 18; i++)
            r0[i] = r1[i] = (uint8_t)(10 * i);
        for (int i = 0; i < 9; i++)
            red[i] = (uint8_t)(20 * i);
        struct gv_lambda_model a, b;
        if (gv_lambda_model_init(&a, w, 3) < 0 || gv_lambda_model_init(&b, w, 3) < 0)
            fail("out of memory");
        gv_lambda_model_rows(&a, r0, r1, red);
        gv_lambda_model_finish(&a);
        red[8] ^= 0x40;
        gv_lambda_model_rows(&b, r0, r1, red);
        gv_lambda_model_finish(&b);
        check(memcmp(a.sum, b.sum, sizeof a.sum) != 0,
              "a changed level-1 pixel changes the sums (negative control)");
        gv_lambda_model_free(&a);
        gv_lambda_model_free(&b);
    }
    return tap_done();
}
