/*
 * height_encode.c - the streaming encoder of stores of 16-bit codes:
 * height stores, and sample stores of 1 to 8 channels (see
 * height_encode.h).
 *
 * Steps: (float input only) read the input once for its range; pass 1
 * reads it again row by row, maps the samples to codes and pushes each
 * row up the pyramid (one pending row per level, the box filter on pairs
 * of rows), writing every level, the root's included, to the scratch
 * file in strips (strips.h) at orig_base[k]; pass 2 codes levels root-1
 * .. 0 page by page: the page's window is mapped from (or copied out of)
 * its strip, its 64 tiles are cut from it clamp-padded and coded on the
 * pool, each against its decoded parent, and the decoded tiles of levels
 * >= 1 go to the scratch file at recon_base[k] (513x513 codes each,
 * row-major by tile), where the level below finds them.  The root is
 * stored losslessly.  Every step computes what the in-memory encoder
 * before it did, tile for tile, so stores are byte for byte the same.
 *
 * A sample store's levels hold c codes a pixel, interleaved, in the strips;
 * its decoded tiles are kept as c planes of 513 x 513 codes (what the
 * height codec reads as a parent), and a tile's buffer is its channels'
 * height buffers one after another (codec/samples_tile.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/pool.h"
#include "base/spill.h"
#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "render/samples_region.h"
#include "render/window.h"
#include "store/store_meta.h"
#include "encode/codes_pass.h"
#include "encode/codes_trial.h"
#include "encode/encode_int.h"
#include "encode/height_encode.h"
#include "encode/source.h"
#include "encode/strips.h"
#include "store/store_format.h"
#include "store/store_write.h"

#define ME "height"
#define WINDOW GV_STRIP_WINDOW
#define PAGE_W GV_STRIP_PAGE_W
#define CHUNK_BYTES (4u << 20)  /* input rows read at a time */
#define PASS1_SHARE 0.15        /* progress weight of pass 1 */
#define PLANE_BYTES ((size_t)GV_HT_SAMPLES * sizeof(uint16_t))

struct henc {
    const struct gv_height_opts *o;
    const char *const *inputs;
    int n;
    const char *name;            /* the input, for messages */
    struct gv_error *err;
    struct gv_source_opts so;
    struct gv_geometry g;
    int c;                       /* channels: 1 for a height store */
    int kind;                    /* GV_KIND_HEIGHT or GV_KIND_SAMPLES */
    size_t tile_bytes;           /* a decoded tile: c planes */
    int src_bits;                /* bits of an input sample */
    int e;                       /* the half-step in codes */
    struct gv_height_result m;   /* mapping, range, bound */
    struct gv_spill *spill;
    uint64_t orig_base[GV_MAX_LEVELS], recon_base[GV_MAX_LEVELS];
    /* pass 1 */
    uint16_t *pending[GV_MAX_LEVELS], *reduced[GV_MAX_LEVELS];
    int have_pending[GV_MAX_LEVELS];
    uint32_t rows_out[GV_MAX_LEVELS];
    uint16_t lo, hi;             /* integer input: smallest, largest code */
    /* pass 2 */
    struct gv_pool *pool;
    int level;
    uint32_t px, py;
    const uint16_t *win;         /* the page's window: a view, or copy */
    uint32_t win_w, win_h;       /* win_w is also its stride */
    uint16_t *copy;
    struct gv_spill_view view;
    uint16_t *root, *root_tile;
    uint16_t *parents[16];
    const uint16_t *parent_at[16];
    uint16_t *dec[GV_PAGE_SLOTS];
    uint8_t *bufs[GV_PAGE_SLOTS];
    size_t lens[GV_PAGE_SLOTS], caps[GV_PAGE_SLOTS];
    double sse[GV_PAGE_SLOTS];   /* level 0: the slot's squared error */
    double sse0;                 /* level 0's, summed */
    uint16_t *orig[GV_PAGE_SLOTS];  /* per worker */
    uint8_t *chan[GV_PAGE_SLOTS];   /* per worker: one channel's buffer */
    uint8_t *meta;               /* the packed metadata section, or NULL */
    size_t meta_len;
    struct gv_store_writer *wr;
    uint64_t tiles;
    double work_total, work_done;
};

static void report(struct henc *h, const char *phase, double fraction)
{
    if (!h->o->progress)
        return;
    struct gv_encode_progress p = {
        .fraction = fraction > 1.0 ? 1.0 : fraction,
        .source_pixels = (uint64_t)h->g.width * h->g.height,
        .phase = phase,
        .level = h->level,
    };
    h->o->progress(h->o->progress_ctx, &p);
}

/* ------------------------------------------------------ the input */

/* Open the input as native samples; fills *si.  NULL with h->err. */
static struct gv_source *open_input(struct henc *h, struct gv_source_info *si)
{
    struct gv_source *src = gv_source_open(h->inputs, h->n, &h->so, si, h->err);
    if (src && !h->o->samples && si->channels != 1) {
        gv_fail(h->err, GV_EINVAL, ME ": %s has %d channels; a height field "
                "has one", h->name, si->channels);
        gv_source_free(src);
        return NULL;
    }
    if (src && si->channels > GV_SAMPLES_MAX_CHANNELS) {
        gv_fail(h->err, GV_EINVAL, ME ": %s has %d channels; a sample store "
                "holds at most %d", h->name, si->channels, GV_SAMPLES_MAX_CHANNELS);
        gv_source_free(src);
        return NULL;
    }
    return src;
}

/* Rows of the input read at a time. */
static uint32_t chunk_rows(const struct gv_source_info *si)
{
    uint32_t c = (uint32_t)(CHUNK_BYTES / ((size_t)si->width * si->sample_bytes *
                                           (size_t)si->channels));
    c = c ? c : 1;
    return c < si->height ? c : si->height;
}

/* Float input: read it once for its range and set the mapping (offset =
 * the smallest sample, scale = the range / 65535).  Non-finite samples
 * are refused. */
static int float_range(struct henc *h)
{
    struct gv_source_info si;
    struct gv_source *src = open_input(h, &si);
    if (!src)
        return -1;
    const uint32_t chunk = chunk_rows(&si);
    const size_t row = (size_t)si.width * (size_t)si.channels;
    float *buf = malloc((size_t)chunk * row * sizeof *buf);
    float lo = INFINITY, hi = -INFINITY;
    int rc = -1;
    if (!buf) {
        gv_fail(h->err, GV_ENOMEM, ME ": out of memory for input rows");
        goto out;
    }
    for (uint32_t y = 0; y < si.height; y += chunk) {
        const uint32_t k = si.height - y < chunk ? si.height - y : chunk;
        if (gv_source_read(src, k, (uint8_t *)buf, h->err) < 0)
            goto out;
        for (size_t i = 0; i < (size_t)k * row; i++) {
            if (!isfinite(buf[i])) {
                gv_fail(h->err, GV_EINVAL, ME ": %s has a sample that is "
                        "not a finite number", h->name);
                goto out;
            }
            lo = buf[i] < lo ? buf[i] : lo;
            hi = buf[i] > hi ? buf[i] : hi;
        }
    }
    h->m.offset = lo;
    h->m.scale = hi > lo ? ((double)hi - lo) / 65535.0 : 1.0;
    h->m.min = lo;
    h->m.max = hi;
    rc = 0;
out:
    free(buf);
    gv_source_free(src);
    return rc;
}

/* The samples' full range, what -q's PSNR is over (docs/FORMAT.md
 * section 13): every code for float input, 2^bits - 1 for integers. */
static double full_range(const struct henc *h)
{
    return h->m.src_float ? 65535.0 : (double)((1u << h->src_bits) - 1);
}

/* The half-step e in codes: the largest whose bound fits --max-error.
 * After the mapping is known. */
static int pick_e(struct henc *h)
{
    struct gv_height_result *m = &h->m;
    if (h->o->target_psnr > 0) {
        /* The largest e whose uniform error, e (e + 1) / 3 in mean square,
         * reaches the target over the samples' full range. */
        const double peak = full_range(h);
        const double mse = peak * peak / pow(10.0, h->o->target_psnr / 10.0);
        int e = 0;
        while (e < GV_HT_MAX_E && (e + 1.0) * (e + 2.0) / 3.0 <= mse)
            e++;
        h->e = m->e = e;
        return 0;
    }
    double q = m->src_float ? 0.5 : 0.0;   /* quantization, in codes */
    double ec = floor(h->o->max_error / m->scale - q + 1e-9);
    if (h->o->max_error > 0 && ec < 0)
        return gv_fail(h->err, GV_EINVAL, ME ": --max-error %g is below the "
                       "16-bit quantization of this float input (%g)",
                       h->o->max_error, m->scale / 2);
    h->e = ec < 0 ? 0 : (ec > GV_HT_MAX_E ? GV_HT_MAX_E : (int)ec);
    m->e = h->e;
    return 0;
}

/* The bound in source units, once the range is known.  Float input:
 * quantizing adds scale/2, and the double arithmetic of the mapping a few
 * ulps of the values (1e-12 of the largest magnitude covers it with room
 * to spare). */
static void set_bound(struct henc *h)
{
    struct gv_height_result *m = &h->m;
    m->max_error = m->src_float
        ? m->scale * (h->e + 0.5) + 1e-12 * fmax(fabs(m->min), fabs(m->max))
        : m->scale * h->e;
}

/* Map w samples of the row `raw` (sample_bytes each) to codes, and keep
 * their range in lo, hi. */
static void to_codes(struct henc *h, const void *raw, int sample_bytes,
                     uint32_t w, uint16_t *codes)
{
    if (sample_bytes == 4) {
        const float *f = raw;
        for (uint32_t x = 0; x < w; x++) {
            double c = floor((f[x] - h->m.offset) / h->m.scale + 0.5);
            codes[x] = (uint16_t)(c < 0 ? 0 : (c > 65535 ? 65535 : c));
        }
    } else if (sample_bytes == 1)
        for (uint32_t x = 0; x < w; x++)
            codes[x] = ((const uint8_t *)raw)[x];
    else if (codes != raw)
        memcpy(codes, raw, (size_t)w * sizeof *codes);
    uint16_t lo = h->lo, hi = h->hi;
    for (uint32_t x = 0; x < w; x++) {
        lo = codes[x] < lo ? codes[x] : lo;
        hi = codes[x] > hi ? codes[x] : hi;
    }
    h->lo = lo;
    h->hi = hi;
}

/* ------------------------------------------------------------ pass 1 */

/* Store row rows_out[k] of level k and feed the level above. */
static int push_row(struct henc *h, int k, const uint16_t *row)
{
    const struct gv_level *l = &h->g.level[k];
    if (gv_strips_store(h->spill, l, h->orig_base[k], 2 * h->c, h->rows_out[k],
                        row, 0, l->width, h->err) < 0)
        return -1;
    h->rows_out[k]++;
    if (k == h->g.root)
        return 0;
    if (!h->have_pending[k]) {
        memcpy(h->pending[k], row, (size_t)l->width * h->c * sizeof *row);
        h->have_pending[k] = 1;
        return 0;
    }
    h->have_pending[k] = 0;
    gv_codes_box_reduce_row(h->pending[k], row, l->width, h->c, h->reduced[k + 1]);
    return push_row(h, k + 1, h->reduced[k + 1]);
}

static int pass1(struct henc *h, struct gv_source *src,
                 const struct gv_source_info *si)
{
    const struct gv_geometry *g = &h->g;
    const uint32_t chunk = chunk_rows(si);
    const size_t row_samples = (size_t)g->width * h->c;
    const size_t raw_row = row_samples * si->sample_bytes;
    uint8_t *buf = malloc((size_t)chunk * raw_row);
    uint16_t *codes = malloc(row_samples * sizeof *codes);
    int rc = -1;
    if (!buf || !codes)
        goto nomem;
    for (int k = 0; k <= g->root; k++) {
        const size_t rb = (size_t)g->level[k].width * h->c * sizeof(uint16_t);
        if (!(h->pending[k] = malloc(rb)) || !(h->reduced[k] = malloc(rb)))
            goto nomem;
    }
    h->lo = 65535;
    h->hi = 0;
    for (uint32_t y = 0; y < g->height; y += chunk) {
        const uint32_t n = g->height - y < chunk ? g->height - y : chunk;
        if (gv_source_read(src, n, buf, h->err) < 0)
            goto out;
        for (uint32_t i = 0; i < n; i++) {
            const uint8_t *raw = buf + (size_t)i * raw_row;
            /* 16-bit rows are codes as they are */
            uint16_t *row = si->sample_bytes == 2 ? (uint16_t *)(void *)raw
                                                  : codes;
            to_codes(h, raw, si->sample_bytes, (uint32_t)row_samples, row);
            if (push_row(h, 0, row) < 0)
                goto out;
        }
        report(h, "pyramid", PASS1_SHARE * (double)(y + n) / g->height);
    }
    /* Odd heights: the last row of a level pairs with itself. */
    for (int k = 0; k < g->root; k++)
        if (h->have_pending[k]) {
            h->have_pending[k] = 0;
            gv_codes_box_reduce_row(h->pending[k], h->pending[k],
                                    g->level[k].width, h->c, h->reduced[k + 1]);
            if (push_row(h, k + 1, h->reduced[k + 1]) < 0)
                goto out;
        }
    if (!h->m.src_float) {
        h->m.min = h->lo * h->m.scale + h->m.offset;
        h->m.max = h->hi * h->m.scale + h->m.offset;
    }
    rc = 0;
    goto out;
nomem:
    gv_fail(h->err, GV_ENOMEM, ME ": out of memory for input rows");
out:
    free(buf);
    free(codes);
    return rc;
}

/* ------------------------------------------------------------ pass 2 */

/* Channel k of tile (tx,ty) of a w x h level of c-channel codes with
 * `stride` pixels from row to row, clamp-padded to 513x513, into the
 * plane t. */
static void extract(const uint16_t *lv, size_t stride, uint32_t w, uint32_t h,
                    int c, int k, uint32_t tx, uint32_t ty, uint16_t *t)
{
    for (uint32_t v = 0; v < GV_HT_SIDE; v++) {
        uint32_t y = ty * GV_STEP + v;
        const uint16_t *row = lv + (size_t)(y < h ? y : h - 1) * stride * c + k;
        uint32_t x0 = tx * GV_STEP;
        uint32_t avail = w - x0 < GV_HT_SIDE ? w - x0 : GV_HT_SIDE;
        uint16_t *o = t + v * GV_HT_SIDE;
        if (c == 1)
            memcpy(o, row + x0, avail * sizeof *t);
        else
            for (uint32_t u = 0; u < avail; u++)
                o[u] = row[(size_t)(x0 + u) * c];
        for (uint32_t u = avail; u < GV_HT_SIDE; u++)
            o[u] = row[(size_t)(w - 1) * c];
    }
}

/* Pool job: code slot `item` of the current page; lens[item] stays 0 for
 * a slot outside the level and on allocation failure. */
static void encode_slot(void *ctx, size_t item, int worker)
{
    struct henc *h = ctx;
    const struct gv_level *l = &h->g.level[h->level];
    const uint32_t i = (uint32_t)(item % GV_PAGE_TILES), j = (uint32_t)(item / GV_PAGE_TILES);
    const uint32_t tx = h->px * GV_PAGE_TILES + i, ty = h->py * GV_PAGE_TILES + j;
    h->lens[item] = 0;
    if (tx >= l->tiles_x || ty >= l->tiles_y)
        return;
    uint16_t *orig = h->orig[worker];
    const int w = (int)gv_tile_span(l->width, tx), hh = (int)gv_tile_span(l->height, ty);
    size_t at = 0;
    h->sse[item] = 0;
    for (int k = 0; k < h->c; k++) {
        /* The window's columns and rows are the level's, from the page on. */
        extract(h->win, h->win_w, h->win_w, h->win_h, h->c, k, i, j, orig);
        uint16_t *dec = h->dec[item] + (size_t)k * GV_HT_SAMPLES;
        /* One channel codes straight into the slot; more go through the
         * worker's buffer and are appended. */
        uint8_t *out = h->c == 1 ? h->bufs[item] : h->chan[worker];
        size_t n = gv_height_tile_encode(
            orig, h->parent_at[(j / 2) * 4 + i / 2] + (size_t)k * GV_HT_SAMPLES,
            (int)(tx & 1), (int)(ty & 1), h->e, w, hh, out, dec);
        if (!n)
            return;
        if (h->c > 1) {
            if (at + n > h->caps[item]) {
                size_t cap = 2 * (at + n);
                uint8_t *b = realloc(h->bufs[item], cap);
                if (!b)
                    return;
                h->bufs[item] = b;
                h->caps[item] = cap;
            }
            memcpy(h->bufs[item] + at, out, n);
        }
        at += n;
        if (h->level == 0)
            h->sse[item] += gv_codes_level0_sse(l, tx, ty, orig, dec, NULL);
    }
    h->lens[item] = at;
}

/* Map (or copy) the current page's window out of its strip. */
static int load_window(struct henc *h)
{
    const struct gv_level *l = &h->g.level[h->level];
    const uint32_t y0 = h->py * PAGE_W;
    h->win_w = gv_strip_width(l->width, h->px);
    h->win_h = l->height - y0 < WINDOW ? l->height - y0 : WINDOW;
    const uint64_t at = gv_strip_at(l, h->orig_base[h->level], 2 * h->c, h->px, y0);
    const size_t span = (size_t)h->win_h * h->win_w * h->c * sizeof(uint16_t);
    gv_spill_unview(&h->view);
    if (gv_spill_view(h->spill, at, span, &h->view) == 0) {
        h->win = (const uint16_t *)(const void *)h->view.data;
        return 0;
    }
    if (!h->copy && !(h->copy = malloc((size_t)WINDOW * WINDOW * h->c * sizeof *h->copy)))
        return gv_fail(h->err, GV_ENOMEM, ME ": out of memory");
    h->win = h->copy;
    return gv_spill_read(h->spill, h->copy, span, at, h->err);
}

/* The 16 decoded parents of the current page: the root tile, or tiles of
 * the level above from the scratch file. */
static int load_parents(struct henc *h)
{
    const int pl = h->level + 1;
    const struct gv_level *l = &h->g.level[pl];
    for (int s = 0; s < 16; s++) {
        const uint32_t ptx = h->px * 4 + (uint32_t)(s % 4);
        const uint32_t pty = h->py * 4 + (uint32_t)(s / 4);
        h->parent_at[s] = pl == h->g.root ? h->root_tile : h->parents[s];
        if (pl == h->g.root || ptx >= l->tiles_x || pty >= l->tiles_y)
            continue;
        if (gv_spill_read(h->spill, h->parents[s], h->tile_bytes,
                          h->recon_base[pl] +
                              ((uint64_t)pty * l->tiles_x + ptx) * h->tile_bytes,
                          h->err) < 0)
            return -1;
    }
    return 0;
}

static int encode_page(struct henc *h)
{
    const struct gv_level *l = &h->g.level[h->level];
    if (load_window(h) < 0 || load_parents(h) < 0)
        return -1;
    gv_pool_run(h->pool, encode_slot, h, GV_PAGE_SLOTS);
    const uint8_t *tb[GV_PAGE_SLOTS] = {0};
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        const uint32_t tx = h->px * GV_PAGE_TILES + (uint32_t)(s % GV_PAGE_TILES);
        const uint32_t ty = h->py * GV_PAGE_TILES + (uint32_t)(s / GV_PAGE_TILES);
        if (tx >= l->tiles_x || ty >= l->tiles_y)
            continue;
        if (!h->lens[s])
            return gv_fail(h->err, GV_ENOMEM, ME ": out of memory");
        tb[s] = h->bufs[s];
        h->tiles++;
        h->sse0 += h->sse[s];
        h->work_done += (double)gv_tile_span(l->width, tx) * gv_tile_span(l->height, ty);
        /* Level 0 is nobody's parent. */
        if (h->level > 0 &&
            gv_spill_write(h->spill, h->dec[s], h->tile_bytes,
                           h->recon_base[h->level] +
                               ((uint64_t)ty * l->tiles_x + tx) * h->tile_bytes,
                           h->err) < 0)
            return -1;
    }
    if (gv_store_writer_page(h->wr, h->level, h->px, h->py, tb, h->lens, h->err) < 0)
        return -1;
    report(h, "encode", PASS1_SHARE + (1.0 - PASS1_SHARE) * h->work_done / h->work_total);
    return 0;
}

static int pass2(struct henc *h)
{
    for (int k = h->g.root - 1; k >= 0; k--) {
        const struct gv_level *l = &h->g.level[k];
        h->level = k;
        for (h->py = 0; h->py < l->pages_y; h->py++)
            for (h->px = 0; h->px < l->pages_x; h->px++)
                if (encode_page(h) < 0)
                    return -1;
    }
    return 0;
}

/* ------------------------------------------------------------ driver */

/* Where each level's codes and decoded tiles lie in the scratch file. */
static void layout_scratch(struct henc *h)
{
    const struct gv_geometry *g = &h->g;
    uint64_t off = 0;
    for (int k = 0; k <= g->root; k++) {
        h->orig_base[k] = off;
        off += gv_strips_bytes(&g->level[k], 2 * h->c);
    }
    h->work_total = 0;
    for (int k = 1; k < g->root; k++) {
        h->recon_base[k] = off;
        off += (uint64_t)g->level[k].tiles_x * g->level[k].tiles_y * h->tile_bytes;
    }
    for (int k = 0; k < g->root; k++)
        h->work_total += (double)g->level[k].width * g->level[k].height;
    if (h->work_total <= 0)
        h->work_total = 1;
}

/* The pool (no more workers than a page has tiles: they would idle) and
 * pass 2's buffers. */
static int start_workers(struct henc *h)
{
    int threads = h->o->threads > 0 ? h->o->threads : gv_cpu_count();
    if (threads > GV_PAGE_SLOTS)
        threads = GV_PAGE_SLOTS;
    if (!(h->pool = gv_pool_new(threads)))
        return gv_fail(h->err, GV_ENOMEM, ME ": cannot start %d threads", threads);
    for (int i = 0; i < gv_pool_size(h->pool); i++)
        if (!(h->orig[i] = malloc(PLANE_BYTES)) ||
            (h->c > 1 && !(h->chan[i] = malloc(GV_HT_BUF_MAX))))
            return gv_fail(h->err, GV_ENOMEM, ME ": out of memory");
    for (int s = 0; s < 16; s++)
        if (!(h->parents[s] = malloc(h->tile_bytes)))
            return gv_fail(h->err, GV_ENOMEM, ME ": out of memory");
    /* A sample store's tile buffers grow as its channels are appended. */
    const size_t cap = h->c == 1 ? GV_HT_BUF_MAX : 4096;
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        if (!(h->dec[s] = malloc(h->tile_bytes)) || !(h->bufs[s] = malloc(cap)))
            return gv_fail(h->err, GV_ENOMEM, ME ": out of memory");
        h->caps[s] = cap;
    }
    return 0;
}

/* After pass 1: the root level's codes, and its clamp-padded tile (the
 * parent of level root-1). */
static int load_root(struct henc *h)
{
    const struct gv_level *rl = &h->g.level[h->g.root];
    const size_t n = (size_t)rl->width * rl->height * h->c;
    h->root = malloc(n * sizeof *h->root);
    h->root_tile = malloc(h->tile_bytes);
    if (!h->root || !h->root_tile)
        return gv_fail(h->err, GV_ENOMEM, ME ": out of memory for the root");
    if (gv_spill_read(h->spill, h->root, n * sizeof *h->root,
                      h->orig_base[h->g.root], h->err) < 0)
        return -1;
    for (int k = 0; k < h->c; k++)
        extract(h->root, rl->width, rl->width, rl->height, h->c, k, 0, 0,
                h->root_tile + (size_t)k * GV_HT_SAMPLES);
    return 0;
}

/* Level 0's PSNR over the samples' full range (section 13), once pass 2
 * is done, capped at 99 dB (lossless) as an image store's. */
static double psnr0(const struct henc *h)
{
    return gv_codes_psnr(h->sse0, (double)h->g.width * h->g.height * h->c,
                         full_range(h));
}

/* -q: refine pick_e's uniform rule by coding a sample (codes_trial.h). */
static int choose_e(struct henc *h)
{
    if (h->o->target_psnr <= 0)
        return 0;
    struct gv_codes_trial t = {
        .spill = h->spill, .g = &h->g, .orig_base = h->orig_base, .c = h->c,
        .root_tile = h->root_tile, .pool = h->pool,
        .peak = full_range(h),
    };
    int e;
    if (gv_codes_trial(&t, h->o->target_psnr, h->e, &e, &h->m.trial_tries,
                       &h->m.trial_psnr, h->err) < 0)
        return -1;
    h->m.uniform_e = h->e;
    h->e = h->m.e = e;
    return 0;
}

/* A sample store's metadata: what the input says of its pixels, and the
 * default display window (on codes, 0..65535) and colours if given,
 * packed. */
static int samples_meta(struct henc *h, struct gv_source *src)
{
    const char *meta = gv_source_meta(src);
    char *merged = NULL, *coloured = NULL;
    if (h->o->colours) {
        struct gv_colours c;
        if (gv_colours_parse(h->o->colours, &c, h->err) < 0 ||
            gv_colours_check(&c, h->c, h->err) < 0 ||
            !(meta = coloured = gv_colours_meta_set(meta, &c, h->err)))
            return -1;
    }
    if (h->o->window) {
        struct gv_window w;
        int bad = gv_window_parse(h->o->window, 65535, &w, h->err) < 0;
        if (!bad && w.count != 1 && w.count != h->c)
            bad = gv_fail(h->err, GV_EINVAL, "window: %d windows for an "
                          "image of %d channels (give one, or one per "
                          "channel)", w.count, h->c) < 0;
        if (bad || !(meta = merged = gv_window_meta_set(meta, &w, h->err))) {
            free(coloured);
            return -1;
        }
    }
    int rc = meta ? gv_meta_pack(meta, strlen(meta), &h->meta, &h->meta_len,
                                 h->err) : 0;
    free(merged);
    free(coloured);
    return rc;
}

/* The header of the store, once the range is known. */
static void height_header(const struct henc *h, struct gv_header *hd)
{
    const struct gv_height_result *m = &h->m;
    memset(hd, 0, sizeof *hd);
    hd->width = h->g.width;
    hd->height = h->g.height;
    hd->channels = (uint8_t)h->c;
    hd->src_bits = m->src_float ? 32 : h->kind == GV_KIND_SAMPLES ? (uint8_t)h->src_bits : 16;
    hd->src_float = (uint8_t)m->src_float;
    hd->kind = (uint8_t)h->kind;
    hd->height_float = (uint8_t)m->src_float;
    hd->height_e = (uint16_t)h->e;
    hd->height_scale = m->scale;
    hd->height_offset = m->offset;
    hd->height_max_error = m->max_error;
    hd->height_min = (float)m->min;
    hd->height_max = (float)m->max;
    if (h->o->unit)
        snprintf(hd->height_unit, sizeof hd->height_unit, "%s", h->o->unit);
    if (h->kind == GV_KIND_SAMPLES) {
        hd->samples_lo = h->lo;
        hd->samples_hi = h->hi;
        hd->root_side = (uint16_t)h->g.root_side;
        gv_samples_derive(hd);
    }
}

static void teardown(struct henc *h)
{
    gv_store_writer_abort(h->wr);
    gv_pool_free(h->pool);
    gv_spill_unview(&h->view);
    free(h->copy);
    free(h->root);
    free(h->root_tile);
    for (int s = 0; s < 16; s++)
        free(h->parents[s]);
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        free(h->dec[s]);
        free(h->bufs[s]);
        free(h->orig[s]);
        free(h->chan[s]);
    }
    free(h->meta);
    for (int k = 0; k < GV_MAX_LEVELS; k++) {
        free(h->pending[k]);
        free(h->reduced[k]);
    }
    gv_spill_free(h->spill);
}

/* Everything after the options are checked.  0 or -1 with h->err. */
static int encode(struct henc *h, const char *output, struct gv_height_result *r)
{
    struct gv_source_info si;
    struct gv_source *src = open_input(h, &si);
    if (!src)
        return -1;
    h->m.src_float = si.src_float;
    h->c = si.channels;
    h->kind = h->o->samples ? GV_KIND_SAMPLES : GV_KIND_HEIGHT;
    h->tile_bytes = PLANE_BYTES * (size_t)h->c;
    h->src_bits = si.src_bits > 16 ? 16 : si.src_bits;
    /* Only the size so far: float input is read first for its range. */
    /* A sample store's root is small, as an image store's (the root is
     * lossless, the tiles below it at the store's bound). */
    const uint32_t side = h->kind == GV_KIND_SAMPLES ? GV_ROOT_SIDE : GV_ROOT_MAX;
    if (gv_geometry_init(&h->g, si.width, si.height, h->c, side) < 0) {
        gv_source_free(src);
        return gv_fail(h->err, GV_EINVAL, ME ": bad dimensions %ux%u",
                       si.width, si.height);
    }
    if (si.src_float) {
        gv_source_free(src);
        if (float_range(h) < 0 || !(src = open_input(h, &si)))
            return -1;
    }
    int rc = -1;
    if (pick_e(h) < 0 || (h->kind == GV_KIND_SAMPLES && samples_meta(h, src) < 0))
        goto out;
    layout_scratch(h);
    if (!(h->spill = gv_strips_spill_new(h->o->tmpdir, output, h->err)) ||
        pass1(h, src, &si) < 0)
        goto out;
    gv_source_free(src);
    src = NULL;
    if (load_root(h) < 0 || start_workers(h) < 0 || choose_e(h) < 0)
        goto out;
    set_bound(h);
    struct gv_header hd;
    height_header(h, &hd);
    if (h->kind == GV_KIND_SAMPLES) {   /* as a reader will see them */
        h->m.min = hd.height_min;
        h->m.max = hd.height_max;
        h->m.max_error = hd.height_max_error;
    }
    if (!(h->wr = gv_store_writer_new(output, &hd, h->err)) || pass2(h) < 0 ||
        (h->meta && gv_store_writer_meta(h->wr, h->meta, h->meta_len, h->err) < 0) ||
        gv_store_writer_root(h->wr, (const uint8_t *)(const void *)h->root,
                             h->err) < 0)
        goto out;
    if (h->kind == GV_KIND_SAMPLES)
        gv_store_writer_set_psnr(h->wr, (uint32_t)lround(psnr0(h) * 1000.0));
    uint64_t bytes = gv_store_writer_bytes(h->wr);
    struct gv_store_writer *w = h->wr;
    h->wr = NULL;
    if (gv_store_writer_finish(w, h->err) < 0)
        goto out;
    *r = h->m;
    r->geometry = h->g;
    r->tiles = h->tiles;
    r->e = h->e;
    r->channels = h->c;
    r->psnr0 = psnr0(h);
    /* the index and header follow the pages and the root */
    r->file_bytes = bytes + h->g.pages * GV_INDEX_ENTRY + 4;
    r->scratch_bytes = gv_spill_bytes(h->spill);
    report(h, "done", 1.0);
    rc = 0;
out:
    gv_source_free(src);
    return rc;
}

int gv_height_encode(const char *const *inputs, int n, const char *output,
                     const struct gv_height_opts *o,
                     struct gv_height_result *r, struct gv_error *err)
{
    const double t0 = gv_encode_now();
    if (o->unit && (strlen(o->unit) > GV_HEIGHT_UNIT ||
                    strspn(o->unit, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                    "0123456789-_.^/%") != strlen(o->unit)))
        return gv_fail(err, GV_EINVAL, ME ": --unit wants up to %d letters, "
                       "digits or -_.^/%%", GV_HEIGHT_UNIT);
    struct henc h;
    memset(&h, 0, sizeof h);
    h.o = o;
    h.inputs = inputs;
    h.n = n;
    h.name = n == 1 ? inputs[0] : "the mosaic";
    h.err = err;
    h.so.mosaic_cols = o->mosaic_cols;
    h.so.mosaic_rows = o->mosaic_rows;
    h.so.max_pixels = o->max_pixels;
    h.so.max_decoder_bytes = o->max_decoder_bytes;
    h.so.plane = o->plane;
    h.so.native = 1;
    h.m.scale = o->mapped ? o->scale : 1;
    h.m.offset = o->mapped ? o->offset : 0;
    struct gv_height_result tmp;
    int rc = encode(&h, output, r ? r : &tmp);
    teardown(&h);
    if (rc == 0 && r)
        r->seconds = gv_encode_now() - t0;
    return rc;
}
