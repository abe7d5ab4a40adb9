/*
 * test_roundtrip.c - encode real photographs (and procedural images) with
 * gv_encode, then check every tile of every level independently: the
 * original pyramid is rebuilt here from the input rows and each tile is
 * decoded by the reference decoder.  In the per-tile mode its PSNR over
 * the pixels inside the image must reach the target unless the tile sits
 * at the rate cap; in the default mode, the whole level 0 must land within
 * WHOLE_TOL dB of the target.  Regions must agree with tiles, and the PSNR
 * the encoder recorded for level 0 must be the one measured here.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "render/store_decoder.h"
#include "encode/stream_encoder.h"
#include "encode/source.h"
#include "store/store_format.h"
#include "store/store_read.h"
#include "codec/tile.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

/* Default mode: |level-0 PSNR - target| at most PHOTO_TOL dB on the
 * photographs, SYNTH_TOL on the procedural image, whose hard edges the
 * model of lambda_model.h was not fitted on.  Measured: +0.33
 * (seeding-640x480 at 40), +0.09 (picos at 40), -0.69 (seeding-700x520
 * at 50), -3.51 (synth:1500x1100 at 40). */
#define PHOTO_TOL 1.5
#define SYNTH_TOL 4.0

/* The whole input as 8-bit rows, and its box pyramid. */
struct pyramid {
    int levels, channels;
    uint32_t w[GV_MAX_LEVELS], h[GV_MAX_LEVELS];
    uint8_t *px[GV_MAX_LEVELS];
};

static int load_pyramid(const char *input, struct pyramid *p, const struct gv_geometry *g)
{
    struct gv_source_opts o = {0};
    struct gv_source_info info;
    struct gv_error err = {0};
    const char *in[1] = {input};
    struct gv_source *s = gv_source_open(in, 1, &o, &info, &err);
    if (!s)
        return -1;
    p->channels = info.channels;
    p->levels = g->root + 1;
    p->w[0] = info.width;
    p->h[0] = info.height;
    p->px[0] = malloc((size_t)info.width * info.height * info.channels);
    int rc = gv_source_read(s, info.height, p->px[0], &err);
    gv_source_free(s);
    for (int k = 1; k < p->levels; k++) {
        p->w[k] = (p->w[k - 1] + 1) / 2;
        p->h[k] = (p->h[k - 1] + 1) / 2;
        p->px[k] = malloc((size_t)p->w[k] * p->h[k] * p->channels);
        gv_box_reduce(p->px[k - 1], p->w[k - 1], p->h[k - 1], p->channels, p->px[k]);
    }
    return rc;
}

static void free_pyramid(struct pyramid *p)
{
    for (int k = 0; k < p->levels; k++)
        free(p->px[k]);
}

/* Encode `input` at `psnr` (per tile, or for the whole image) and check
 * it. */
static void roundtrip(const char *input, double psnr, int max_rate, int per_tile)
{
    const double whole_tol = strncmp(input, "synth:", 6) ? PHOTO_TOL : SYNTH_TOL;
    char out[256];
    snprintf(out, sizeof out, "%s/rt.gv", dir);
    struct gv_encode_opts o;
    gv_encode_opts_default(&o);
    o.target_psnr = psnr;
    o.max_rate = max_rate;
    o.per_tile = per_tile;
    struct gv_encode_result r;
    struct gv_error err = {0};
    const char *in[1] = {input};
    const char *name = strrchr(input, '/') ? strrchr(input, '/') + 1 : input;
    if (!check(gv_encode(in, 1, out, &o, &r, &err) == 0, "%s: encode at %.0f dB", name, psnr)) {
        printf("# %s\n", err.text);
        return;
    }
    struct gv_store *s = gv_store_open(out, &err);
    if (!check(s != NULL, "%s: reopen", name))
        return;
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    struct pyramid p;
    memset(&p, 0, sizeof p);
    if (load_pyramid(input, &p, g) < 0)
        fail("cannot reread %s", input);
    const int c = g->channels;
    struct gv_decoder *d = gv_decoder_new(s, 32u << 20);
    int tiles = 0, missed = 0, capped = 0, errors = 0;
    double worst = 99.0;
    uint64_t sse0 = 0;
    for (int k = g->root - 1; k >= 0; k--) {
        const struct gv_level *l = &g->level[k];
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++) {
                const uint8_t *t;
                if (gv_decoder_tile(d, k, tx, ty, &t, &err) < 0) {
                    errors++;
                    continue;
                }
                uint8_t *page;
                size_t plen, tlen;
                const uint8_t *buf;
                int rate = -1;
                if (gv_store_read_page(s, k, tx / 8, ty / 8, &page, &plen, &err) == 0) {
                    if (gv_page_tile(page, plen, c, (int)(tx % 8), (int)(ty % 8), &buf,
                                     &tlen, &err) == 0)
                        rate = buf[0] & 0x0f;
                    free(page);
                }
                uint32_t vw = l->width - tx * 512 < 513 ? l->width - tx * 512 : 513;
                uint32_t vh = l->height - ty * 512 < 513 ? l->height - ty * 512 : 513;
                double sse = 0;
                for (uint32_t v = 0; v < vh; v++)
                    for (uint32_t u = 0; u < vw * (uint32_t)c; u++) {
                        double dd = (double)t[(size_t)v * 513 * c + u] -
                                    p.px[k][((size_t)(ty * 512 + v) * l->width + tx * 512) * c + u];
                        sse += dd * dd;
                    }
                double tp = sse == 0 ? 99.0 : 10 * log10(65025.0 * vw * vh * c / sse);
                tiles++;
                if (tp < worst)
                    worst = tp;
                if (tp < psnr - 1e-9) {
                    if (rate == max_rate)
                        capped++;
                    else
                        missed++;
                }
            }
    }
    if (per_tile)
        check(errors == 0 && missed == 0,
              "%s: %d tiles meet %.0f dB (worst %.2f, %d at the cap, %d missed)", name,
              tiles, psnr, worst, capped, missed);
    else
        check(errors == 0 && fabs(r.psnr0 - psnr) <= whole_tol && r.lambda > 0,
              "%s: %d tiles, level 0 at %.2f dB for a %.0f dB target (lambda %.1f)",
              name, tiles, r.psnr0, psnr, r.lambda);

    /* Level 0 through the region path, against the input. */
    uint8_t *region = malloc((size_t)g->width * g->height * c);
    int rok = gv_decode_region(d, 0, 0, 0, g->width, g->height, region, &err) == 0;
    for (size_t i = 0; rok && i < (size_t)g->width * g->height * c; i++) {
        double dd = (double)region[i] - p.px[0][i];
        sse0 += (uint64_t)(dd * dd);
    }
    double p0 = sse0 == 0 ? 99.0 : 10 * log10(65025.0 * g->width * g->height * c / (double)sse0);
    double recorded = gv_store_info(s)->header.psnr0_mdb / 1000.0;
    check(rok && fabs(p0 - recorded) < 0.002 && fabs(p0 - r.psnr0) < 0.002,
          "%s: level-0 PSNR %.3f dB measured, %.3f recorded", name, p0, recorded);
    /* A sub-region straddling a tile seam equals the full decode. */
    if (g->width > 600 && g->height > 40) {
        uint32_t rx = 500, ry = 10, rw = 30, rh = 20;
        uint8_t *sub = malloc((size_t)rw * rh * c);
        int same = gv_decode_region(d, 0, rx, ry, rw, rh, sub, &err) == 0;
        for (uint32_t y = 0; same && y < rh; y++)
            same = memcmp(sub + (size_t)y * rw * c,
                          region + ((size_t)(ry + y) * g->width + rx) * c, (size_t)rw * c) == 0;
        check(same, "%s: a region across the seam at x=512 matches", name);
        free(sub);
    }
    /* The root mip 0 is the top pyramid level as its near-lossless
     * approximation for the target gives it (exactly the level when the
     * target asks for a lossless root, or the root is level 0). */
    uint32_t rw0, rh0;
    const uint8_t *root = gv_store_root(s, 0, &rw0, &rh0);
    const size_t rbytes = (size_t)p.w[g->root] * p.h[g->root] * c;
    uint8_t *approx = malloc(rbytes);
    memcpy(approx, p.px[g->root], rbytes);
    const int nl = g->root > 0 ? gv_root_near_lossless(psnr) : 100;
    if (gv_root_approx(approx, p.w[g->root], p.h[g->root], c, nl, &err) < 0)
        fail("root approximation: %s", err.text);
    double rsse = 0;
    for (size_t i = 0; root && i < rbytes; i++)
        rsse += ((double)root[i] - p.px[g->root][i]) * ((double)root[i] - p.px[g->root][i]);
    check(root && rw0 == p.w[g->root] && rh0 == p.h[g->root] &&
          memcmp(root, approx, rbytes) == 0 && (nl < 100 || rsse == 0),
          "%s: root %ux%u is the near-lossless approximation at %d (%.2f dB)", name,
          rw0, rh0, nl, rsse == 0 ? 99.0 : 10 * log10(65025.0 * (double)rbytes / rsse));
    free(approx);
    free(region);
    gv_decoder_free(d);
    gv_store_close(s);
    free_pyramid(&p);
    unlink(out);
}

int main(void)
{
    const char *data = test_data_dir();
    test_tmpdir_new(dir, sizeof dir, "gv-test-roundtrip");
    char a[512], b[512], c[512], d[512];
    snprintf(a, sizeof a, "%s/seeding-640x480.jpg", data);
    snprintf(b, sizeof b, "%s/seeding-700x520.png", data);
    snprintf(c, sizeof c, "%s/etopo-600x400-u16.png", data);
    snprintf(d, sizeof d, "%s/picos-1100x700.jpg", data);
    /* The default mode: one slope for the whole image. */
    roundtrip(a, 40.0, 10, 0);
    roundtrip(d, 40.0, 10, 0);
    roundtrip(b, 50.0, 10, 0);   /* smooth: 47.8 dB with no bits at all */
    roundtrip("synth:1500x1100", 40.0, 10, 0);
    /* The per-tile mode. */
    roundtrip(a, 34.0, 10, 1);
    roundtrip(d, 36.0, 10, 1);   /* a busy mountain scene, two tiled levels */
    roundtrip(d, 30.0, 6, 1);
    roundtrip(b, 38.0, 10, 1);
    roundtrip(b, 30.0, 4, 1);
    roundtrip(c, 40.0, 10, 1);
    roundtrip("synth:1500x1100", 36.0, 10, 1);
    roundtrip("synth:1100x1500:gray", 33.0, 8, 1);
    roundtrip("synth:2100x700", 45.0, 3, 1);   /* a cap that binds */
    /* Widths whose last tile's parent exists only because a level has at
     * least half the tiles of the level below (1026: 3 tiles over a level
     * of 513 pixels; 2050: 5 tiles, then 3 and 2). */
    roundtrip("synth:1026x600", 36.0, 10, 1);
    roundtrip("synth:600x2050:gray", 36.0, 10, 1);
    test_tmpdir_free(dir);
    return tap_done();
}
