/*
 * test_render.c - gv_render against the reference decoder, and
 * gv_image_encode round trips.
 *
 * A 1500x1100 synthetic store (levels 0..1 tiled, level 2 the root, then
 * its mips) and a gray one are encoded into a temporary directory.  A
 * render at the region's own size must equal gv_decode_region at level 0
 * byte for byte, and a render of a level-aligned region at exactly level
 * k's size must equal gv_decode_region at level k (tiled levels, the root
 * and a root mip).  Rotation and mirroring are checked against index math
 * on the unrotated render, gray and bitonal against their formulas.  The
 * in-memory encoder must give back exactly the pixels for png and tif
 * (read back through OpenImageIO) and a close image for jpg and webp.
 * gv_render_to, with one buffer kept across a sequence of renders (tiles
 * at their level's size, which it decodes into the buffer, resampled,
 * rotated and gray ones, a larger one after smaller ones), gives
 * gv_render's pixels each time.
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "render/store_decoder.h"
#include "encode/stream_encoder.h"
#include "imageio/imageio.h"
#include "render/region.h"
#include "store/store_read.h"
#include "store_fixture.h"
#include "test_env.h"
#include "util.h"

static char dir[128];

struct img {
    uint8_t *px;
    uint32_t w, h;
    int c;
};

static void img_free(struct img *m)
{
    free(m->px);
    m->px = NULL;
}

static struct gv_render_req req_of(uint32_t x, uint32_t y, uint32_t w,
                                   uint32_t h, uint32_t ow, uint32_t oh)
{
    struct gv_render_req r;
    memset(&r, 0, sizeof r);
    r.x = x;
    r.y = y;
    r.w = w;
    r.h = h;
    r.out_w = ow;
    r.out_h = oh;
    r.quality = GV_QUALITY_DEFAULT;
    return r;
}

static int render(struct gv_decoder *d, const struct gv_render_req *r,
                  struct img *m, struct gv_error *err)
{
    memset(m, 0, sizeof *m);
    return gv_render(d, r, &m->px, &m->w, &m->h, &m->c, err);
}

static uint8_t *decode(struct gv_decoder *d, int level, uint32_t x,
                       uint32_t y, uint32_t w, uint32_t h, int c)
{
    struct gv_error err = {0};
    uint8_t *p = malloc((size_t)w * h * c);
    if (!p)
        fail("out of memory");
    if (gv_decode_region(d, level, x, y, w, h, p, &err) != 0)
        fail("decode level %d: %s", level, err.text);
    return p;
}

/* Render region (x,y,w,h) at ow x oh and compare with level `level`'s
 * region (lx,ly,ow,oh). */
static void check_exact(struct gv_decoder *d, int c, uint32_t x, uint32_t y,
                        uint32_t w, uint32_t h, uint32_t ow, uint32_t oh,
                        int level, uint32_t lx, uint32_t ly)
{
    struct gv_render_req r = req_of(x, y, w, h, ow, oh);
    struct img m;
    struct gv_error err = {0};
    int rc = render(d, &r, &m, &err);
    if (rc != 0) {
        check(0, "render %u,%u %ux%u at %ux%u: %s", x, y, w, h, ow, oh,
              err.text);
        return;
    }
    uint8_t *ref = decode(d, level, lx, ly, ow, oh, c);
    check(m.w == ow && m.h == oh && m.c == c
              && memcmp(m.px, ref, (size_t)ow * oh * c) == 0,
          "render %u,%u %ux%u at %ux%u == level %d decode", x, y, w, h, ow,
          oh, level);
    free(ref);
    img_free(&m);
}

/* Pixel (x, y) of the unrotated image u that lands at (X, Y) of the
 * rotated one, for a clockwise rotation after an optional mirror. */
static void source_of(uint32_t X, uint32_t Y, uint32_t uw, uint32_t uh,
                      int rot, int mirror, uint32_t *x, uint32_t *y)
{
    uint32_t mx, my;
    switch (rot) {
    case 90: mx = Y; my = uh - 1 - X; break;
    case 180: mx = uw - 1 - X; my = uh - 1 - Y; break;
    case 270: mx = uw - 1 - Y; my = X; break;
    default: mx = X; my = Y; break;
    }
    *x = mirror ? uw - 1 - mx : mx;
    *y = my;
}

static void check_rotations(struct gv_decoder *d)
{
    struct gv_render_req r = req_of(700, 450, 600, 400, 150, 100);
    struct img u, m;
    struct gv_error err = {0};
    if (render(d, &r, &u, &err) != 0)
        fail("render: %s", err.text);
    static const int rots[] = {0, 90, 180, 270};
    for (int mirror = 0; mirror < 2; mirror++)
        for (int i = 0; i < 4; i++) {
            if (!mirror && !rots[i])
                continue;
            r.rotation = rots[i];
            r.mirror = mirror;
            if (render(d, &r, &m, &err) != 0) {
                check(0, "render rotation %d mirror %d: %s", rots[i], mirror,
                      err.text);
                continue;
            }
            int odd = rots[i] == 90 || rots[i] == 270;
            int ok = m.c == u.c && m.w == (odd ? u.h : u.w)
                     && m.h == (odd ? u.w : u.h);
            for (uint32_t Y = 0; ok && Y < m.h; Y++)
                for (uint32_t X = 0; ok && X < m.w; X++) {
                    uint32_t sx, sy;
                    source_of(X, Y, u.w, u.h, rots[i], mirror, &sx, &sy);
                    ok = memcmp(m.px + ((size_t)Y * m.w + X) * m.c,
                                u.px + ((size_t)sy * u.w + sx) * u.c,
                                (size_t)u.c) == 0;
                }
            check(ok, "rotation %d mirror %d: %ux%u matches index math",
                  rots[i], mirror, m.w, m.h);
            img_free(&m);
        }
    /* the corners by hand: 90 degrees clockwise puts the top-left pixel at
     * the top-right */
    r.rotation = 90;
    r.mirror = 0;
    if (render(d, &r, &m, &err) == 0) {
        check(memcmp(m.px + (size_t)(m.w - 1) * 3, u.px, 3) == 0
                  && memcmp(m.px + ((size_t)(m.h - 1) * m.w + m.w - 1) * 3,
                            u.px + (size_t)(u.w - 1) * 3, 3) == 0,
              "rotation 90: top-left -> top-right, top-right -> "
              "bottom-right");
        img_free(&m);
    }

    /* quality */
    r.rotation = 0;
    struct img g, b, col;
    r.quality = GV_QUALITY_GRAY;
    int rc1 = render(d, &r, &g, &err);
    r.quality = GV_QUALITY_BITONAL;
    int rc2 = render(d, &r, &b, &err);
    r.quality = GV_QUALITY_COLOR;
    int rc3 = render(d, &r, &col, &err);
    if (rc1 || rc2 || rc3)
        fail("quality renders: %s", err.text);
    int okg = g.c == 1 && g.w == u.w && g.h == u.h;
    int okb = b.c == 1 && b.w == u.w && b.h == u.h;
    int bl = 0, wh = 0;
    for (size_t i = 0; okg && okb && i < (size_t)u.w * u.h; i++) {
        const uint8_t *p = u.px + i * 3;
        unsigned y = (299u * p[0] + 587u * p[1] + 114u * p[2] + 500u) / 1000u;
        okg = g.px[i] == y;
        okb = b.px[i] == (y >= 128 ? 255 : 0);
        bl += b.px[i] == 0;
        wh += b.px[i] == 255;
    }
    check(okg, "gray == (299R + 587G + 114B + 500) / 1000");
    check(okb && bl > 0 && wh > 0, "bitonal == gray >= 128 (%d black, %d "
          "white)", bl, wh);
    check(col.c == 3 && memcmp(col.px, u.px, (size_t)u.w * u.h * 3) == 0,
          "color of an RGB store == default");
    /* gray after mirror + rotation is the rotated gray */
    r.quality = GV_QUALITY_GRAY;
    r.rotation = 270;
    r.mirror = 1;
    if (render(d, &r, &m, &err) == 0) {
        int ok = m.c == 1 && m.w == u.h && m.h == u.w;
        for (uint32_t Y = 0; ok && Y < m.h; Y++)
            for (uint32_t X = 0; ok && X < m.w; X++) {
                uint32_t sx, sy;
                source_of(X, Y, u.w, u.h, 270, 1, &sx, &sy);
                ok = m.px[(size_t)Y * m.w + X] == g.px[(size_t)sy * g.w + sx];
            }
        check(ok, "gray with mirror and rotation 270");
        img_free(&m);
    } else {
        check(0, "gray with mirror and rotation 270: %s", err.text);
    }
    img_free(&g);
    img_free(&b);
    img_free(&col);
    img_free(&u);
}

static void check_scaling(struct gv_decoder *d)
{
    struct gv_error err = {0};
    struct img m;

    /* 2x upscale: sizes, and bilinear values at a corner and inside */
    struct gv_render_req r = req_of(100, 100, 50, 40, 100, 80);
    uint8_t *src = decode(d, 0, 100, 100, 50, 40, 3);
    if (render(d, &r, &m, &err) != 0) {
        check(0, "upscale: %s", err.text);
    } else {
        int ok = m.w == 100 && m.h == 80 && m.c == 3
                 && memcmp(m.px, src, 3) == 0;
        /* output (1,1): source (0.25, 0.25) */
        for (int ch = 0; ok && ch < 3; ch++) {
            double v = 0.5625 * src[ch] + 0.1875 * src[3 + ch]
                       + 0.1875 * src[50 * 3 + ch]
                       + 0.0625 * src[51 * 3 + ch];
            ok = fabs(m.px[(100 + 1) * 3 + ch] - v) <= 1.0;
        }
        check(ok, "2x upscale: 100x80, corner exact, bilinear inside");
        img_free(&m);
    }
    free(src);

    /* an unaligned downscale keeps the mean */
    r = req_of(3, 5, 1001, 999, 300, 290);
    src = decode(d, 0, 3, 5, 1001, 999, 3);
    if (render(d, &r, &m, &err) != 0) {
        check(0, "downscale: %s", err.text);
    } else {
        double a = 0, b = 0;
        for (size_t i = 0; i < (size_t)1001 * 999 * 3; i++)
            a += src[i];
        for (size_t i = 0; i < (size_t)300 * 290 * 3; i++)
            b += m.px[i];
        a /= 1001.0 * 999 * 3;
        b /= 300.0 * 290 * 3;
        check(m.w == 300 && m.h == 290 && fabs(a - b) < 1.5,
              "unaligned downscale 1001x999 -> 300x290: mean %.2f vs %.2f",
              a, b);
        img_free(&m);
    }
    free(src);

    /* the whole image as one pixel (the coarsest mip) */
    r = req_of(0, 0, 1500, 1100, 1, 1);
    if (render(d, &r, &m, &err) == 0) {
        check(m.w == 1 && m.h == 1 && m.c == 3, "whole image at 1x1");
        img_free(&m);
    } else {
        check(0, "whole image at 1x1: %s", err.text);
    }
    /* a distorted w,h: one axis up, the other down */
    r = req_of(200, 300, 40, 400, 120, 100);
    if (render(d, &r, &m, &err) == 0) {
        check(m.w == 120 && m.h == 100, "mixed upscale/downscale 40x400 -> "
              "120x100");
        img_free(&m);
    } else {
        check(0, "mixed scale: %s", err.text);
    }
}

static void check_errors(struct gv_decoder *d)
{
    struct gv_error err = {0};
    struct img m;
    struct gv_render_req r = req_of(0, 0, 1500, 1100, 1500, 1100);
    r.max_decode_pixels = 1000;
    gv_error_clear(&err);
    check(render(d, &r, &m, &err) != 0 && err.code == GV_ELIMIT,
          "max_decode_pixels exceeded -> GV_ELIMIT (%s)", err.text);
    r.max_decode_pixels = 1500 * 1100;
    if (render(d, &r, &m, &err) == 0) {
        check(1, "max_decode_pixels equal to the region is allowed");
        img_free(&m);
    } else {
        check(0, "max_decode_pixels equal to the region: %s", err.text);
    }
    /* a small output decodes a coarse level: the limit applies to it */
    r = req_of(0, 0, 1500, 1100, 100, 70);
    r.max_decode_pixels = 200 * 200;
    if (render(d, &r, &m, &err) == 0) {
        check(m.w == 100 && m.h == 70, "limit counts the decoded level's "
              "pixels, not level 0's");
        img_free(&m);
    } else {
        check(0, "small output under a limit: %s", err.text);
    }

    static const struct { uint32_t x, y, w, h, ow, oh; int rot; } bad[] = {
        {1500, 0, 1, 1, 1, 1, 0},   /* outside */
        {0, 1100, 1, 1, 1, 1, 0},
        {1, 0, 1500, 1, 1, 1, 0},   /* past the right edge */
        {0, 0, 0, 10, 1, 1, 0},     /* zero size */
        {0, 0, 10, 0, 1, 1, 0},
        {0, 0, 10, 10, 0, 1, 0},    /* zero output */
        {0, 0, 10, 10, 1, 0, 0},
        {0, 0, 10, 10, 1, 1, 45},   /* not a multiple of 90 */
        {0xffffffffu, 0, 2, 1, 1, 1, 0},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        r = req_of(bad[i].x, bad[i].y, bad[i].w, bad[i].h, bad[i].ow,
                   bad[i].oh);
        r.rotation = bad[i].rot;
        m.px = NULL;
        gv_error_clear(&err);
        int rc = render(d, &r, &m, &err);
        check(rc != 0 && err.code == GV_EINVAL && m.px == NULL,
              "bad request %u,%u %ux%u -> %ux%u rot %d -> GV_EINVAL",
              bad[i].x, bad[i].y, bad[i].w, bad[i].h, bad[i].ow, bad[i].oh,
              bad[i].rot);
    }
}

static void check_gray_store(struct gv_decoder *d)
{
    struct gv_error err = {0};
    struct img a, b, c;
    struct gv_render_req r = req_of(0, 0, 700, 600, 700, 600);
    check_exact(d, 1, 0, 0, 700, 600, 700, 600, 0, 0, 0);
    check_exact(d, 1, 0, 0, 700, 600, 350, 300, 1, 0, 0);
    r.out_w = 350;
    r.out_h = 300;
    int rc = render(d, &r, &a, &err);
    r.quality = GV_QUALITY_COLOR;
    rc |= render(d, &r, &b, &err);
    r.quality = GV_QUALITY_BITONAL;
    rc |= render(d, &r, &c, &err);
    if (rc)
        fail("gray store renders: %s", err.text);
    int okc = a.c == 1 && b.c == 3 && c.c == 1;
    for (size_t i = 0; okc && i < (size_t)350 * 300; i++)
        okc = b.px[3 * i] == a.px[i] && b.px[3 * i + 1] == a.px[i]
              && b.px[3 * i + 2] == a.px[i]
              && c.px[i] == (a.px[i] >= 128 ? 255 : 0);
    check(okc, "gray store: color replicates, bitonal thresholds");
    img_free(&a);
    img_free(&b);
    img_free(&c);
}

/* ---- gv_image_encode ---- */

static double psnr(const uint8_t *a, const uint8_t *b, size_t n)
{
    double se = 0;
    for (size_t i = 0; i < n; i++) {
        double e = (double)a[i] - b[i];
        se += e * e;
    }
    if (se == 0)
        return 99.0;
    return 10 * log10(255.0 * 255.0 * n / se);
}

/* Encode m as fmt, write the bytes to a file and read them back. */
static int roundtrip(const struct img *m, const char *fmt, int quality,
                     struct img *back, size_t *bytes)
{
    struct gv_error err = {0};
    uint8_t *data = NULL;
    size_t len = 0;
    memset(back, 0, sizeof *back);
    if (gv_image_encode(fmt, m->w, m->h, m->c, m->px, quality, &data, &len,
                        &err) != 0) {
        printf("# encode %s: %s\n", fmt, err.text);
        return -1;
    }
    *bytes = len;
    char path[256];
    snprintf(path, sizeof path, "%s/enc.%s", dir, fmt);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, len, f) != len || fclose(f) != 0)
        fail("cannot write %s", path);
    free(data);
    struct gv_image_info info;
    struct gv_image_in *in = gv_image_open(path, 1u << 30, &info, &err);
    if (!in) {
        printf("# read back %s: %s\n", fmt, err.text);
        unlink(path);
        return -1;
    }
    back->w = info.width;
    back->h = info.height;
    back->c = info.channels;
    int rc = -1;
    if (info.sample == GV_SAMPLE_U8) {
        back->px = malloc((size_t)info.width * info.height * info.channels);
        if (back->px && gv_image_read(in, info.height, back->px, &err) == 0)
            rc = 0;
    }
    gv_image_close(in);
    unlink(path);
    return rc;
}

struct thread_job {
    const struct img *m;
    uint8_t *data;
    size_t len;
    int rc;
};

static void *encode_thread(void *arg)
{
    struct thread_job *j = arg;
    struct gv_error err = {0};
    j->rc = gv_image_encode("png", j->m->w, j->m->h, j->m->c, j->m->px, 90,
                            &j->data, &j->len, &err);
    return NULL;
}

static void check_encode(struct gv_decoder *d)
{
    struct gv_error err = {0};
    struct img m, g, back;
    size_t bytes;
    struct gv_render_req r = req_of(0, 0, 1500, 1100, 375, 275);
    if (render(d, &r, &m, &err) != 0)
        fail("render: %s", err.text);
    r.quality = GV_QUALITY_GRAY;
    if (render(d, &r, &g, &err) != 0)
        fail("render: %s", err.text);
    const size_t n = (size_t)m.w * m.h * 3;

    static const char *const exact[] = {"png", "tif"};
    for (int i = 0; i < 2; i++) {
        int rc = roundtrip(&m, exact[i], 90, &back, &bytes);
        check(rc == 0 && back.w == m.w && back.h == m.h && back.c == 3
                  && memcmp(back.px, m.px, n) == 0,
              "%s: RGB %ux%u round trip is exact (%zu bytes)", exact[i], m.w,
              m.h, bytes);
        img_free(&back);
        rc = roundtrip(&g, exact[i], 90, &back, &bytes);
        check(rc == 0 && back.w == g.w && back.h == g.h && back.c == 1
                  && memcmp(back.px, g.px, (size_t)g.w * g.h) == 0,
              "%s: gray round trip is exact", exact[i]);
        img_free(&back);
    }
    /* The synthetic store is full of per-pixel noise, which lossy codecs
     * are right to smooth: judge them on a smooth image of the same size
     * (gradients and a disc with a soft edge). */
    struct img sm = {malloc(n), m.w, m.h, 3};
    if (!sm.px)
        fail("out of memory");
    for (uint32_t y = 0; y < sm.h; y++)
        for (uint32_t x = 0; x < sm.w; x++) {
            double dx = x - 180.0, dy = y - 140.0;
            double disc = 80.0 / (1.0 + exp((sqrt(dx * dx + dy * dy) - 90) / 4));
            uint8_t *q = sm.px + ((size_t)y * sm.w + x) * 3;
            q[0] = (uint8_t)(x * 200 / sm.w + disc / 2);
            q[1] = (uint8_t)(y * 200 / sm.h + disc / 4);
            q[2] = (uint8_t)(100 + disc);
        }
    static const char *const lossy[] = {"jpg", "webp"};
    for (int i = 0; i < 2; i++) {
        int rc = roundtrip(&sm, lossy[i], 90, &back, &bytes);
        double p = rc == 0 && back.c == 3 && back.w == m.w && back.h == m.h
                       ? psnr(back.px, sm.px, n) : 0;
        check(p > 30, "%s q90: %ux%u, PSNR %.1f dB > 30 (%zu bytes)",
              lossy[i], back.w, back.h, p, bytes);
        img_free(&back);
        size_t big = bytes;
        rc = roundtrip(&sm, lossy[i], 20, &back, &bytes);
        check(rc == 0 && back.w == m.w && bytes < big,
              "%s: quality 20 is smaller than 90 (%zu < %zu bytes)",
              lossy[i], bytes, big);
        img_free(&back);
    }
    /* gray jpg */
    {
        int rc = roundtrip(&g, "jpg", 90, &back, &bytes);
        double p = rc == 0 && back.c == 1 && back.w == g.w
                       ? psnr(back.px, g.px, (size_t)g.w * g.h) : 0;
        check(p > 30, "jpg gray: PSNR %.1f dB", p);
        img_free(&back);
    }
    uint8_t *data = NULL;
    size_t len;
    gv_error_clear(&err);
    check(gv_image_encode("gif", m.w, m.h, 3, m.px, 90, &data, &len, &err)
                  != 0 && err.code == GV_EFORMAT && !data,
          "gif -> GV_EFORMAT (%s)", err.text);
    gv_error_clear(&err);
    check(gv_image_encode("bmp", m.w, m.h, 3, m.px, 90, &data, &len, &err)
                  != 0 && err.code == GV_EFORMAT,
          "bmp -> GV_EFORMAT");
    gv_error_clear(&err);
    check(gv_image_encode("png", m.w, m.h, 2, m.px, 90, &data, &len, &err)
                  != 0 && err.code == GV_EINVAL,
          "2 channels -> GV_EINVAL");

    /* from several threads at once: the same bytes */
    struct thread_job jobs[4];
    pthread_t th[4];
    for (int i = 0; i < 4; i++) {
        jobs[i].m = &m;
        jobs[i].data = NULL;
        jobs[i].rc = -1;
        if (pthread_create(&th[i], NULL, encode_thread, &jobs[i]) != 0)
            fail("pthread_create");
    }
    int same = 1;
    for (int i = 0; i < 4; i++)
        pthread_join(th[i], NULL);
    for (int i = 0; i < 4; i++)
        same = same && jobs[i].rc == 0 && jobs[i].len == jobs[0].len
               && memcmp(jobs[i].data, jobs[0].data, jobs[0].len) == 0;
    check(same, "4 threads encoding png at once agree");
    for (int i = 0; i < 4; i++)
        free(jobs[i].data);
    img_free(&m);
    img_free(&g);
    img_free(&sm);
}

/* gv_render_to with one buffer kept across renders equals gv_render. */
static void check_render_to(struct gv_decoder *d)
{
    struct gv_render_req reqs[8] = {
        req_of(0, 0, 512, 512, 512, 512),       /* a tile, decoded in place */
        req_of(512, 512, 512, 512, 512, 512),
        req_of(0, 0, 1024, 1024, 512, 512),     /* level 1, in place */
        req_of(100, 100, 700, 500, 333, 222),   /* resampled */
        req_of(0, 0, 512, 512, 512, 512),
        req_of(0, 0, 1500, 1100, 1500, 1100),   /* larger than before */
        req_of(512, 0, 512, 512, 512, 512),
        req_of(0, 0, 1024, 1024, 512, 512)};
    reqs[4].rotation = 90;
    reqs[6].quality = GV_QUALITY_GRAY;
    uint8_t *buf = NULL;
    size_t cap = 0;
    for (int i = 0; i < 8; i++) {
        struct img want;
        struct gv_error e1 = {0}, e2 = {0};
        uint32_t w = 0, h = 0;
        int c = 0;
        int r1 = render(d, &reqs[i], &want, &e1);
        int r2 = gv_render_to(d, &reqs[i], &buf, &cap, &w, &h, &c, &e2);
        check(r1 == 0 && r2 == 0 && w == want.w && h == want.h &&
              c == want.c && cap >= (size_t)w * h * c &&
              memcmp(buf, want.px, (size_t)w * h * c) == 0,
              "gv_render_to, render %d of one kept buffer (%ux%u x%d, "
              "buffer %zu bytes): gv_render's pixels", i, w, h, c, cap);
        img_free(&want);
    }
    free(buf);
}

int main(void)
{
    test_tmpdir_new(dir, sizeof dir, "gv-test-render");
    struct gv_store *s = fixture_store(dir, "rgb.gv", "synth:1500x1100", 0);
    struct gv_store *sg = fixture_store(dir, "gray.gv", "synth:700x600:gray", 0);
    struct gv_decoder *d = gv_decoder_new(s, 64u << 20);
    struct gv_decoder *dg = gv_decoder_new(sg, 64u << 20);
    if (!d || !dg)
        fail("decoder");
    const struct gv_geometry *g = &gv_store_info(s)->geometry;
    check(g->root == 2 && g->root_mips >= 4, "store: root %d, %d mips",
          g->root, g->root_mips);

    /* level 0: at the region's own size, identical to the decoder */
    check_exact(d, 3, 0, 0, 1500, 1100, 1500, 1100, 0, 0, 0);
    check_exact(d, 3, 100, 200, 700, 600, 700, 600, 0, 100, 200);
    check_exact(d, 3, 511, 511, 3, 3, 3, 3, 0, 511, 511);
    check_exact(d, 3, 1499, 1099, 1, 1, 1, 1, 0, 1499, 1099);
    /* level-aligned regions at level k's size */
    check_exact(d, 3, 0, 0, 1500, 1100, 750, 550, 1, 0, 0);
    check_exact(d, 3, 512, 256, 768, 512, 384, 256, 1, 256, 128);
    check_exact(d, 3, 512, 256, 768, 512, 192, 128, 2, 128, 64);
    check_exact(d, 3, 0, 0, 1500, 1100, 375, 275, 2, 0, 0);
    check_exact(d, 3, 0, 0, 1024, 1024, 128, 128, 3, 0, 0);
    check_exact(d, 3, 1024, 512, 256, 256, 16, 16, 4, 64, 32);
    /* odd edge: the last level-1 pixel covers only one level-0 column */
    check_exact(d, 3, 1498, 1098, 2, 2, 1, 1, 1, 749, 549);

    check_rotations(d);
    check_scaling(d);
    check_errors(d);
    check_gray_store(dg);
    check_encode(d);
    check_render_to(d);

    gv_decoder_free(d);
    gv_decoder_free(dg);
    gv_store_close(s);
    gv_store_close(sg);
    test_tmpdir_free(dir);
    return tap_done();
}
