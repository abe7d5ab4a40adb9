/*
 * height_encode.c - the height store encoder (see height_encode.h).
 *
 * Steps: read the raster into codes (imageio, or the synthetic terrain),
 * build the code pyramid with the box filter, then code levels root-1 ..
 * 0 page by page, each tile against its parent as the decoder will have
 * decoded it (the decoded tiles of the level above are kept until the
 * level is done).  The root is stored losslessly.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "base/pool.h"
#include "codec/height_tile.h"
#include "encode/height_encode.h"
#include "imageio/imageio.h"
#include "store/store_write.h"

#define ME "height"
#define STRIP 64   /* rows read at a time */

/* ---- synth-height: integer value-noise fBm, a function of (x, y) ---- */

/* Same shape as mix32 in encode/source.c and id_final in store/store_read.c:
 * deliberately separate, other constants, and each output is part of what a
 * store holds. */
static uint32_t hash2(uint32_t x, uint32_t y, uint32_t o)
{
    uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ o * 0xcb1ab31fu;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return h;
}

/* Smoothstep in 16-bit fixed point: t in 0..65536. */
static int64_t smooth(int64_t t)
{
    return (t * t * (3 * 65536 - 2 * t)) >> 32;
}

/* One octave of cell size 2^shift at (x, y): -32768..32767. */
static int64_t octave(uint32_t x, uint32_t y, int shift, uint32_t o)
{
    uint32_t cx = x >> shift, cy = y >> shift;
    int64_t fx = smooth((int64_t)(x & ((1u << shift) - 1)) << (16 - shift));
    int64_t fy = smooth((int64_t)(y & ((1u << shift) - 1)) << (16 - shift));
    int64_t a = (int64_t)(hash2(cx, cy, o) >> 16) - 32768;
    int64_t b = (int64_t)(hash2(cx + 1, cy, o) >> 16) - 32768;
    int64_t c = (int64_t)(hash2(cx, cy + 1, o) >> 16) - 32768;
    int64_t d = (int64_t)(hash2(cx + 1, cy + 1, o) >> 16) - 32768;
    int64_t top = a + (((b - a) * fx) >> 16), bot = c + (((d - c) * fx) >> 16);
    return top + (((bot - top) * fy) >> 16);
}

/* Terrain code at (x, y): 11 octaves from 2048-pixel cells down to 2,
 * amplitude halving (fractal dimension about 2.0 + 0.5), ridged a little
 * by folding, in metres, about 0 .. 7000. */
static uint16_t synth_height(uint32_t x, uint32_t y)
{
    int64_t s = 0;
    for (int k = 11, amp = 1024; k >= 1; k--, amp = amp * 5 / 9)
        s += octave(x, y, k, (uint32_t)k) * amp;
    s >>= 11;                       /* about -6000 .. 6000 */
    int64_t v = s < 0 ? -s / 4 : s; /* shallow "sea floor" below 0 */
    v += 1000;
    return (uint16_t)(v < 0 ? 0 : (v > 65535 ? 65535 : v));
}

static int parse_synth(const char *spec, uint32_t *w, uint32_t *h)
{
    unsigned long long a, b;
    char tail;
    if (sscanf(spec, "synth-height:%llux%llu%c", &a, &b, &tail) != 2 || !a ||
        !b || a > GV_MAX_DIM || b > GV_MAX_DIM)
        return -1;
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return 0;
}

/* ---- reading the input into codes ---- */

/* The samples of synth-height:WxH into a new *codes (caller frees).
 * Returns 0 or -1 with err set. */
static int read_synth(const char *input, uint64_t limit, uint16_t **codes,
                      uint32_t *w, uint32_t *h, struct gv_error *err)
{
    if (parse_synth(input, w, h) < 0)
        return gv_fail(err, GV_EINVAL, ME ": bad pattern '%s' (want "
                       "synth-height:WIDTHxHEIGHT)", input);
    if ((uint64_t)*w * *h > limit)
        return gv_fail(err, GV_ELIMIT, ME ": %ux%u is more than %llu "
                       "pixels", *w, *h, (unsigned long long)limit);
    *codes = malloc(sizeof **codes * (size_t)*w * *h);
    if (!*codes)
        return gv_fail(err, GV_ENOMEM, ME ": out of memory for the input");
    for (uint32_t y = 0; y < *h; y++)
        for (uint32_t x = 0; x < *w; x++)
            (*codes)[(size_t)y * *w + x] = synth_height(x, y);
    return 0;
}

/* Map n finite float samples onto the 16-bit codes, lowest to 0 and
 * highest to 65535 (m's offset, scale, min and max set).  Returns 0, or
 * -1 with err set when a sample is not a finite number. */
static int map_float(const float *fl, size_t n, uint16_t *codes,
                     struct gv_height_result *m, const char *input,
                     struct gv_error *err)
{
    float lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(fl[i]))
            return gv_fail(err, GV_EINVAL, ME ": %s has a sample that is "
                           "not a finite number", input);
        lo = fl[i] < lo ? fl[i] : lo;
        hi = fl[i] > hi ? fl[i] : hi;
    }
    m->offset = lo;
    m->scale = hi > lo ? ((double)hi - lo) / 65535.0 : 1.0;
    m->min = lo;
    m->max = hi;
    for (size_t i = 0; i < n; i++) {
        double c = floor((fl[i] - m->offset) / m->scale + 0.5);
        codes[i] = (uint16_t)(c < 0 ? 0 : (c > 65535 ? 65535 : c));
    }
    return 0;
}

/* The one channel of image file `input` into a new *codes (caller frees):
 * 8- and 16-bit samples as they are, float ones through map_float
 * (m->src_float set).  Returns 0 or -1 with err set. */
static int read_image_codes(const char *input, const struct gv_height_opts *o,
                            uint64_t limit, uint16_t **codes, uint32_t *w,
                            uint32_t *h, struct gv_height_result *m,
                            struct gv_error *err)
{
    struct gv_image_info ii;
    const struct gv_image_limits lim = {
        .max_pixels = limit, .max_decoder_bytes = o->max_decoder_bytes};
    struct gv_image_in *in = gv_image_open_limits(input, &lim, &ii, err);
    if (!in)
        return -1;
    int rc = -1;
    void *strip = NULL;
    float *fl = NULL;
    if (ii.channels != 1) {
        gv_fail(err, GV_EINVAL, ME ": %s has %d channels; a height field "
                "has one", input, ii.channels);
        goto done;
    }
    *w = ii.width;
    *h = ii.height;
    const size_t n = (size_t)*w * *h;
    const int fp = ii.sample == GV_SAMPLE_F32;
    const size_t ss = ii.sample == GV_SAMPLE_U8 ? 1 : (fp ? 4 : 2);
    *codes = malloc(sizeof **codes * n);
    strip = malloc(ss * *w * STRIP);
    if (fp)
        fl = malloc(sizeof *fl * n);
    if (!*codes || !strip || (fp && !fl)) {
        gv_fail(err, GV_ENOMEM, ME ": out of memory for the input");
        goto done;
    }
    for (uint32_t y = 0; y < *h; y += STRIP) {
        uint32_t rows = *h - y < STRIP ? *h - y : STRIP;
        if (gv_image_read(in, rows, strip, err) < 0)
            goto done;
        size_t k = (size_t)rows * *w, at = (size_t)y * *w;
        for (size_t i = 0; i < k; i++) {
            if (ii.sample == GV_SAMPLE_U8)
                (*codes)[at + i] = ((const uint8_t *)strip)[i];
            else if (!fp)
                (*codes)[at + i] = ((const uint16_t *)strip)[i];
            else
                fl[at + i] = ((const float *)strip)[i];
        }
    }
    m->src_float = fp;
    if (fp && map_float(fl, n, *codes, m, input, err) < 0)
        goto done;
    rc = 0;
done:
    free(strip);
    free(fl);
    gv_image_close(in);
    if (rc < 0) {
        free(*codes);
        *codes = NULL;
    }
    return rc;
}

static int read_input(const char *input, const struct gv_height_opts *o,
                      uint16_t **codes, uint32_t *w, uint32_t *h,
                      struct gv_height_result *m, int *e,
                      struct gv_error *err)
{
    uint64_t limit = o->max_pixels ? o->max_pixels : GV_HEIGHT_MAX_PIXELS;
    *codes = NULL;
    m->scale = o->mapped ? o->scale : 1;
    m->offset = o->mapped ? o->offset : 0;
    if (strncmp(input, "synth-height:", 13) == 0) {
        if (read_synth(input, limit, codes, w, h, err) < 0)
            return -1;
        m->src_float = 0;
    } else if (read_image_codes(input, o, limit, codes, w, h, m, err) < 0) {
        return -1;
    }
    const size_t n = (size_t)*w * *h;
    if (!m->src_float) {
        uint16_t lo = 65535, hi = 0;
        for (size_t i = 0; i < n; i++) {
            lo = (*codes)[i] < lo ? (*codes)[i] : lo;
            hi = (*codes)[i] > hi ? (*codes)[i] : hi;
        }
        m->min = lo * m->scale + m->offset;
        m->max = hi * m->scale + m->offset;
    }
    /* The half-step in codes: the largest e whose bound fits E. */
    double q = m->src_float ? 0.5 : 0.0;   /* quantization, in codes */
    double ec = floor(o->max_error / m->scale - q + 1e-9);
    if (o->max_error > 0 && ec < 0) {
        free(*codes);
        *codes = NULL;
        return gv_fail(err, GV_EINVAL, ME ": --max-error %g is below the "
                       "16-bit quantization of this float input (%g)",
                       o->max_error, m->scale / 2);
    }
    *e = ec < 0 ? 0 : (ec > GV_HT_MAX_E ? GV_HT_MAX_E : (int)ec);
    m->e = *e;
    /* Float input: quantizing adds scale/2, and the double arithmetic of
     * the mapping a few ulps of the values (1e-12 of the largest
     * magnitude covers it with room to spare). */
    m->max_error = m->src_float
        ? m->scale * (*e + 0.5) + 1e-12 * fmax(fabs(m->min), fabs(m->max))
        : m->scale * *e;
    return 0;
}

/* ---- coding the pyramid ---- */

/* Tile (tx,ty) of a w x h level, clamp-padded, into t. */
static void extract(const uint16_t *lv, uint32_t w, uint32_t h, uint32_t tx,
                    uint32_t ty, uint16_t *t)
{
    for (uint32_t v = 0; v < GV_HT_SIDE; v++) {
        uint32_t y = ty * GV_STEP + v;
        const uint16_t *row = lv + (size_t)(y < h ? y : h - 1) * w;
        for (uint32_t u = 0; u < GV_HT_SIDE; u++) {
            uint32_t x = tx * GV_STEP + u;
            t[v * GV_HT_SIDE + u] = row[x < w ? x : w - 1];
        }
    }
}

/* One page of level k: its tiles are coded in parallel (each from its
 * parent, all of the level above done), then written in order. */
struct page_job {
    const struct gv_level *l;
    const uint16_t *lv;           /* level k's exact codes */
    uint16_t **dec, **dec_up;     /* decoded tiles of level k and k+1 */
    uint32_t up_tx, px, py;
    int e;
    uint8_t **bufs;               /* per slot */
    size_t *lens;                 /* per slot; 0 on failure */
    uint16_t **orig;              /* per worker */
};

static void encode_slot(void *ctx, size_t item, int worker)
{
    struct page_job *pj = ctx;
    const struct gv_level *l = pj->l;
    uint32_t tx = pj->px * GV_PAGE_TILES + (uint32_t)(item % GV_PAGE_TILES);
    uint32_t ty = pj->py * GV_PAGE_TILES + (uint32_t)(item / GV_PAGE_TILES);
    pj->lens[item] = 0;
    if (tx >= l->tiles_x || ty >= l->tiles_y)
        return;
    size_t ti = (size_t)ty * l->tiles_x + tx;
    if (!(pj->dec[ti] = malloc(sizeof **pj->dec * GV_HT_SAMPLES)))
        return;
    uint16_t *orig = pj->orig[worker];
    extract(pj->lv, l->width, l->height, tx, ty, orig);
    uint32_t vw = l->width - tx * GV_STEP, vh = l->height - ty * GV_STEP;
    pj->lens[item] = gv_height_tile_encode(
        orig, pj->dec_up[(size_t)(ty / 2) * pj->up_tx + tx / 2], (int)(tx & 1),
        (int)(ty & 1), pj->e, vw < GV_TILE ? (int)vw : GV_TILE,
        vh < GV_TILE ? (int)vh : GV_TILE, pj->bufs[item], pj->dec[ti]);
}

static void free_tiles(uint16_t **t, size_t n)
{
    if (!t)
        return;
    for (size_t i = 0; i < n; i++)
        free(t[i]);
    free(t);
}

/* The header of a height store of w x h codes at bound e (in codes). */
static void height_header(struct gv_header *hd, uint32_t w, uint32_t h, int e,
                          const struct gv_height_result *meta, const char *unit)
{
    memset(hd, 0, sizeof *hd);
    hd->width = w;
    hd->height = h;
    hd->channels = 1;
    hd->src_bits = meta->src_float ? 32 : 16;
    hd->src_float = (uint8_t)meta->src_float;
    hd->kind = GV_KIND_HEIGHT;
    hd->height_float = (uint8_t)meta->src_float;
    hd->height_e = (uint16_t)e;
    hd->height_scale = meta->scale;
    hd->height_offset = meta->offset;
    hd->height_max_error = meta->max_error;
    hd->height_min = (float)meta->min;
    hd->height_max = (float)meta->max;
    if (unit)
        snprintf(hd->height_unit, sizeof hd->height_unit, "%s", unit);
}

int gv_height_encode_codes(const uint16_t *codes, uint32_t w, uint32_t h,
                           int e, const struct gv_height_result *meta,
                           const char *unit, int threads, const char *output,
                           struct gv_height_result *r, struct gv_error *err)
{
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    struct gv_geometry g;
    if (gv_geometry_init(&g, w, h, 1) < 0)
        return gv_fail(err, GV_EINVAL, ME ": bad dimensions %ux%u", w, h);
    struct gv_header hd;
    height_header(&hd, w, h, e, meta, unit);

    int rc = -1;
    uint16_t *lv[GV_MAX_LEVELS] = {0};
    uint16_t **dec_up = NULL, **dec = NULL;   /* decoded tiles: above, this */
    uint8_t *bufs[GV_PAGE_SLOTS] = {0};
    lv[0] = (uint16_t *)(uintptr_t)codes;   /* read only, not copied */
    struct gv_store_writer *wr = NULL;
    uint64_t tiles = 0;
    size_t up_n = 0, cur_n = 0;
    /* More workers than a page has tiles would idle. */
    if (threads <= 0)
        threads = gv_cpu_count();
    if (threads > GV_PAGE_SLOTS)
        threads = GV_PAGE_SLOTS;
    struct gv_pool *pool = gv_pool_new(threads);
    uint16_t *orig[GV_PAGE_SLOTS] = {0};
    if (!pool)
        goto nomem;
    for (int i = 0; i < gv_pool_size(pool); i++)
        if (!(orig[i] = malloc(sizeof *orig[i] * GV_HT_SAMPLES)))
            goto nomem;
    /* The code pyramid: lv[0] is the input. */
    for (int k = 1; k <= g.root; k++) {
        lv[k] = malloc(sizeof **lv * (size_t)g.level[k].width * g.level[k].height);
        if (!lv[k])
            goto nomem;
        gv_height_box_reduce(lv[k - 1], g.level[k - 1].width,
                             g.level[k - 1].height, lv[k]);
    }
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        if (!(bufs[s] = malloc(GV_HT_BUF_MAX)))
            goto nomem;
    wr = gv_store_writer_new(output, &hd, err);
    if (!wr)
        goto out;
    /* The root tile is the parent of level root-1. */
    dec_up = calloc(1, sizeof *dec_up);
    if (!dec_up || !(dec_up[0] = malloc(sizeof **dec_up * GV_HT_SAMPLES)))
        goto nomem;
    extract(lv[g.root], g.level[g.root].width, g.level[g.root].height, 0, 0,
            dec_up[0]);
    uint32_t up_tx = 1;
    up_n = 1;
    for (int k = g.root - 1; k >= 0; k--) {
        const struct gv_level *l = &g.level[k];
        size_t nt = (size_t)l->tiles_x * l->tiles_y;
        dec = calloc(nt, sizeof *dec);
        if (!dec)
            goto nomem;
        cur_n = nt;
        for (uint32_t py = 0; py < l->pages_y; py++)
            for (uint32_t px = 0; px < l->pages_x; px++) {
                const uint8_t *tb[GV_PAGE_SLOTS] = {0};
                size_t lens[GV_PAGE_SLOTS] = {0};
                struct page_job pj = {l, lv[k], dec, dec_up, up_tx, px, py, e,
                                      bufs, lens, orig};
                gv_pool_run(pool, encode_slot, &pj, GV_PAGE_SLOTS);
                for (int sl = 0; sl < GV_PAGE_SLOTS; sl++) {
                    uint32_t tx = px * GV_PAGE_TILES + (uint32_t)(sl % GV_PAGE_TILES);
                    uint32_t ty = py * GV_PAGE_TILES + (uint32_t)(sl / GV_PAGE_TILES);
                    if (tx >= l->tiles_x || ty >= l->tiles_y)
                        continue;
                    if (!lens[sl])
                        goto nomem;
                    tb[sl] = bufs[sl];
                    tiles++;
                }
                if (gv_store_writer_page(wr, k, px, py, tb, lens, err) < 0)
                    goto out;
            }
        free_tiles(dec_up, up_n);
        dec_up = dec;
        up_n = cur_n;
        dec = NULL;
        cur_n = 0;
        up_tx = l->tiles_x;
    }
    if (gv_store_writer_root(wr, (const uint8_t *)(const void *)lv[g.root], err) < 0)
        goto out;
    uint64_t bytes = gv_store_writer_bytes(wr);
    rc = gv_store_writer_finish(wr, err);
    wr = NULL;
    if (rc == 0 && r) {
        *r = *meta;
        r->geometry = g;
        r->tiles = tiles;
        r->e = e;
        /* the index and header follow the pages and the root */
        r->file_bytes = bytes + g.pages * GV_INDEX_ENTRY + 4;
        clock_gettime(CLOCK_MONOTONIC, &t1);
        r->seconds = (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) / 1e9;
    }
    goto out;
nomem:
    gv_fail(err, GV_ENOMEM, ME ": out of memory");
out:
    gv_store_writer_abort(wr);
    /* dec_up holds the decoded tiles of the last level finished (or the
     * root tile), dec those of the level in progress. */
    free_tiles(dec_up, up_n);
    free_tiles(dec, cur_n);
    for (int i = 0; i < GV_PAGE_SLOTS; i++)
        free(orig[i]);
    gv_pool_free(pool);
    for (int k = 1; k <= g.root; k++)
        free(lv[k]);
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        free(bufs[s]);
    return rc;
}

int gv_height_encode(const char *input, const char *output,
                     const struct gv_height_opts *o,
                     struct gv_height_result *r, struct gv_error *err)
{
    uint16_t *codes = NULL;
    uint32_t w = 0, h = 0;
    int e = 0;
    struct gv_height_result m;
    memset(&m, 0, sizeof m);
    if (o->unit && (strlen(o->unit) > GV_HEIGHT_UNIT ||
                    strspn(o->unit, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                    "0123456789-_.^/%") != strlen(o->unit)))
        return gv_fail(err, GV_EINVAL, ME ": --unit wants up to %d letters, "
                       "digits or -_.^/%%", GV_HEIGHT_UNIT);
    if (read_input(input, o, &codes, &w, &h, &m, &e, err) < 0)
        return -1;
    int rc = gv_height_encode_codes(codes, w, h, e, &m, o->unit, o->threads,
                                    output, r, err);
    free(codes);
    return rc;
}
