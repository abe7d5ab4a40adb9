/*
 * test_filter_run.c - the filter templates on the EGL context (llvmpipe in
 * CI), against CPU computations written here from docs/FILTERS.md:
 *
 *   - point: negate, exact; a body reading abs_pos/rel_pos/filterArea;
 *   - kernel module: a 5x5 kernel in the middle of a region and at its
 *     edge (the padding clipped there), within 1e-5;
 *   - logreduce: block maxima aligned to level coordinates, read back
 *     through $(FilterInput1)(p, lod), exact;
 *   - propagation: integer prefix sums along every direction, and a +x
 *     sweep followed by a -x sweep (merge skipped: the pass, merge and
 *     line-copy counts are checked), exact; then all of it again as
 *     compute shaders;
 *   - the distance transform of FILTERS.md's four sweeps against a scalar
 *     implementation of the same rules (sites identical);
 *   - values: 6 channels of 16-bit codes through values and values2 as
 *     code * scale + offset rounded to float, exact, channels past the
 *     sample's 0, an image's bytes where a run gives no values, a kernel
 *     over values at the region's edge;
 *   - a GLSL error reported with the module and the body's line.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "filter.h"
#include "gpu/gpu.h"
#include "util.h"

static uint32_t rng = 12345;
static uint32_t rnd(void)
{
    rng = rng * 1664525u + 1013904223u;
    return rng >> 8;
}

static struct gv_filter_graph *parse(const char *json)
{
    struct gv_error err = {0};
    struct gv_filter_graph *g = gv_filter_graph_parse(json, strlen(json), NULL, &err);
    if (!g)
        fail("parse: %s\n%s", err.text, json);
    return g;
}

/* Run g on img (w x h RGBA8) with the ROI at (rx, ry, rw, rh), abs origin
 * (ax, ay).  Returns the float ROI or NULL (message printed). */
static enum gv_filter_path path = GV_FILTER_PATH_FRAGMENT;

static float *run(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                  const uint8_t *img, int w, int h, int rx, int ry, int rw, int rh,
                  int ax, int ay, struct gv_filter_stats *st)
{
    double params[64];
    struct gv_error err = {0};
    if (gv_filter_params(g, NULL, params, &err) < 0)
        fail("params: %s", err.text);
    struct gv_filter_input in = {
        .w = (uint32_t)w, .h = (uint32_t)h, .rgba = img,
        .roi_x = (uint32_t)rx, .roi_y = (uint32_t)ry, .roi_w = (uint32_t)rw,
        .roi_h = (uint32_t)rh, .abs_x = ax, .abs_y = ay, .params = params,
        .path = path};
    float *out = NULL;
    if (gv_filter_run(gpu, g, &in, &out, st, &err) < 0) {
        printf("# run: %s\n", err.text);
        return NULL;
    }
    return out;
}

static uint8_t *random_image(int w, int h)
{
    uint8_t *p = malloc((size_t)w * h * 4);
    for (int i = 0; i < w * h * 4; i++)
        p[i] = (uint8_t)rnd();
    return p;
}

static void test_point(struct gv_gpu *gpu)
{
    int w = 37, h = 23;
    uint8_t *img = random_image(w, h);
    struct gv_filter_graph *g = parse(
        "{\"name\":\"neg\",\"output\":\"n\",\"modules\":[{\"id\":\"n\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"vec4 s = $(FilterInput1)(rel_pos);\\n"
        "return vec4(1.0 - s.rgb, s.a);\"}]}");
    struct gv_filter_stats st;
    float *out = run(gpu, g, img, w, h, 3, 2, 30, 20, 100, 200, &st);
    double maxd = out ? 0 : 1e9;
    for (int y = 0; out && y < 20; y++)
        for (int x = 0; x < 30; x++)
            for (int c = 0; c < 4; c++) {
                float v = img[((size_t)(y + 2) * w + x + 3) * 4 + c] / 255.0f;
                float want = c < 3 ? 1.0f - v : v;
                double d = fabs(out[((size_t)y * 30 + x) * 4 + c] - want);
                if (d > maxd)
                    maxd = d;
            }
    check(maxd < 1e-6, "point negate: max difference %g", maxd);
    check(st.passes == 1 && st.textures == 1, "point: 1 pass (%d), 1 texture (%d)",
          st.passes, st.textures);
    free(out);
    gv_filter_graph_free(g);

    /* Predefined variables. */
    g = parse("{\"name\":\"vars\",\"output\":\"v\",\"modules\":[{\"id\":\"v\","
              "\"template\":\"point\",\"inputs\":[\"source\"],\"glsl\":"
              "\"return vec4(float(abs_pos.x), float(abs_pos.y), float(rel_pos.x) + "
              "filterArea.x * 1000.0, pixelsAround.x + 10.0 * pixelsAround.w);\"}]}");
    out = run(gpu, g, img, w, h, 3, 2, 30, 20, 100, 200, NULL);
    int bad = out ? 0 : 1;
    for (int y = 0; out && y < 20; y++)
        for (int x = 0; x < 30; x++) {
            const float *o = &out[((size_t)y * 30 + x) * 4];
            if (o[0] != 103 + x || o[1] != 202 + y || o[2] != x + 30000.0f ||
                o[3] != 3 + 10.0f * 1)
                bad++;
        }
    check(bad == 0, "abs_pos, rel_pos, filterArea, pixelsAround: %d wrong texels", bad);
    free(out);
    gv_filter_graph_free(g);
    free(img);
}

static void test_kernel(struct gv_gpu *gpu)
{
    int w = 64, h = 48;
    uint8_t *img = random_image(w, h);
    float k[25];
    char weights[512] = "";
    for (int i = 0; i < 25; i++) {
        k[i] = (float)((int)(rnd() % 9) - 4);
        snprintf(weights + strlen(weights), sizeof weights - strlen(weights), "%s%g",
                 i ? "," : "", (double)k[i]);
    }
    char json[1024];
    snprintf(json, sizeof json,
             "{\"name\":\"k\",\"output\":\"k\",\"modules\":[{\"id\":\"k\",\"template\":"
             "\"point\",\"inputs\":[\"source\"],\"kernel\":{\"width\":5,\"height\":5,"
             "\"weights\":[%s],\"scale\":0.25,\"bias\":0.5}}]}", weights);
    struct gv_filter_graph *g = parse(json);
    check(g->pad_left == 2 && g->pad_bottom == 2, "5x5 kernel: padding 2 (%d)",
          g->pad_left);
    /* The ROI in the middle (padding present) and at the top-left corner
     * (the region's edge is the image's edge: clamped reads). */
    const int roi[2][4] = {{10, 8, 40, 30}, {0, 0, 20, 20}};
    for (int t = 0; t < 2; t++) {
        int rx = roi[t][0], ry = roi[t][1], rw = roi[t][2], rh = roi[t][3];
        float *out = run(gpu, g, img, w, h, rx, ry, rw, rh, 0, 0, NULL);
        double maxd = out ? 0 : 1e9;
        for (int y = 0; out && y < rh; y++)
            for (int x = 0; x < rw; x++)
                for (int c = 0; c < 4; c++) {
                    float acc = 0;
                    for (int j = 0; j < 5; j++)
                        for (int i = 0; i < 5; i++) {
                            int sx = rx + x + i - 2, sy = ry + y + j - 2;
                            sx = sx < 0 ? 0 : sx >= w ? w - 1 : sx;
                            sy = sy < 0 ? 0 : sy >= h ? h - 1 : sy;
                            acc += k[j * 5 + i] * (img[((size_t)sy * w + sx) * 4 + c] / 255.0f);
                        }
                    double d = fabs(out[((size_t)y * rw + x) * 4 + c] - (0.5f + 0.25f * acc));
                    if (d > maxd)
                        maxd = d;
                }
        check(maxd < 1e-5, "5x5 kernel, ROI %s: max difference %g",
              t ? "at the corner" : "in the middle", maxd);
        free(out);
    }
    gv_filter_graph_free(g);
    free(img);
}

static void test_logreduce(struct gv_gpu *gpu)
{
    /* A region whose top-left is level (40, 16): a multiple of 8, as the
     * server aligns it; 8x8 maxima read back at lod 3. */
    int w = 75, h = 50, ax = 40, ay = 16;
    uint8_t *img = random_image(w, h);
    struct gv_filter_graph *g = parse(
        "{\"name\":\"max\",\"output\":\"show\",\"modules\":["
        "{\"id\":\"max\",\"template\":\"logreduce\",\"max_passes\":3,\"inputs\":[\"source\"],"
        "\"glsl\":\"ivec2 q = 2 * texel_pos;\\nreturn max(max($(FilterInput1)(q), "
        "$(FilterInput1)(q + ivec2(1, 0))), max($(FilterInput1)(q + ivec2(0, 1)), "
        "$(FilterInput1)(q + ivec2(1, 1))));\"},"
        "{\"id\":\"show\",\"template\":\"point\",\"inputs\":[\"max\"],"
        "\"glsl\":\"return $(FilterInput1)(rel_pos, 3);\"}]}");
    check(g->align == 8, "logreduce of 3 passes: alignment 8 (%d)", g->align);
    check(g->pad_left == 7, "logreduce of 3 passes: padding 7 (%d)", g->pad_left);
    struct gv_filter_stats st;
    int rx = 5, ry = 3, rw = 70, rh = 47;   /* to the odd right and bottom edges */
    float *out = run(gpu, g, img, w, h, rx, ry, rw, rh, ax, ay, &st);
    int bad = out ? 0 : 1;
    for (int y = 0; out && y < rh; y++)
        for (int x = 0; x < rw; x++) {
            /* The 8x8 block of the padded region holding the texel. */
            int bx = (rx + x) / 8 * 8, by = (ry + y) / 8 * 8;
            for (int c = 0; c < 4; c++) {
                int m = 0;
                for (int j = by; j < by + 8 && j < h; j++)
                    for (int i = bx; i < bx + 8 && i < w; i++)
                        if (img[((size_t)j * w + i) * 4 + c] > m)
                            m = img[((size_t)j * w + i) * 4 + c];
                if (fabsf(out[((size_t)y * rw + x) * 4 + c] - m / 255.0f) > 1e-6f)
                    bad++;
            }
        }
    check(bad == 0, "8x8 block maxima through the pyramid: %d wrong", bad);
    check(st.passes == 4, "logreduce: 3 level passes + 1 point pass (%d)", st.passes);
    free(out);
    gv_filter_graph_free(g);
    free(img);
}

/* Integer prefix sums: rgba32i state, "own + previous line". */
static const char *sum_body = "ivec4 own = $(FilterInput1)(rel_pos);\\n"
                              "ivec4 prev = $(FilterInput1)(rel_pos - sweepDir);\\n"
                              "return own + prev;";

static void test_propagation(struct gv_gpu *gpu)
{
    int w = 23, h = 17;
    uint8_t *img = random_image(w, h);
    const char *dirs[4] = {"+x", "-x", "+y", "-y"};
    for (int d = 0; d < 4; d++) {
        char json[1024];
        snprintf(json, sizeof json,
                 "{\"name\":\"sum\",\"output\":\"s\",\"modules\":["
                 "{\"id\":\"i\",\"template\":\"point\",\"format\":\"rgba32i\",\"inputs\":[\"source\"],"
                 "\"glsl\":\"return ivec4($(FilterInput1)(rel_pos) * 255.0 + 0.5);\"},"
                 "{\"id\":\"s\",\"template\":\"propagation\",\"direction\":\"%s\","
                 "\"format\":\"rgba32i\",\"inputs\":[\"i\"],\"glsl\":\"%s\"}]}",
                 dirs[d], sum_body);
        struct gv_filter_graph *g = parse(json);
        struct gv_filter_stats st;
        float *out = run(gpu, g, img, w, h, 0, 0, w, h, 0, 0, &st);
        int bad = out ? 0 : 1;
        for (int y = 0; out && y < h; y++)
            for (int x = 0; x < w; x++) {
                long want = 0;
                for (int t = 0; t < (d < 2 ? w : h); t++) {
                    int sx = d < 2 ? t : x, sy = d < 2 ? y : t;
                    int pos = d < 2 ? x : y;
                    if ((d % 2 == 0 && t <= pos) || (d % 2 == 1 && t >= pos))
                        want += img[((size_t)sy * w + sx) * 4];
                }
                if (out[((size_t)y * w + x) * 4] != (float)want)
                    bad++;
            }
        int lines = d < 2 ? w : h;
        int frag = path == GV_FILTER_PATH_FRAGMENT;
        check(bad == 0 && st.compute == !frag &&
                  (frag ? st.passes == 1 + lines - 1 && st.merges == 1
                        : st.passes == 1 + (lines - 1 + 31) / 32 && st.merges == 0),
              "propagation %s (%s): prefix sums exact (%d wrong), %d passes, %d merge",
              dirs[d], frag ? "fragment" : "compute", bad, st.passes, st.merges);
        free(out);
        gv_filter_graph_free(g);
    }

    /* +x then -x: the merge after +x is skipped; the -x sweep starts with a
     * single line copy. */
    char json[1536];
    snprintf(json, sizeof json,
             "{\"name\":\"sum2\",\"output\":\"b\",\"modules\":["
             "{\"id\":\"i\",\"template\":\"point\",\"format\":\"rgba32i\",\"inputs\":[\"source\"],"
             "\"glsl\":\"return ivec4($(FilterInput1)(rel_pos) * 255.0 + 0.5);\"},"
             "{\"id\":\"a\",\"template\":\"propagation\",\"direction\":\"+x\","
             "\"format\":\"rgba32i\",\"inputs\":[\"i\"],\"glsl\":\"%s\"},"
             "{\"id\":\"b\",\"template\":\"propagation\",\"direction\":\"-x\","
             "\"format\":\"rgba32i\",\"inputs\":[\"a\"],\"glsl\":\"%s\"}]}",
             sum_body, sum_body);
    struct gv_filter_graph *g = parse(json);
    check(g->module[1].skip_merge == 1 && g->module[2].skip_merge == 0,
          "+x then -x: merge after +x skipped in the plan");
    struct gv_filter_stats st;
    float *out = run(gpu, g, img, w, h, 0, 0, w, h, 0, 0, &st);
    int bad = out ? 0 : 1;
    for (int y = 0; out && y < h; y++) {
        long prefix[64], want = 0;
        long s = 0;
        for (int x = 0; x < w; x++)
            prefix[x] = s += img[((size_t)y * w + x) * 4];
        for (int x = w - 1; x >= 0; x--) {
            want += prefix[x];
            if (out[((size_t)y * w + x) * 4] != (float)want)
                bad++;
        }
    }
    check(bad == 0, "+x then -x in place: exact (%d wrong)", bad);
    if (path == GV_FILTER_PATH_FRAGMENT)
        check(st.passes == 1 + 2 * (w - 1) && st.merges == 1 && st.merges_skipped == 1 &&
                  st.line_copies == 1,
              "+x then -x: %d passes, %d merge, %d skipped, %d line copy",
              st.passes, st.merges, st.merges_skipped, st.line_copies);
    else
        check(st.passes == 1 + 2 && st.merges == 0 && st.line_copies == 0,
          "+x then -x: %d passes, %d merge, %d skipped, %d line copy",
          st.passes, st.merges, st.merges_skipped, st.line_copies);
    free(out);
    gv_filter_graph_free(g);
    free(img);
}

/* ---- distance transform, FILTERS.md's sweeps, scalar ---- */

struct site {
    int32_t x, y;
    uint32_t id, valid;
};

static void edt_scalar(struct site *s, int w, int h, int ax, int ay)
{
    const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    struct site *old = malloc((size_t)w * h * sizeof *old);
    for (int d = 0; d < 4; d++) {
        int dx = dirs[d][0], dy = dirs[d][1];
        int n = dx ? w : h;
        for (int k = 1; k < n; k++) {
            int line = (dx + dy) > 0 ? k : n - 1 - k;
            int prevl = line - (dx + dy);
            int m = dx ? h : w;
            memcpy(old, s, (size_t)w * h * sizeof *old);
            for (int t = 0; t < m; t++) {
                int x = dx ? line : t, y = dx ? t : line;
                struct site best = old[(size_t)y * w + x];
                int px = ax + x, py = ay + y;
                uint32_t bd = best.valid ? (uint32_t)((best.x - px) * (best.x - px) +
                                                      (best.y - py) * (best.y - py))
                                         : 0xffffffffu;
                for (int c = 0; c < 3; c++) {
                    int off = c == 0 ? 0 : c == 1 ? -1 : 1;
                    int cx = dx ? prevl : x + off, cy = dx ? y + off : prevl;
                    cx = cx < 0 ? 0 : cx >= w ? w - 1 : cx;
                    cy = cy < 0 ? 0 : cy >= h ? h - 1 : cy;
                    struct site q = s[(size_t)cy * w + cx];
                    if (!q.valid)
                        continue;
                    uint32_t qd = (uint32_t)((q.x - px) * (q.x - px) + (q.y - py) * (q.y - py));
                    if (!best.valid || qd < bd) {
                        best = q;
                        bd = qd;
                    }
                }
                s[(size_t)y * w + x] = best;
            }
        }
    }
    free(old);
}

static const char *sweep_body =
    "uvec4 best = $(FilterInput1)(rel_pos);\\n"
    "uint bd = 0xffffffffu;\\n"
    "if (best.w != 0u) { ivec2 e = ivec2(best.xy) - abs_pos; bd = uint(e.x * e.x + e.y * e.y); }\\n"
    "ivec2 perp = abs(ivec2(sweepDir.y, sweepDir.x));\\n"
    "for (int c = 0; c < 3; c++) {\\n"
    "  ivec2 off = c == 0 ? ivec2(0) : c == 1 ? -perp : perp;\\n"
    "  uvec4 q = $(FilterInput1)(rel_pos - sweepDir + off);\\n"
    "  if (q.w == 0u) continue;\\n"
    "  ivec2 e = ivec2(q.xy) - abs_pos;\\n"
    "  uint d = uint(e.x * e.x + e.y * e.y);\\n"
    "  if (best.w == 0u || d < bd) { best = q; bd = d; }\\n"
    "}\\n"
    "return best;";

static void test_edt(struct gv_gpu *gpu)
{
    int w = 96, h = 80, ax = 1000, ay = 2000;
    uint8_t *img = calloc((size_t)w * h * 4, 1);
    struct site *ref = calloc((size_t)w * h, sizeof *ref);
    for (int i = 0; i < 40; i++) {
        int x = (int)(rnd() % (unsigned)w), y = (int)(rnd() % (unsigned)h);
        img[((size_t)y * w + x) * 4] = 255;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if (img[((size_t)y * w + x) * 4])
                ref[(size_t)y * w + x] = (struct site){ax + x, ay + y,
                                                       (uint32_t)(y * w + x + 1), 1};
    edt_scalar(ref, w, h, ax, ay);
    char json[4096];
    snprintf(json, sizeof json,
             "{\"name\":\"edt\",\"output\":\"ym\",\"modules\":["
             "{\"id\":\"init\",\"template\":\"point\",\"format\":\"rgba32ui\",\"inputs\":[\"source\"],"
             "\"glsl\":\"if ($(FilterInput1)(rel_pos).r < 0.5) return uvec4(0u);\\n"
             "ivec2 t = texel_pos;\\nreturn uvec4(uvec2(abs_pos), uint(t.y * int(filterArea.x) + t.x + 1), 1u);\"},"
             "{\"id\":\"xp\",\"template\":\"propagation\",\"direction\":\"+x\",\"format\":\"rgba32ui\",\"inputs\":[\"init\"],\"glsl\":\"%s\"},"
             "{\"id\":\"xm\",\"template\":\"propagation\",\"direction\":\"-x\",\"format\":\"rgba32ui\",\"inputs\":[\"xp\"],\"glsl\":\"%s\"},"
             "{\"id\":\"yp\",\"template\":\"propagation\",\"direction\":\"+y\",\"format\":\"rgba32ui\",\"inputs\":[\"xm\"],\"glsl\":\"%s\"},"
             "{\"id\":\"ym\",\"template\":\"propagation\",\"direction\":\"-y\",\"format\":\"rgba32ui\",\"inputs\":[\"yp\"],\"glsl\":\"%s\"}]}",
             sweep_body, sweep_body, sweep_body, sweep_body);
    struct gv_filter_graph *g = parse(json);
    check(g->module[1].skip_merge && !g->module[2].skip_merge && g->module[3].skip_merge &&
              !g->module[4].skip_merge,
          "EDT: merges skipped after +x and +y only");
    struct gv_filter_stats st;
    float *out = run(gpu, g, img, w, h, 0, 0, w, h, ax, ay, &st);
    int bad = out ? 0 : 1;
    for (int i = 0; out && i < w * h; i++) {
        const float *o = &out[(size_t)i * 4];
        if (o[3] != (float)ref[i].valid ||
            (ref[i].valid && (o[0] != (float)ref[i].x || o[1] != (float)ref[i].y ||
                              o[2] != (float)ref[i].id)))
            if (bad++ < 3)
                printf("# texel %d: GPU (%g,%g,%g,%g) CPU (%d,%d,%u,%u)\n", i, o[0], o[1],
                       o[2], o[3], ref[i].x, ref[i].y, ref[i].id, ref[i].valid);
    }
    check(bad == 0, "EDT sweeps on the GPU equal the scalar rules: %d texels differ", bad);
    if (path == GV_FILTER_PATH_FRAGMENT)
        check(st.passes == 1 + 2 * (w - 1) + 2 * (h - 1) && st.merges == 2 &&
                  st.merges_skipped == 2 && st.line_copies == 2,
              "EDT: %d passes, %d merges, %d skipped, %d line copies, %d textures",
              st.passes, st.merges, st.merges_skipped, st.line_copies, st.textures);
    else
        check(st.passes == 1 + 2 * 3 + 2 * 3 && st.merges == 0,
          "EDT: %d passes, %d merges, %d skipped, %d line copies, %d textures",
          st.passes, st.merges, st.merges_skipped, st.line_copies, st.textures);
    free(out);
    gv_filter_graph_free(g);
    free(ref);
    free(img);
}

static void test_compile_error(struct gv_gpu *gpu)
{
    struct gv_filter_graph *g = parse(
        "{\"name\":\"bad\",\"output\":\"b\",\"modules\":[{\"id\":\"b\",\"template\":\"point\","
        "\"inputs\":[\"source\"],\"glsl\":\"vec4 s = $(FilterInput1)(rel_pos);\\n"
        "float x = undefined_thing + 1.0;\\nreturn s;\"}]}");
    struct gv_error err = {0};
    int rc = gv_filter_compile(gpu, g, &err);
    printf("# %s\n", err.text);

    /* The driver's own words follow the prefix; they differ between drivers. */
    static const char prefix[] = "filter: module 'b' line 2: ";
    check(rc < 0 && err.code == GV_EINVAL && strncmp(err.text, prefix, strlen(prefix)) == 0,
          "a GLSL error starts \"%s\": the module and the body's line 2", prefix);
    gv_filter_graph_free(g);
}

/* The values inputs: codes of 6 channels as code * scale + offset. */
static void test_values(struct gv_gpu *gpu)
{
    enum { W = 29, H = 17, C = 6 };
    uint8_t *img = random_image(W, H), codes[W * H * C * 2];
    for (size_t i = 0; i < sizeof codes; i++)
        codes[i] = (uint8_t)rnd();
    const double scale = 0.0137, offset = -123.25;
    struct gv_filter_graph *g = parse(
        "{\"name\":\"v\",\"output\":\"o\",\"output_channels\":4,\"modules\":["
        "{\"id\":\"o\",\"template\":\"point\",\"inputs\":[\"values\",\"values2\"],"
        "\"glsl\":\"vec4 a = $(FilterInput1)(rel_pos), b = $(FilterInput2)(rel_pos);\\n"
        "return rel_pos.x % 2 == 0 ? a : b;\"}]}");
    struct gv_filter_input in = {
        .w = W, .h = H, .rgba = img, .roi_x = 2, .roi_y = 1, .roi_w = 25, .roi_h = 15,
        .values = codes, .nvalues = C, .values_scale = scale, .values_offset = offset,
        .path = path};
    float *out = NULL;
    struct gv_error err = {0};
    if (gv_filter_run(gpu, g, &in, &out, NULL, &err) < 0)
        printf("# run: %s\n", err.text);
    int bad = out ? 0 : 1;
    for (int y = 0; out && y < 15; y++)
        for (int x = 0; x < 25; x++)
            for (int k = 0; k < 4; k++) {
                const int ch = (x % 2 ? 4 : 0) + k;
                const uint8_t *b = &codes[(((size_t)(y + 1) * W + x + 2) * C + ch) * 2];
                const float want = ch < C ? (float)((b[0] | b[1] << 8) * scale + offset) : 0.0f;
                if (out[((size_t)y * 25 + x) * 4 + k] != want)
                    bad++;
            }
    check(bad == 0, "values and values2: 6 channels of codes as code * scale + offset, "
          "channels 7 and 8 zero, exact (%d wrong)", bad);
    free(out);
    out = NULL;
    in.values = NULL;
    in.nvalues = 0;
    bad = gv_filter_run(gpu, g, &in, &out, NULL, &err) < 0;
    for (int y = 0; out && y < 15; y++)
        for (int x = 0; x < 25; x++)
            for (int k = 0; k < 4; k++) {
                const float want = x % 2 ? 0.0f : img[((size_t)(y + 1) * W + x + 2) * 4 + k];
                if (out[((size_t)y * 25 + x) * 4 + k] != want)
                    bad++;
            }
    check(bad == 0, "a run without values (an image): values are the source's bytes, "
          "values2 zero (%d wrong)", bad);
    free(out);
    out = NULL;
    in.nvalues = 9;
    check(gv_filter_run(gpu, g, &in, &out, NULL, &err) < 0 && err.code == GV_EINVAL,
          "9 channels of values are refused: %s", err.text);
    gv_filter_graph_free(g);

    /* A 3x3 box sum over values, at the padded region's edge (clamped). */
    g = parse("{\"name\":\"k\",\"output\":\"k\",\"modules\":[{\"id\":\"k\","
              "\"template\":\"point\",\"inputs\":[\"values\"],\"kernel\":{\"width\":3,"
              "\"height\":3,\"weights\":[1,1,1,1,1,1,1,1,1]}}]}");
    in.values = codes;
    in.nvalues = C;
    in.roi_x = 0;
    in.roi_y = 0;
    in.roi_w = W;
    in.roi_h = H;
    double maxd = 1e9;
    if (gv_filter_run(gpu, g, &in, &out, NULL, &err) == 0) {
        maxd = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double want = 0;
                for (int j = -1; j <= 1; j++)
                    for (int i = -1; i <= 1; i++) {
                        int xx = x + i < 0 ? 0 : x + i >= W ? W - 1 : x + i;
                        int yy = y + j < 0 ? 0 : y + j >= H ? H - 1 : y + j;
                        const uint8_t *b = &codes[((size_t)yy * W + xx) * C * 2];
                        want += (float)((b[0] | b[1] << 8) * scale + offset);
                    }
                double d = fabs(out[((size_t)y * W + x) * 4] - want) / (1 + fabs(want));
                if (d > maxd)
                    maxd = d;
            }
    } else {
        printf("# run: %s\n", err.text);
    }
    check(maxd < 1e-6, "a kernel over values, edges clamped: relative difference %g", maxd);
    free(out);
    gv_filter_graph_free(g);
    free(img);
}

int main(void)
{
    struct gv_error err = {0};
    struct gv_gpu *gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    if (!gpu) {
        return tap_skip_all("no EGL context: %s", err.text);
    }
    printf("# %s / %s\n", gv_gpu_info(gpu)->api, gv_gpu_info(gpu)->renderer);
    test_point(gpu);
    test_kernel(gpu);
    test_logreduce(gpu);
    test_propagation(gpu);
    test_edt(gpu);
    test_values(gpu);
    if (gv_gpu_info(gpu)->ssbo) {
        /* The same sweeps as compute shaders, 32 lines per dispatch. */
        path = GV_FILTER_PATH_COMPUTE;
        test_propagation(gpu);
        test_edt(gpu);
    } else {
        tap_skip("no compute shaders in this context",
                 "propagation and EDT sweeps as compute shaders");
    }
    test_compile_error(gpu);
    gv_gpu_close(gpu);
    return tap_done();
}
