/*
 * stream_encoder.c - the two-pass streaming encoder (see stream_encoder.h).
 *
 * Scratch layout, in two unnamed files: level 0 of the original pyramid
 * alone in one, and in the other levels k = 1..root, each at orig_base[k]
 * (level 0's is 0, in its own file) in strips (strips.h: one per column
 * of pages, so that a page's window is one contiguous span of the file
 * and can be mapped as it is); decoded tiles
 * of level k (1..root-1) are stored as 513x513xC records at
 * recon_base[k], row-major by tile, because level k-1 is predicted from
 * decoded tiles, not from a decoded image.
 * Where level 0 fits in the page window and the encoder is not a shard,
 * it is kept there instead, from pass 1 until pass 2 has coded it
 * (level0_resident).  Else, where the input file holds its pixels
 * uncompressed as pass 1 read them (an uncompressed 8-bit TIFF), pass 2
 * reads each level-0 tile from the file again (level0_file,
 * imageio/raw_regions.h) and level 0 is never written to scratch: that
 * saves a copy as large as the input, written, kept in the page cache
 * beside the input's own pages, and read back (a 1.07-gigapixel tiled
 * TIFF: 3.2 GB; bench/README.md, 2026-11-26, the gigapixel mosaic at 1.18–1.33×).
 *
 * Working set of pass 2 for one page: the original window (4097^2 x C;
 * mapped from the scratch file where it can be, else copied from it),
 * up to 16 parent tiles, 64 decoded tiles (level 0: one per thread, since
 * no level is predicted from it) and 64 tile buffers, plus one tile
 * workspace per thread.  Pass 1 holds one chunk of input rows (in two
 * halves: one being decoded by the reader thread) and one pending row
 * per level.
 *
 * A shard writes only the pixels of its tiles to the scratch file, which
 * is sized once so that the rest are holes (they read as zeros and take
 * no disk), skips the pages it has no tile in, and leaves the other slots
 * of its pages unencoded: every tile it encodes has its parent among them
 * too, so what it reads from the holes is never used.
 *
 * Threads: pass 1 reads the input on a thread of its own while the
 * encoder's thread reduces and stores the rows; pass 2 codes each page's
 * tiles on the pool, while one more thread packs the root's lossless WebP
 * (which depends only on the root's pixels) for finish_store.
 */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <sys/mman.h>
#include <unistd.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "base/pool.h"
#include "base/spill.h"
#include "codec/tile.h"
#include "encode/encode_int.h"
#include "encode/lambda_model.h"
#include "encode/lambda_trial.h"
#include "encode/shard_file.h"
#include "encode/shard_plan.h"
#include "encode/stream_encoder.h"
#include "encode/strips.h"
#include "encode/tile_pass.h"
#include "imageio/raw_regions.h"
#include "render/store_decoder.h"
#include "render/window.h"
#include "store/store_format.h"
#include "store/store_meta.h"
#include "store/store_write.h"

#define WINDOW GV_STRIP_WINDOW                /* 4097: a page plus overlap */
#define PAGE_W GV_STRIP_PAGE_W                /* 4096: from page to page */
#define CHUNK_BYTES (16u << 20)               /* input rows in memory (two halves) */
#define PASS1_SHARE 0.15                      /* progress weight of pass 1 */

void gv_encode_opts_default(struct gv_encode_opts *o)
{
    memset(o, 0, sizeof *o);
    o->target_psnr = GV_DEFAULT_PSNR;
    o->max_rate = GV_DEFAULT_MAX_RATE;
}

struct encoder {
    const struct gv_encode_opts *opts;
    uint8_t *meta;            /* the store's metadata section (store_meta.h)
                               * from the input's, or NULL */
    size_t meta_len;
    double target_mse;        /* gv_psnr_to_mse(opts->target_psnr) */
    double lambda;            /* equal-slope mode: the price of a bit */
    double level_f;           /* ... in level k: lambda * level_f^k */
    struct gv_lambda_model model[GV_MAX_LEVELS]; /* levels' detail, pass 1 */
    struct gv_lambda_trial trial; /* the tiles that correct lambda before
                                   * pass 2 (equal-slope mode) */
    struct gv_lambda_trial_result trial_res; /* ... and their chosen coding */
    struct gv_geometry g;
    int c;
    struct gv_spill *spill;   /* levels 1 .. root, decoded tiles */
    /* Level 0, in a file of its own: pass 1's reader writes it while the
     * encoder's thread writes the levels above, and writes to one file
     * wait on each other (the inode's lock, spun on: 1.6 % of an 8 MP
     * photograph's encode). */
    struct gv_spill *spill0;
    uint64_t orig_base[GV_MAX_LEVELS], recon_base[GV_MAX_LEVELS];
    struct gv_store_writer *writer;
    struct gv_shard_plan plan;
    int sharded;              /* plan is in use; shard replaces writer */
    struct gv_shard_writer *shard;
    struct gv_pool *pool;
    struct gv_tile_workspace **ws;
    int nws;
    uint8_t *root;            /* the root level's pixels */
    uint8_t *root_tile;       /* ... clamp-padded to a tile: level R-1's parent */
    struct root_packer {      /* the root's WebP, packed during pass 2 */
        pthread_t thread;
        int started, rc;
        uint8_t *z;
        size_t zlen;
        struct gv_error err;
    } packer;
    struct gv_encode_result *res;
    struct gv_error *err;
    /* pass 1 */
    uint8_t *pending[GV_MAX_LEVELS];
    int have_pending[GV_MAX_LEVELS];
    uint32_t rows_out[GV_MAX_LEVELS];
    uint8_t *reduced[GV_MAX_LEVELS];
    /* pass 2: the current page */
    int level;
    uint32_t px, py;
    uint8_t *window;          /* WINDOW x WINDOW x C */
    uint32_t win_w, win_h;
    const uint8_t *win;       /* the page's window: a view, or window */
    size_t win_stride;        /* bytes from one of its rows to the next */
    struct gv_spill_view view;
    int no_views;             /* GIGAVIEW_SPILL_VIEWS=0: always copy */
    int window_resident;      /* copies' pages may be in memory */
    /* Level 0 kept whole in window (rows of width * C bytes) from pass 1
     * to the end, never written to the scratch file: where it fits
     * (width * height <= 4097^2), the encoder is not a shard and the
     * image is more than its root.  The other levels' windows are then
     * copied, where they cannot be mapped, into copies instead. */
    int level0_resident;
    /* Level 0 read again from the input file in pass 2, tile by tile
     * (see the top of the file); NULL where it is not. */
    struct gv_raw_regions *level0_file;
    /* A pool job that failed (reading level0_file): the first error. */
    atomic_int job_failed;
    struct gv_error job_err;
    uint8_t *copies;          /* window, or memory of its own */
    uint8_t *parents[16];     /* decoded parent tiles, 4x4 around the page */
    const uint8_t *parent_at[16]; /* where they are: parents, or kept */
    /* Level 1 is one page, whose decoded tiles stay in recon while level
     * 0 (which does not use recon) is coded: they are its parents, never
     * stored in the scratch file and read back. */
    int level1_kept;
    uint8_t *recon[GV_PAGE_SLOTS];
    uint8_t *bufs[GV_PAGE_SLOTS];
    size_t lens[GV_PAGE_SLOTS];
    struct gv_tile_stats stats[GV_PAGE_SLOTS];
    uint8_t *tile_rate[GV_MAX_LEVELS]; /* levels >= 1: each tile's rate */
    uint8_t order[GV_PAGE_SLOTS];      /* the page's slots, likely slowest first */
    uint64_t canon_sse[GV_PAGE_SLOTS];
    uint8_t *origs;           /* per-worker 513^2 x C original tile */
    uint8_t *wrecon;          /* per-worker decoded tile, level 0 (kept
                               * by nobody: no level is predicted from it) */
    /* progress */
    double work_total, work_done;
};

static void report(struct encoder *e, const char *phase, double fraction)
{
    if (!e->opts->progress)
        return;
    /* Tiles overlap by one pixel, so the samples they count add up to a
     * little more than the levels' pixels: never report past the end. */
    if (fraction > 1.0)
        fraction = 1.0;
    struct gv_encode_progress p = {
        .fraction = fraction,
        .source_pixels = (uint64_t)e->g.width * e->g.height,
        .phase = phase,
        .level = e->level,
    };
    e->opts->progress(e->opts->progress_ctx, &p);
}

/* ------------------------------------------------------------ pass 1 */

static int push_row(struct encoder *e, int k, const uint8_t *row);

/* The scratch file that holds level k's original. */
static struct gv_spill *level_spill(const struct encoder *e, int k)
{
    return k == 0 ? e->spill0 : e->spill;
}

/* Offset of row y of strip p of level k in its scratch file. */
static uint64_t strip_at(const struct encoder *e, int k, uint32_t p, uint32_t y)
{
    return gv_strip_at(&e->g.level[k], e->orig_base[k], (size_t)e->c, p, y);
}

/* Store columns x0 .. x1-1 of row y of level k (row holds the whole
 * row), in each strip they reach. */
static int store_columns(struct encoder *e, int k, uint32_t y,
                         const uint8_t *row, uint32_t x0, uint32_t x1)
{
    return gv_strips_store(level_spill(e, k), &e->g.level[k], e->orig_base[k],
                           (size_t)e->c, y, row, x0, x1, e->err);
}

/* A shard keeps the original of tile (tx, ty) of level k: its own, and
 * the lambda trial's sample, which every shard encodes alike. */
static int shard_keeps(const struct encoder *e, int k, uint32_t tx, uint32_t ty)
{
    return gv_shard_plan_wants(&e->plan, &e->g, k, tx, ty) ||
           gv_lambda_trial_wants(&e->trial, k, tx, ty);
}

/* Store row `rows_out[k]` of level k in the scratch file: all of it, or
 * for a shard the runs of columns that its tiles of level k (and the
 * trial's) cover. */
static int store_row(struct encoder *e, int k, const uint8_t *row)
{
    const struct gv_level *l = &e->g.level[k];
    if (!e->sharded || k == e->g.root)
        return store_columns(e, k, e->rows_out[k], row, 0, l->width);
    /* Row y is in tile row y/512, and is row 512 of the tile row above
     * when y is a multiple of 512. */
    const uint32_t y = e->rows_out[k], ta = y / GV_STEP;
    const int above = y % GV_STEP == 0 && y > 0;
    uint32_t run = 0;
    int in_run = 0;
    for (uint32_t tx = 0; tx <= l->tiles_x; tx++) {
        int want = tx < l->tiles_x &&
                   (shard_keeps(e, k, tx, ta) || (above && shard_keeps(e, k, tx, ta - 1)));
        if (want && !in_run) {
            run = tx;
            in_run = 1;
        } else if (!want && in_run) {
            /* Tiles run..tx-1 cover columns 512*run .. 512*(tx-1)+512. */
            uint32_t x0 = run * GV_STEP, x1 = tx * GV_STEP + 1;
            if (x1 > l->width)
                x1 = l->width;
            if (store_columns(e, k, y, row, x0, x1) < 0)
                return -1;
            in_run = 0;
        }
    }
    return 0;
}

static int emit_reduced(struct encoder *e, int k, const uint8_t *r0,
                        const uint8_t *r1)
{
    const struct gv_level *l = &e->g.level[k];
    gv_box_reduce_row(r0, r1, l->width, e->c, e->reduced[k + 1]);
    if (!e->opts->per_tile)
        gv_lambda_model_rows(&e->model[k], r0, r1, e->reduced[k + 1]);
    return push_row(e, k + 1, e->reduced[k + 1]);
}

/* Store row `rows_out[k]` of level k and count it; level 0's rows are
 * stored by pass 1's reader, except a shard's (see struct reader), and
 * not at all when pass 2 reads them from the input file. */
static int store_next(struct encoder *e, int k, const uint8_t *row)
{
    if ((k > 0 || (e->sharded && !e->level0_file)) &&
        store_row(e, k, row) < 0)
        return -1;
    e->rows_out[k]++;
    return 0;
}

/* Store row `rows_out[k]` of level k and feed the level above. */
static int push_row(struct encoder *e, int k, const uint8_t *row)
{
    const struct gv_level *l = &e->g.level[k];
    const size_t rb = (size_t)l->width * e->c;
    if (store_next(e, k, row) < 0)
        return -1;
    if (k == e->g.root)
        return 0;
    if (!e->have_pending[k]) {
        memcpy(e->pending[k], row, rb);
        e->have_pending[k] = 1;
        return 0;
    }
    e->have_pending[k] = 0;
    return emit_reduced(e, k, e->pending[k], row);
}

/* push_row of level-0 rows r0 and r1 in turn when no row is pending and
 * both lie in the input chunk: the pair is reduced where it is, without
 * the copy of r0 that push_row keeps for a pair split between chunks. */
static int push_pair0(struct encoder *e, const uint8_t *r0, const uint8_t *r1)
{
    if (store_next(e, 0, r0) < 0 || store_next(e, 0, r1) < 0)
        return -1;
    return emit_reduced(e, 0, r0, r1);
}

/* Pass 1's input reader: a thread that decodes the next chunk of rows
 * while the encoder's thread reduces and stores the previous one, in two
 * buffers of CHUNK_BYTES / 2 (the memory of one chunk before).  A chunk
 * is ready when rows[slot] > 0; the consumer sets it back to 0.  Unless
 * the encoder is a shard (which keeps only its tiles' columns), the
 * reader also writes the chunk's rows to level 0 of the scratch file
 * (where they lie end to end).  That takes the largest copy off
 * the encoder's thread, which bounds pass 1 on an input that is cheap to
 * decode (a 54 MP uncompressed tiled TIFF: the whole encode 1.28 -> 1.20 s,
 * best of 4; bench/README.md, "2026-11-26, encoding").
 * Where the input is read where it lies (gv_source_reads_raw), which
 * costs the reader little, and there are levels above level 0, the
 * reader also reduces each pair of the chunk's rows into level 1 (red)
 * and feeds level 0's rate model, and the encoder's thread takes the
 * level-1 rows from there: that work had bounded pass 1 on the encoder's
 * thread (the model alone 36 % of pass 1 on the 1.07-gigapixel bench
 * mosaic), while the reader waited.  Chunks then hold an even number of
 * rows, so that no pair is split between two; an odd last row pairs
 * with itself, as it does in push_row.  A decoder (JPEG, PNG, LZW...)
 * keeps the reader busy enough, and the encoder's thread does that work
 * as before. */
struct reader {
    struct gv_source *src;
    struct gv_spill *spill;   /* NULL: the encoder's thread stores level 0 */
    const struct encoder *e;  /* level 0's geometry and strips (strip_at) */
    size_t row_bytes;
    uint32_t chunk, height;
    uint8_t *buf[2];
    uint8_t *red[2];          /* level-1 rows of buf[i]'s pairs, or NULL */
    struct gv_lambda_model *model0;  /* level 0's, fed with red, or NULL */
    uint8_t *whole;           /* else: chunk at y read to whole + y rows */
    uint32_t rows[2];
    int failed, stop;
    struct gv_error err;
    pthread_mutex_t mu;
    pthread_cond_t cv;
};

static void *reader_main(void *arg)
{
    struct reader *r = arg;
    int slot = 0;
    for (uint32_t y = 0; y < r->height; y += r->chunk, slot ^= 1) {
        const uint32_t n = r->height - y < r->chunk ? r->height - y : r->chunk;
        pthread_mutex_lock(&r->mu);
        while (r->rows[slot] && !r->stop)
            pthread_cond_wait(&r->cv, &r->mu);
        const int stop = r->stop;
        pthread_mutex_unlock(&r->mu);
        if (stop)
            break;
        struct gv_error err = {0};
        uint8_t *dst = r->whole ? r->whole + (size_t)y * r->row_bytes
                                : r->buf[slot];
        int rc = gv_source_read(r->src, n, dst, &err);
        /* Each strip's rows lie end to end in the file (strip_at). */
        const struct gv_level *l0 = &r->e->g.level[0];
        const int c = r->e->c;
        for (uint32_t p = 0; rc == 0 && r->spill && p < gv_strip_count(l0); p++)
            rc = gv_spill_write_rows(
                r->spill, dst + (size_t)p * PAGE_W * c, r->row_bytes,
                (size_t)gv_strip_width(l0->width, p) * c, n,
                strip_at(r->e, 0, p, y), &err);
        const size_t rb1 = (size_t)r->e->g.level[1].width * c;
        for (uint32_t i = 0; rc == 0 && r->red[slot] && i < n; i += 2) {
            const uint8_t *r0 = dst + (size_t)i * r->row_bytes;
            const uint8_t *r1 = i + 1 < n ? r0 + r->row_bytes : r0;
            uint8_t *out = r->red[slot] + (size_t)(i / 2) * rb1;
            gv_box_reduce_row(r0, r1, l0->width, c, out);
            if (r->model0)
                gv_lambda_model_rows(r->model0, r0, r1, out);
        }
        pthread_mutex_lock(&r->mu);
        if (rc < 0) {
            r->err = err;
            r->failed = 1;
        } else {
            r->rows[slot] = n;
        }
        pthread_cond_broadcast(&r->cv);
        pthread_mutex_unlock(&r->mu);
        if (rc < 0)
            break;
    }
    return NULL;
}

/* Rows a chunk of pass 1 holds: about CHUNK_BYTES / 2 of them, even
 * when the reader reduces pairs of rows (`split`). */
static uint32_t pass1_chunk(const struct gv_geometry *g, size_t rb0, int split)
{
    uint32_t chunk = (uint32_t)(CHUNK_BYTES / 2 / rb0);
    /* At least eight chunks (of 64 rows or more) on an image whose rows
     * would fill fewer: the encoder's thread waits for the reader's first
     * chunk, and the reader for the encoder's last, so a third of the
     * image in each (an 8 MP photograph) left a thread idle for a third
     * of the pass. */
    const uint32_t eighth = (g->height + 7) / 8;
    if (chunk > eighth)
        chunk = eighth < 64 ? 64 : eighth;
    if (chunk < 1)
        chunk = 1;
    if (chunk > g->height)
        chunk = g->height;
    /* Pairs of rows reduced by the reader (see struct reader). */
    if (split)
        chunk = chunk < 2 ? 2 : chunk & ~1u;
    return chunk;
}

/* Feed the n rows of one chunk of pass 1 (rows; with `split`, also the
 * reader's n / 2 level-1 rows, red) into the pyramid.  Returns 0 or -1
 * (e->err set). */
static int pass1_rows(struct encoder *e, const uint8_t *rows,
                      const uint8_t *red, uint32_t n, int split)
{
    const struct gv_geometry *g = &e->g;
    const size_t rb0 = (size_t)g->width * e->c;
    if (split) {
        const size_t rb1 = (size_t)g->level[1].width * e->c;
        /* Level 0's rows counted (and a shard's stored), then the
         * level-1 rows the reader made of them. */
        for (uint32_t r = 0; r < n; r++)
            if (store_next(e, 0, rows + (size_t)r * rb0) < 0)
                return -1;
        for (uint32_t i = 0; i < n; i += 2)
            if (push_row(e, 1, red + (size_t)(i / 2) * rb1) < 0)
                return -1;
        return 0;
    }
    for (uint32_t r = 0; r < n; r++) {
        const uint8_t *row = rows + (size_t)r * rb0;
        if (g->root == 0 || e->have_pending[0] || r + 1 == n) {
            if (push_row(e, 0, row) < 0)
                return -1;
        } else {
            if (push_pair0(e, row, row + rb0) < 0)
                return -1;
            r++;
        }
    }
    return 0;
}

static int pass1(struct encoder *e, struct gv_source *src)
{
    const int split = e->g.root > 0 && gv_source_reads_raw(src);
    const struct gv_geometry *g = &e->g;
    const size_t rb0 = (size_t)g->width * e->c;
    const uint32_t chunk = pass1_chunk(g, rb0, split);
    const size_t rb1 = split ? (size_t)g->level[1].width * e->c : 0;
    /* Level 0 in memory: read where it stays, not stored. */
    struct reader rd = {.src = src, .chunk = chunk, .height = g->height,
                        .spill = e->sharded || e->level0_resident ||
                                         e->level0_file ? NULL : e->spill0,
                        .whole = e->level0_resident ? e->window : NULL,
                        .e = e, .row_bytes = rb0};
    int rc = -1, started = 0;
    pthread_mutex_init(&rd.mu, NULL);
    pthread_cond_init(&rd.cv, NULL);
    pthread_t thread;
    /* The chunk's halves live in pass 2's page window, unused until
     * then, so that memory the process has faulted in once serves both
     * passes (each half is at most CHUNK_BYTES / 2, and the window holds
     * 4097^2 x C bytes, more than CHUNK_BYTES); only rows wider than the
     * window's half get memory of their own. */
    const int own = !e->level0_resident &&
                    2 * (size_t)chunk * rb0 > (size_t)WINDOW * WINDOW * e->c;
    e->window_resident |= !own && !e->level0_resident;
    rd.buf[0] = own ? malloc((size_t)chunk * rb0) : e->window;
    rd.buf[1] = own ? malloc((size_t)chunk * rb0) : e->window + (size_t)chunk * rb0;
    if (split) {
        rd.red[0] = malloc((size_t)(chunk / 2) * rb1);
        rd.red[1] = malloc((size_t)(chunk / 2) * rb1);
        rd.model0 = e->opts->per_tile ? NULL : &e->model[0];
    }
    if (!rd.buf[0] || !rd.buf[1] || (split && (!rd.red[0] || !rd.red[1]))) {
        gv_fail(e->err, GV_ENOMEM, "encode: out of memory for input rows");
        goto out;
    }
    for (int k = 0; k <= g->root; k++) {
        size_t rb = (size_t)g->level[k].width * e->c;
        e->pending[k] = malloc(rb);
        e->reduced[k] = malloc(rb);
        if (!e->pending[k] || !e->reduced[k]) {
            gv_fail(e->err, GV_ENOMEM, "encode: out of memory for pyramid rows");
            goto out;
        }
    }
    if (pthread_create(&thread, NULL, reader_main, &rd) != 0) {
        gv_fail(e->err, GV_ENOMEM, "encode: cannot start the input reader");
        goto out;
    }
    started = 1;
    int slot = 0;
    for (uint32_t y = 0; y < g->height; slot ^= 1) {
        pthread_mutex_lock(&rd.mu);
        while (!rd.rows[slot] && !rd.failed)
            pthread_cond_wait(&rd.cv, &rd.mu);
        const uint32_t n = rd.rows[slot];
        if (!n) {
            *e->err = rd.err;
            pthread_mutex_unlock(&rd.mu);
            goto out;
        }
        pthread_mutex_unlock(&rd.mu);
        const uint8_t *rows = rd.whole ? rd.whole + (size_t)y * rb0
                                       : rd.buf[slot];
        if (pass1_rows(e, rows, rd.red[slot], n, split) < 0)
            goto out;
        pthread_mutex_lock(&rd.mu);
        rd.rows[slot] = 0;
        pthread_cond_broadcast(&rd.cv);
        pthread_mutex_unlock(&rd.mu);
        y += n;
        report(e, "pyramid", PASS1_SHARE * (double)y / g->height);
    }
    /* Odd heights: the last row of a level pairs with itself (level 0's
     * the reader's, when it reduces). */
    for (int k = 0; k < g->root; k++)
        if (e->have_pending[k]) {
            e->have_pending[k] = 0;
            if (emit_reduced(e, k, e->pending[k], e->pending[k]) < 0)
                goto out;
        }
    rc = 0;
out:
    if (started) {
        pthread_mutex_lock(&rd.mu);
        rd.stop = 1;
        pthread_cond_broadcast(&rd.cv);
        pthread_mutex_unlock(&rd.mu);
        pthread_join(thread, NULL);
    }
    if (own) {
        free(rd.buf[0]);
        free(rd.buf[1]);
    }
    free(rd.red[0]);
    free(rd.red[1]);
    pthread_cond_destroy(&rd.cv);
    pthread_mutex_destroy(&rd.mu);
    return rc;
}

/* ------------------------------------------------------------ pass 2 */


/* Repeat the last of the w x h pixels read into orig (513x513xC) to the
 * tile's right and bottom edges. */
static void pad_tile(uint8_t *orig, uint32_t w, uint32_t h, int c)
{
    const size_t row = (size_t)GV_TILE * c;
    for (uint32_t v = 0; v < GV_TILE; v++) {
        uint8_t *dst = orig + v * row;
        if (v >= h)
            memcpy(dst, orig + (h - 1) * row, row);
        else
            for (uint32_t u = w; u < GV_TILE; u++)
                memcpy(dst + u * c, dst + (size_t)(w - 1) * c, (size_t)c);
    }
}

/* The original of tile (tx, ty) of level k, the last row and column
 * repeated past the image's edge: from level 0 kept whole, the input
 * file, or the scratch file's strip (which holds the lambda trial's tiles
 * in a shard too, shard_keeps).  The lambda trial's read_orig
 * (lambda_trial.h), between the passes, and pass 2's reader of level 0
 * from the input file (cut_tile).  Returns 0 or -1 with *err. */
static int read_orig_tile(const void *ctx, int k, uint32_t tx, uint32_t ty,
                          uint8_t *orig, struct gv_error *err)
{
    const struct encoder *e = ctx;
    const struct gv_level *l = &e->g.level[k];
    const int c = e->c;
    const size_t row = (size_t)GV_TILE * c;
    const uint32_t x0 = tx * GV_STEP, y0 = ty * GV_STEP;
    const uint32_t w = gv_tile_span(l->width, tx), h = gv_tile_span(l->height, ty);
    if (k == 0 && e->level0_file) {
        if (gv_raw_regions_read(e->level0_file, x0, y0, w, h, orig, row, err) < 0)
            return -1;
    } else if (k == 0 && e->level0_resident) {
        const size_t rb = (size_t)l->width * c;
        for (uint32_t v = 0; v < h; v++)
            memcpy(orig + v * row, e->window + (size_t)(y0 + v) * rb + (size_t)x0 * c,
                   (size_t)w * c);
    } else {
        /* A tile lies within the strip of its column of pages. */
        const uint32_t p = x0 / PAGE_W;
        for (uint32_t v = 0; v < h; v++)
            if (gv_spill_read(level_spill(e, k), orig + v * row, (size_t)w * c,
                              strip_at(e, k, p, y0 + v) +
                                  (uint64_t)(x0 - p * PAGE_W) * c, err) < 0)
                return -1;
    }
    pad_tile(orig, w, h, c);
    return 0;
}

/* Cut the original of tile (i, j) of the current page out of the page
 * window into orig (513x513xC), repeating the last row and column past
 * the image's edge; at level 0 read from the input file where it is
 * (read_orig_tile).  Returns 0 or -1 with *err. */
static int cut_tile(const struct encoder *e, int i, int j, uint8_t *orig,
                    struct gv_error *err)
{
    if (e->level == 0 && e->level0_file)
        return read_orig_tile(e, 0, e->px * GV_PAGE_TILES + (uint32_t)i,
                              e->py * GV_PAGE_TILES + (uint32_t)j, orig, err);
    const int c = e->c;
    const size_t row = (size_t)GV_TILE * c;
    for (uint32_t v = 0; v < GV_TILE; v++) {
        uint32_t wy = (uint32_t)j * GV_STEP + v;
        if (wy >= e->win_h)
            wy = e->win_h - 1;
        const uint8_t *src = e->win + (size_t)wy * e->win_stride;
        uint8_t *dst = orig + v * row;
        uint32_t x0 = (uint32_t)i * GV_STEP;
        uint32_t avail = e->win_w - x0 < GV_TILE ? e->win_w - x0 : GV_TILE;
        memcpy(dst, src + (size_t)x0 * c, (size_t)avail * c);
        for (uint32_t u = avail; u < GV_TILE; u++)
            memcpy(dst + u * c, src + (size_t)(e->win_w - 1) * c, (size_t)c);
    }
    return 0;
}


static int env_off(const char *name);

/* Correct the model's lambda by trial encodes of the sample
 * (lambda_trial.h), with pass 2's workers and buffers, which are free
 * until it starts. */
static int trial_lambda(struct encoder *e)
{
    _Static_assert(GV_TRIAL_RECON <= GV_PAGE_SLOTS, "the trial borrows recon");
    _Static_assert(GV_TRIAL_MAX <= GV_PAGE_SLOTS, "the trial borrows bufs");
    const struct gv_lambda_trial_env env = {
        .g = &e->g,
        .c = e->c,
        .root_tile = e->root_tile,
        .params = {
            .target_mse = e->target_mse,
            .max_rate = e->opts->max_rate,
            .dct = e->opts->dct,
        },
        .pool = e->pool,
        .ws = e->ws,
        .origs = e->origs,
        .wrecon = e->wrecon,
        .recon = e->recon,
        .bufs = e->bufs,
        .read_orig = read_orig_tile,
        .ctx = e,
        .model = e->model,
        .model_levels = e->g.root,
        .dct = e->opts->dct != GV_LAYOUTS_VQ,
        .level_f = e->level_f,
    };
    struct gv_lambda_trial_result *r = &e->trial_res;
    if (gv_lambda_trial_search(&e->trial, &env, e->opts->target_psnr, e->lambda,
                               r, e->err) < 0)
        return -1;
    e->lambda = r->lambda;
    e->res->lambda_tries = r->tries;
    e->res->model_psnr = r->first_psnr;
    /* GIGAVIEW_TRIAL_REUSE=0 (tests): pass 2 codes the sample again,
     * which must give the same bytes. */
    if (env_off("GIGAVIEW_TRIAL_REUSE"))
        gv_lambda_trial_result_free(r);
    return 0;
}

/* Pool job: encode slot `slot` of the current page with the workspace of
 * `worker`; lens[slot] stays 0 for a slot outside the level or the shard,
 * and for one whose original cannot be read (job_failed, job_err). */
static void encode_tile(void *ctx, size_t slot, int worker)
{
    struct encoder *e = ctx;
    const struct gv_level *l = &e->g.level[e->level];
    const int c = e->c;
    const int i = (int)(slot % GV_PAGE_TILES), j = (int)(slot / GV_PAGE_TILES);
    const uint32_t tx = e->px * GV_PAGE_TILES + (uint32_t)i;
    const uint32_t ty = e->py * GV_PAGE_TILES + (uint32_t)j;
    e->lens[slot] = 0;
    if (tx >= l->tiles_x || ty >= l->tiles_y)
        return;
    if (e->sharded && !gv_shard_plan_wants(&e->plan, &e->g, e->level, tx, ty))
        return;
    uint8_t *orig = e->origs + (size_t)worker * gv_tile_bytes(c);
    /* Level 0's decoded tiles are only measured, so one buffer per worker
     * does: fewer fresh pages to fault in than one per slot. */
    uint8_t *recon = e->level == 0 ? e->wrecon + (size_t)worker * gv_tile_bytes(c)
                                   : e->recon[slot];
    const uint8_t *parent = e->parent_at[(j / 2) * 4 + i / 2];
    struct gv_error err = {0};
    const struct gv_trial_coded *tc =
        gv_lambda_trial_coded(&e->trial, &e->trial_res, e->level, tx, ty);
    if (tc) {
        /* Coded by the lambda trial at this lambda, from the same parent:
         * the same bytes; decoded where it is a parent. */
        memcpy(e->bufs[slot], tc->buf, tc->len);
        e->stats[slot] = tc->stats;
        e->canon_sse[slot] = tc->canon_sse;
        if (e->level > 0 &&
            gv_tile_decode(tc->buf, tc->len, c, parent, (int)(tx & 1), (int)(ty & 1),
                           recon, &err) < 0) {
            if (!atomic_exchange(&e->job_failed, 1))
                e->job_err = err;
            return;
        }
        e->lens[slot] = tc->len;
        if (e->tile_rate[e->level])
            e->tile_rate[e->level][(size_t)ty * l->tiles_x + tx] = (uint8_t)tc->stats.rate;
        return;
    }
    if (cut_tile(e, i, j, orig, &err) < 0) {
        /* The first failure is kept; encode_page reports it. */
        if (!atomic_exchange(&e->job_failed, 1))
            e->job_err = err;
        return;
    }
    const uint32_t valid_w = gv_tile_span(l->width, tx);
    const uint32_t valid_h = gv_tile_span(l->height, ty);
    struct gv_tile_params params = {
        .target_mse = e->target_mse,
        .max_rate = e->opts->max_rate,
        .seed = gv_encode_tile_seed(e->level, tx, ty),
        .lambda = e->opts->per_tile ? 0.0 : gv_level_lambda(e->lambda, e->level_f,
                                                            e->level),
        .dct = e->opts->dct,
    };
    e->lens[slot] = gv_tile_encode(e->ws[worker], orig, parent, (int)(tx & 1),
                                   (int)(ty & 1), c, valid_w, valid_h, &params,
                                   recon, e->bufs[slot], &e->stats[slot]);
    if (e->tile_rate[e->level])
        e->tile_rate[e->level][(size_t)ty * l->tiles_x + tx] = (uint8_t)e->stats[slot].rate;
    if (e->level == 0)
        e->canon_sse[slot] = gv_level0_tile_sse(l, tx, ty, c, orig, recon, NULL);
}

/* Pool job: the i-th slot of the page's order. */
static void encode_ordered(void *ctx, size_t i, int worker)
{
    struct encoder *e = ctx;
    encode_tile(ctx, e->order[i], worker);
}

/* Order the page's slots for the pool: by the rate of the parent tile,
 * highest first (a tile takes longer the higher the rates its search
 * codes, and a child's rate follows its parent's), slot order among
 * equals.  The workers claim slots in this order, so the slow tiles start
 * first and fewer wait at the end of the page.  Which worker codes which
 * tile never changes the bytes. */
static void order_page(struct encoder *e)
{
    const struct gv_level *l = &e->g.level[e->level];
    const uint8_t *up = e->level + 1 < GV_MAX_LEVELS ? e->tile_rate[e->level + 1] : NULL;
    const uint32_t upw = up ? e->g.level[e->level + 1].tiles_x : 0;
    uint8_t key[GV_PAGE_SLOTS];
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        uint32_t tx = e->px * GV_PAGE_TILES + (uint32_t)(s % GV_PAGE_TILES);
        uint32_t ty = e->py * GV_PAGE_TILES + (uint32_t)(s / GV_PAGE_TILES);
        key[s] = up && tx < l->tiles_x && ty < l->tiles_y ?
                 up[(size_t)(ty / 2) * upw + tx / 2] : 0;
    }
    int n = 0;
    for (int r = 255; r >= 0; r--)
        for (int s = 0; s < GV_PAGE_SLOTS; s++)
            if (key[s] == r)
                e->order[n++] = (uint8_t)s;
}

/* Give the whole pages of buf (len bytes of memory of our own) back to
 * the system; they read as zeros when touched again. */
static void release_pages(uint8_t *buf, size_t len)
{
    const long ps = sysconf(_SC_PAGESIZE);
    const uintptr_t page = ps > 0 ? (uintptr_t)ps : 4096;
    const uintptr_t a = (uintptr_t)buf, end = a + len;
    const uintptr_t first = (a + page - 1) & ~(page - 1);
    const uintptr_t last = end & ~(page - 1);
    if (last > first)
        madvise((void *)first, last - first, MADV_DONTNEED);
}

static int load_window(struct encoder *e)
{
    const struct gv_level *l = &e->g.level[e->level];
    const int c = e->c;
    const uint32_t x0 = e->px * PAGE_W, y0 = e->py * PAGE_W;
    e->win_w = gv_strip_width(l->width, e->px);
    e->win_h = l->height - y0 < WINDOW ? l->height - y0 : WINDOW;
    if (e->level == 0 && e->level0_resident) {
        const size_t rb = (size_t)l->width * c;
        e->win = e->window + (size_t)y0 * rb + (size_t)x0 * c;
        e->win_stride = rb;
        return 0;
    }
    if (e->level == 0 && e->level0_file) {
        /* Each tile is read from the file by its worker (read_orig_tile): no
         * window, and the copies' memory is given back. */
        gv_spill_unview(&e->view);
        if (e->window_resident)
            release_pages(e->copies, (size_t)WINDOW * WINDOW * c);
        e->window_resident = 0;
        e->win = NULL;
        e->win_stride = 0;
        return 0;
    }
    /* The window is rows y0 .. y0 + win_h - 1 of strip px, one span of
     * the file: mapped, it is read where it lies (and only its pages
     * count in the resident set); else it is copied, in one read. */
    const uint64_t at = strip_at(e, e->level, e->px, y0);
    e->win_stride = (size_t)e->win_w * c;
    const size_t span = (size_t)e->win_h * e->win_stride;
    gv_spill_unview(&e->view);
    if (!e->no_views &&
        gv_spill_view(level_spill(e, e->level), at, span, &e->view) == 0) {
        /* The copy's memory is given back while the mapping is used, so
         * that the two never count together. */
        if (e->window_resident)
            release_pages(e->copies, (size_t)WINDOW * WINDOW * c);
        e->window_resident = 0;
        e->win = e->view.data;
        return 0;
    }
    if (!e->copies && !(e->copies = malloc((size_t)WINDOW * WINDOW * c)))
        return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    e->win = e->copies;
    e->window_resident = 1;
    return gv_spill_read(level_spill(e, e->level), e->copies, span, at, e->err);
}

static int load_parents(struct encoder *e, const uint8_t *root_tile)
{
    const int pl = e->level + 1;
    if (pl == e->g.root) {
        for (int s = 0; s < 16; s++)
            e->parent_at[s] = root_tile;
        return 0;
    }
    const struct gv_level *l = &e->g.level[pl];
    const size_t tb = gv_tile_bytes(e->c);
    for (int s = 0; s < 16; s++) {
        uint32_t ptx = e->px * 4 + (uint32_t)(s % 4), pty = e->py * 4 + (uint32_t)(s / 4);
        e->parent_at[s] = e->parents[s];
        if (ptx >= l->tiles_x || pty >= l->tiles_y)
            continue;
        if (pl == 1 && e->level1_kept) {
            e->parent_at[s] = e->recon[pty * GV_PAGE_TILES + ptx];
            continue;
        }
        if (gv_spill_read(e->spill, e->parents[s], tb,
                          e->recon_base[pl] + ((uint64_t)pty * l->tiles_x + ptx) * tb,
                          e->err) < 0)
            return -1;
    }
    return 0;
}

static int store_recon(struct encoder *e)
{
    const struct gv_level *l = &e->g.level[e->level];
    const size_t tb = gv_tile_bytes(e->c);
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        uint32_t tx = e->px * GV_PAGE_TILES + (uint32_t)(s % GV_PAGE_TILES);
        uint32_t ty = e->py * GV_PAGE_TILES + (uint32_t)(s / GV_PAGE_TILES);
        if (tx >= l->tiles_x || ty >= l->tiles_y || !e->lens[s])
            continue;
        if (gv_spill_write(e->spill, e->recon[s], tb,
                           e->recon_base[e->level] +
                               ((uint64_t)ty * l->tiles_x + tx) * tb, e->err) < 0)
            return -1;
    }
    return 0;
}

/* Hand the encoded tiles of the current page to the store or the shard. */
static int emit_page(struct encoder *e)
{
    if (!e->sharded)
        return gv_store_writer_page(e->writer, e->level, e->px, e->py,
                                    (const uint8_t *const *)e->bufs, e->lens,
                                    e->err);
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        if (!e->lens[s])
            continue;
        uint32_t tx = e->px * GV_PAGE_TILES + (uint32_t)(s % GV_PAGE_TILES);
        uint32_t ty = e->py * GV_PAGE_TILES + (uint32_t)(s / GV_PAGE_TILES);
        if (gv_shard_writer_tile(e->shard, e->level, tx, ty, e->bufs[s], e->lens[s],
                                 &e->stats[s], e->level == 0 ? e->canon_sse[s] : 0,
                                 e->err) < 0)
            return -1;
    }
    return 0;
}

/* Add the current page's tiles to the summary, to the progress, and to
 * the level-0 squared error. */
static void account_page(struct encoder *e, uint64_t *sse0)
{
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        if (!e->lens[s])
            continue;
        e->res->tiles++;
        e->res->rate_tiles[e->stats[s].rate]++;
        e->res->level_bytes[e->level] += e->lens[s];
        double mse = (double)e->stats[s].sse / (double)e->stats[s].samples;
        if (e->opts->per_tile && mse > e->target_mse)
            e->res->below_target++;
        e->work_done += (double)e->stats[s].samples;
        if (e->level == 0)
            *sse0 += e->canon_sse[s];
    }
}

/* Encode page (px, py) of level e->level: read its window and parents,
 * encode its tiles on the pool, hand them on, and keep the decoded tiles
 * that the level below is predicted from. */
static int encode_page(struct encoder *e, uint32_t px, uint32_t py,
                       uint64_t *sse0)
{
    e->px = px;
    e->py = py;
    if (load_window(e) < 0 || load_parents(e, e->root_tile) < 0)
        return -1;
    order_page(e);
    gv_pool_run(e->pool, encode_ordered, e, GV_PAGE_SLOTS);
    if (atomic_load(&e->job_failed)) {
        *e->err = e->job_err;
        return -1;
    }
    if (emit_page(e) < 0)
        return -1;
    if (e->level > 0 && !(e->level == 1 && e->level1_kept) &&
        store_recon(e) < 0)
        return -1;
    account_page(e, sse0);
    report(e, "encode", PASS1_SHARE + (1.0 - PASS1_SHARE) *
                            e->work_done / e->work_total);
    return 0;
}

/* Pass 2: every level from the root down, page by page (a shard skips the
 * pages it has no tile in).  Fills the level-0 squared error and sample
 * count for the header's PSNR. */
static int pass2(struct encoder *e, uint64_t *sse0, uint64_t *samples0)
{
    for (int k = e->g.root - 1; k >= 0; k--) {
        const struct gv_level *l = &e->g.level[k];
        e->level = k;
        if (k == 1)
            e->level1_kept = !e->sharded && l->pages_x == 1 && l->pages_y == 1;
        for (uint32_t py = 0; py < l->pages_y; py++)
            for (uint32_t px = 0; px < l->pages_x; px++) {
                if (e->sharded && !gv_shard_plan_wants_page(&e->plan, &e->g, k, px, py))
                    continue;
                if (encode_page(e, px, py, sse0) < 0)
                    return -1;
            }
    }
    if (e->g.root == 0) {
        *sse0 = 0;  /* the root is level 0, stored losslessly */
    }
    *samples0 = (uint64_t)e->g.width * e->g.height * e->c;
    return 0;
}

/* ------------------------------------------------------------ driver */

/* Lay out the scratch file (see the top of this file) and the work that
 * progress counts; a shard sizes the file once so that what it never
 * writes stays a hole. */
static int layout_scratch(struct encoder *e)
{
    const struct gv_geometry *g = &e->g;
    const int c = e->c;
    /* Level 0 alone in spill0, the rest in spill; a level of n strips
     * holds n - 1 columns twice (the windows' overlap). */
    uint64_t bytes[GV_MAX_LEVELS] = {0};
    for (int k = 0; k <= g->root; k++)
        bytes[k] = gv_strips_bytes(&g->level[k], (size_t)c);
    uint64_t off = 0;
    e->orig_base[0] = 0;
    for (int k = 1; k <= g->root; k++) {
        e->orig_base[k] = off;
        off += bytes[k];
    }
    e->work_total = 0;
    for (int k = 1; k < g->root; k++) {
        e->recon_base[k] = off;
        off += (uint64_t)g->level[k].tiles_x * g->level[k].tiles_y * gv_tile_bytes(c);
    }
    for (int k = 0; k < g->root; k++)
        e->work_total += (double)g->level[k].width * g->level[k].height * c;
    if (e->sharded) {
        e->work_total = (double)e->plan.samples;
        const uint64_t size0 = e->level0_file ? 0 : bytes[0];
        /* Size the scratch file once: what the shard never writes stays a
         * hole, so reading a whole page window cannot run past the end. */
        static const uint8_t zero = 0;
        if ((off > 0 && gv_spill_write(e->spill, &zero, 1, off - 1, e->err) < 0) ||
            (size0 > 0 && gv_spill_write(e->spill0, &zero, 1, size0 - 1, e->err) < 0))
            return -1;
    }
    if (e->work_total <= 0)
        e->work_total = 1;
    return 0;
}

/* Whether environment variable `name` is "0" (the tests' switches). */
static int env_off(const char *name)
{
    const char *v = getenv(name);
    return v && !strcmp(v, "0");
}

/* Where level 0 lives between the passes: in the page window where it
 * fits (level0_resident), else in the input file where pass 2 can read it
 * from there (level0_file), else in the scratch file.  For tests,
 * GIGAVIEW_LEVEL0_RESIDENT=0 rules out the first, and
 * GIGAVIEW_RAW_REGIONS=0 the second (imageio.h).  Before layout_scratch
 * and start_workers. */
static int choose_level0(struct encoder *e, struct gv_source *src)
{
    e->level0_resident = !e->sharded && e->g.root > 0 &&
                         (uint64_t)e->g.width * e->g.height <=
                             (uint64_t)WINDOW * WINDOW &&
                         !env_off("GIGAVIEW_LEVEL0_RESIDENT");
    if (e->level0_resident || e->g.root == 0)
        return 0;
    e->level0_file = gv_source_raw_regions(src, e->err);
    return e->level0_file || e->err->code == GV_OK ? 0 : -1;
}

/* The thread pool, and the buffers of pass 2: one tile workspace and one
 * original tile per worker, the page window, 16 parents, and 64 decoded
 * tiles and tile buffers. */
static int start_workers(struct encoder *e)
{
    const int c = e->c;
    int threads = e->opts->threads > 0 ? e->opts->threads : gv_cpu_count();
    e->pool = gv_pool_new(threads);
    if (!e->pool)
        return gv_fail(e->err, GV_ENOMEM, "encode: cannot start %d threads", threads);
    int n = gv_pool_size(e->pool);
    e->ws = calloc((size_t)n, sizeof *e->ws);
    e->nws = e->ws ? n : 0;
    e->origs = malloc((size_t)n * gv_tile_bytes(c));
    e->wrecon = malloc((size_t)n * gv_tile_bytes(c));
    e->window = malloc((size_t)WINDOW * WINDOW * c);
    e->no_views = env_off("GIGAVIEW_SPILL_VIEWS");   /* tests */
    e->copies = e->level0_resident ? NULL : e->window;
    if (!e->ws || !e->origs || !e->wrecon || !e->window)
        return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    for (int i = 0; i < n; i++)
        if (!(e->ws[i] = gv_tile_workspace_new()))
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    for (int k = 1; k < e->g.root; k++)
        if (!(e->tile_rate[k] = calloc((size_t)e->g.level[k].tiles_x *
                                       e->g.level[k].tiles_y, 1)))
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    /* Layout D may use up to GV_TILEBUF_MAX at any rate cap. */
    size_t maxbuf = e->opts->dct == GV_LAYOUTS_VQ ?
                    gv_tilebuf_size(e->opts->max_rate, c) : GV_TILEBUF_MAX;
    for (int s = 0; s < 16; s++)
        if (!(e->parents[s] = malloc(gv_tile_bytes(c))))
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        if (!(e->recon[s] = malloc(gv_tile_bytes(c))) ||
            !(e->bufs[s] = malloc(maxbuf)))
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory");
    return 0;
}

/* The root's lossless WebP (gv_root_pack) takes about as long as a level
 * of a small image's pages (39 ms of a 0.66 s encode of an 8 MP photo,
 * after everything else), and depends only on the root's pixels: it is
 * packed on a thread of its own while pass 2 encodes the pages, and
 * finish_store writes the bytes. */
static void *root_packer_main(void *arg)
{
    struct encoder *e = arg;   /* e->root and e->g: not changed in pass 2 */
    struct root_packer *p = &e->packer;
    const struct gv_level *rl = &e->g.level[e->g.root];
    p->rc = gv_root_pack(e->root, rl->width, rl->height, e->c, &p->z,
                         &p->zlen, &p->err);
    return NULL;
}

/* Start packing e->root; without a thread it is packed at once. */
static void root_packer_start(struct encoder *e)
{
    if (pthread_create(&e->packer.thread, NULL, root_packer_main, e) == 0)
        e->packer.started = 1;
    else
        root_packer_main(e);
}

/* Wait for the packing (if started); the packed root stays in p->z. */
static void root_packer_join(struct root_packer *p)
{
    if (p->started) {
        pthread_join(p->thread, NULL);
        p->started = 0;
    }
}

static void teardown(struct encoder *e)
{
    free(e->meta);
    root_packer_join(&e->packer);
    free(e->packer.z);
    gv_lambda_trial_result_free(&e->trial_res);
    gv_pool_free(e->pool);
    gv_shard_plan_free(&e->plan);
    for (int i = 0; i < e->nws; i++)
        gv_tile_workspace_free(e->ws[i]);
    free(e->ws);
    free(e->origs);
    free(e->wrecon);
    gv_spill_unview(&e->view);
    if (e->copies != e->window)
        free(e->copies);
    free(e->window);
    for (int s = 0; s < 16; s++)
        free(e->parents[s]);
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        free(e->recon[s]);
        free(e->bufs[s]);
    }
    for (int k = 0; k < GV_MAX_LEVELS; k++) {
        free(e->pending[k]);
        free(e->reduced[k]);
        free(e->tile_rate[k]);
    }
    free(e->root);
    free(e->root_tile);
    for (int k = 0; k < GV_MAX_LEVELS; k++)
        gv_lambda_model_free(&e->model[k]);
    gv_spill_free(e->spill);
    gv_spill_free(e->spill0);
    gv_raw_regions_free(e->level0_file);
}

static int check_opts(const struct gv_encode_opts *opts, struct gv_error *err)
{
    if (opts->target_psnr <= 0 || opts->target_psnr > 99)
        return gv_fail(err, GV_EINVAL, "encode: target PSNR %.2f dB is outside "
                       "(0, 99]", opts->target_psnr);
    if (opts->max_rate < 1 || opts->max_rate > GV_MAX_RATE)
        return gv_fail(err, GV_EINVAL, "encode: rate cap %d is outside 1..%d",
                       opts->max_rate, GV_MAX_RATE);
    return 0;
}

/* The VQ-only stores (the per-tile mode, --layouts vq) are version 2
 * with a 512-pixel root, for every reader; the default writes version 6,
 * a root within GV_ROOT_SIDE and tiles in any layout. */
static int vq_only(const struct gv_encode_opts *opts)
{
    return opts->per_tile || opts->dct == GV_LAYOUTS_VQ;
}

static uint16_t root_side_of(const struct gv_encode_opts *opts)
{
    return vq_only(opts) ? GV_ROOT_MAX : GV_ROOT_SIDE;
}

/* The store header before any page: geometry, source and settings. */
static void make_header(const struct encoder *e, struct gv_header *h)
{
    const struct gv_source_info *src = &e->res->source;
    memset(h, 0, sizeof *h);
    h->width = e->g.width;
    h->height = e->g.height;
    h->channels = (uint8_t)e->c;
    h->max_rate = (uint8_t)e->opts->max_rate;
    h->src_bits = (uint8_t)src->src_bits;
    h->src_float = (uint8_t)src->src_float;
    h->tone = (uint8_t)src->tone;
    h->target_mpsnr = (uint32_t)lround(e->opts->target_psnr * 1000.0);
    h->root_side = root_side_of(e->opts);
    h->version = gv_image_version(vq_only(e->opts) ? GV_VERSION : GV_VERSION_DCT,
                                  h->root_side);
}

/* The geometry of the opened source, and the output: a shard file (with
 * the shard's plan) or a store. */
/* The lambda trial's sample (whose originals a shard keeps too), and the
 * rate model's histograms per tile, which it estimates the whole level
 * by. */
static int plan_trial(struct encoder *e)
{
    gv_lambda_trial_plan(&e->g, &e->trial);
    for (int k = 0; k < e->g.root; k++)
        if (gv_lambda_model_set_tiles(&e->model[k], e->g.level[k].tiles_x,
                                      e->g.level[k].tiles_y) < 0)
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory for the rate model");
    return 0;
}

static int open_output(struct encoder *e, const char *output)
{
    const struct gv_encode_opts *opts = e->opts;
    struct gv_encode_result *res = e->res;
    e->c = res->source.channels;
    if (gv_geometry_init(&e->g, res->source.width, res->source.height, e->c,
                         root_side_of(opts)) < 0)
        return gv_fail(e->err, GV_EINVAL, "encode: unsupported size %ux%u",
                       res->source.width, res->source.height);
    res->geometry = e->g;
    struct gv_header h;
    make_header(e, &h);
    for (int k = 0; k < e->g.root && !opts->per_tile; k++)
        if (gv_lambda_model_init(&e->model[k], e->g.level[k].width, e->c) < 0)
            return gv_fail(e->err, GV_ENOMEM, "encode: out of memory for the rate model");
    if (!opts->per_tile && plan_trial(e) < 0)
        return -1;
    if (opts->shard_count <= 0) {
        e->writer = gv_store_writer_new(output, &h, e->err);
        return e->writer ? 0 : -1;
    }
    if (gv_shard_plan_init(&e->plan, &e->g, opts->shard_index,
                           opts->shard_count, e->err) < 0)
        return -1;
    e->sharded = 1;
    e->shard = gv_shard_writer_new(output, &h, e->meta, e->meta_len,
                                   opts->shard_index,
                                   opts->shard_count,
                                   opts->per_tile ? 0 : GV_SHARD_FLAG_RD, e->err);
    return e->shard ? 0 : -1;
}

/* The scratch file, in --tmpdir or else in the output's directory. */
static int open_spill(struct encoder *e, const char *output)
{
    e->spill = gv_strips_spill_new(e->opts->tmpdir, output, e->err);
    e->spill0 = e->spill ? gv_strips_spill_new(e->opts->tmpdir, output, e->err)
                         : NULL;
    return e->spill0 ? 0 : -1;
}

/* After pass 1: read the root level back from the scratch file and build
 * its tile, the parent of level R-1; a shard records the root now. */
static int load_root(struct encoder *e)
{
    const struct gv_level *rl = &e->g.level[e->g.root];
    size_t rbytes = (size_t)rl->width * rl->height * e->c;
    e->root = malloc(rbytes);
    e->root_tile = malloc(gv_tile_bytes(e->c));
    if (!e->root || !e->root_tile)
        return gv_fail(e->err, GV_ENOMEM, "encode: out of memory for the root");
    if (gv_spill_read(level_spill(e, e->g.root), e->root, rbytes,
                      e->orig_base[e->g.root], e->err) < 0)
        return -1;
    if (e->g.root > 0 &&
        gv_root_approx(e->root, rl->width, rl->height, e->c,
                       gv_root_near_lossless(e->opts->target_psnr), e->err) < 0)
        return -1;
    gv_root_tile(e->root, rl->width, rl->height, e->c, e->root_tile);
    if (e->sharded)
        return gv_shard_writer_root(e->shard, e->root, e->err);
    root_packer_start(e);
    return 0;
}

/* Publish the shard file; its size is the result's file_bytes. */
static int finish_shard(struct encoder *e)
{
    struct gv_shard_writer *sw = e->shard;
    e->shard = NULL;
    e->res->file_bytes = gv_shard_writer_bytes(sw);
    if (gv_shard_writer_finish(sw, e->err) < 0)
        return -1;
    e->res->bpp = gv_encode_bpp(e->res);
    return 0;
}

/* Append the root, then publish and verify the store. */
static int finish_store(struct encoder *e, const char *output, uint64_t sse0,
                        uint64_t samples0)
{
    struct root_packer *p = &e->packer;
    root_packer_join(p);
    if (p->rc < 0) {
        *e->err = p->err;
        return -1;
    }
    if (gv_store_writer_root_packed(e->writer, p->z, p->zlen, e->err) < 0 ||
        (e->meta &&
         gv_store_writer_meta(e->writer, e->meta, e->meta_len, e->err) < 0))
        return -1;
    e->res->psnr0 = gv_encode_psnr0(sse0, samples0);
    struct gv_store_writer *w = e->writer;
    e->writer = NULL;
    return gv_encode_publish_store(w, output, e->res, e->err);
}

int gv_encode(const char *const *inputs, int n, const char *output,
              const struct gv_encode_opts *opts, struct gv_encode_result *res,
              struct gv_error *err)
{
    struct encoder e;
    memset(&e, 0, sizeof e);
    memset(res, 0, sizeof *res);
    e.opts = opts;
    e.res = res;
    e.err = err;
    double t0 = gv_encode_now();
    int rc = -1;
    if (check_opts(opts, err) < 0)
        return -1;
    e.target_mse = gv_psnr_to_mse(opts->target_psnr);
    struct gv_source *src = gv_source_open(inputs, n, &opts->source,
                                           &res->source, err);
    if (!src)
        return -1;
    /* What the input says of its pixels (a slide's microns per pixel, a
     * raster's georeference), kept in the store. */
    const char *meta = gv_source_meta(src);
    char *merged = NULL;
    if (opts->window) {   /* and the default display window, if given */
        struct gv_window w;
        if (gv_window_parse(opts->window, 255, &w, err) < 0)
            goto out;
        if (w.count != 1 && w.count != res->source.channels) {
            gv_fail(err, GV_EINVAL, "window: %d windows for an image of %d "
                    "channels (give one, or one per channel)", w.count,
                    res->source.channels);
            goto out;
        }
        if (!(meta = merged = gv_window_meta_set(meta, &w, err)))
            goto out;
    }
    int mrc = meta ? gv_meta_pack(meta, strlen(meta), &e.meta, &e.meta_len, err) : 0;
    free(merged);
    if (mrc < 0)
        goto out;
    if (open_output(&e, output) < 0 || open_spill(&e, output) < 0 ||
        choose_level0(&e, src) < 0 || layout_scratch(&e) < 0 || start_workers(&e) < 0 || pass1(&e, src) < 0)
        goto out;
    gv_source_free(src);
    src = NULL;
    uint64_t sse0 = 0, samples0 = 1;
    if (load_root(&e) < 0)
        goto out;
    for (int k = 0; k < e.g.root; k++)
        gv_lambda_model_finish(&e.model[k]);
    e.lambda = gv_lambda_model_lambda(e.model, e.g.root, e.target_mse,
                                      opts->dct != GV_LAYOUTS_VQ);
    e.level_f = gv_lambda_model_level_factor(e.model, e.g.root, e.target_mse);
    if (!opts->per_tile && trial_lambda(&e) < 0)
        goto out;
    res->per_tile = opts->per_tile;
    res->lambda = opts->per_tile ? 0.0 : e.lambda;
    if (pass2(&e, &sse0, &samples0) < 0)
        goto out;
    gv_lambda_trial_result_free(&e.trial_res);
    /* Level 0 was read twice from the input: it must not have changed. */
    if (e.level0_file && gv_raw_regions_unchanged(e.level0_file, err) < 0)
        goto out;
    res->scratch_bytes = gv_spill_bytes(e.spill) + gv_spill_bytes(e.spill0);
    res->level0_from_input = e.level0_file != NULL;
    if ((e.sharded ? finish_shard(&e)
                   : finish_store(&e, output, sse0, samples0)) < 0)
        goto out;
    report(&e, "done", 1.0);
    rc = 0;
out:
    res->seconds = gv_encode_now() - t0;
    gv_source_free(src);
    gv_store_writer_abort(e.writer);
    gv_shard_writer_abort(e.shard);
    teardown(&e);
    return rc;
}

/* ------------------------------------------ shared with shard_merge.c */

double gv_encode_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

double gv_encode_psnr0(uint64_t sse0, uint64_t samples0)
{
    double p = sse0 == 0 ? 99.0 :
               10.0 * log10(65025.0 * (double)samples0 / (double)sse0);
    return p > 99.0 ? 99.0 : p;
}

double gv_encode_bpp(const struct gv_encode_result *res)
{
    return 8.0 * (double)res->file_bytes /
           ((double)res->geometry.width * res->geometry.height);
}

int gv_encode_publish_store(struct gv_store_writer *w, const char *output,
                            struct gv_encode_result *res,
                            struct gv_error *err)
{
    gv_store_writer_set_psnr(w, (uint32_t)lround(res->psnr0 * 1000.0));
    if (gv_store_writer_finish(w, err) < 0)
        return -1;
    /* Read back what was published: the header and index must verify. */
    struct gv_store *check = gv_store_open(output, err);
    if (!check)
        return -1;
    res->file_bytes = gv_store_info(check)->header.file_size;
    gv_store_close(check);
    res->bpp = gv_encode_bpp(res);
    return 0;
}
