/*
 * shard_merge.c - assembling a store from shard files (see shard_merge.h).
 *
 * Two passes over the shards: the first reads only record headers and
 * builds, per level, a table from tile to (shard, offset, length, CRC);
 * the second walks the pages in store order and copies each tile buffer
 * into the store writer.  Statistics for the summary and the level-0 PSNR
 * are summed from the records (each tile counted once), in integers, so
 * the header's PSNR is the one the single encode computes.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec/tile.h"
#include "store/geometry.h"
#include "encode/encode_int.h"
#include "encode/shard_file.h"
#include "encode/shard_merge.h"
#include "store/store_read.h"
#include "store/store_write.h"

struct slot {
    uint64_t offset;
    uint32_t len, crc;
    uint16_t shard;
    uint8_t have;
};

struct merge {
    const char *const *paths;
    int n;
    struct gv_shard_reader **r;  /* by shard index */
    const struct gv_shard_info *info;
    struct gv_geometry g;
    struct slot *tab[GV_MAX_LEVELS];
    uint8_t *cmp;                /* GV_TILEBUF_MAX, for duplicates */
    uint8_t *bufs[GV_PAGE_SLOTS];
    uint64_t sse0;
    struct gv_encode_result *res;
    struct gv_error *err;
};

/* Open every shard and check that they belong together. */
static int open_shards(struct merge *m)
{
    struct gv_shard_reader **byfile = calloc((size_t)m->n, sizeof *byfile);
    int rc = -1;
    if (!byfile)
        return gv_fail(m->err, GV_ENOMEM, "merge: out of memory");
    for (int i = 0; i < m->n; i++)
        if (!(byfile[i] = gv_shard_open(m->paths[i], m->err)))
            goto out;
    const struct gv_shard_info *first = gv_shard_get_info(byfile[0]);
    if (first->count != m->n) {
        gv_fail(m->err, GV_EINVAL, "merge: %s is shard %d of %d, but %d shard "
                "files were given", m->paths[0], first->index, first->count, m->n);
        goto out;
    }
    m->r = calloc((size_t)m->n, sizeof *m->r);
    if (!m->r) {
        gv_fail(m->err, GV_ENOMEM, "merge: out of memory");
        goto out;
    }
    size_t rootlen;
    const uint8_t *root = gv_shard_root(byfile[0], &rootlen);
    for (int i = 0; i < m->n; i++) {
        const struct gv_shard_info *in = gv_shard_get_info(byfile[i]);
        if (in->count != first->count || in->flags != first->flags ||
            memcmp(in->header_raw, first->header_raw, GV_HEADER_SIZE) != 0) {
            gv_fail(m->err, GV_EINVAL, "merge: %s and %s come from different "
                    "images, options or shard counts", m->paths[0], m->paths[i]);
            goto out;
        }
        size_t len;
        const uint8_t *other = gv_shard_root(byfile[i], &len);
        if (len != rootlen || memcmp(other, root, len) != 0) {
            gv_fail(m->err, GV_EINVAL, "merge: %s and %s come from different "
                    "images (their roots differ)", m->paths[0], m->paths[i]);
            goto out;
        }
        if (m->r[in->index]) {
            gv_fail(m->err, GV_EINVAL, "merge: shard %d/%d is given twice (%s)",
                    in->index, in->count, m->paths[i]);
            goto out;
        }
        m->r[in->index] = byfile[i];
        byfile[i] = NULL;
    }
    m->info = gv_shard_get_info(m->r[0]);
    rc = 0;
out:
    for (int i = 0; i < m->n; i++)
        gv_shard_close(byfile[i]);
    free(byfile);
    return rc;
}

/* Record the tiles of shard s in the tables; compare duplicates. */
static int scan_shard(struct merge *m, int s)
{
    struct gv_shard_record rec;
    int got;
    const double target_mse =
        gv_psnr_to_mse(m->info->header.target_mpsnr / 1000.0);
    while ((got = gv_shard_next(m->r[s], &rec, m->err)) == 1) {
        const struct gv_level *l = &m->g.level[rec.level];
        struct slot *t = &m->tab[rec.level][(uint64_t)rec.ty * l->tiles_x + rec.tx];
        if (t->have) {
            /* An ancestor on a cut: both shards must have coded it alike. */
            struct gv_shard_record prev = {.level = rec.level, .tx = rec.tx,
                                           .ty = rec.ty, .len = t->len,
                                           .crc = t->crc, .offset = t->offset};
            if (t->len != rec.len ||
                gv_shard_read_tile(m->r[t->shard], &prev, m->cmp, m->err) < 0 ||
                gv_shard_read_tile(m->r[s], &rec, m->bufs[0], m->err) < 0 ||
                memcmp(m->cmp, m->bufs[0], rec.len) != 0)
                return gv_fail(m->err, GV_EINVAL, "merge: shards %d and %d differ "
                               "on tile %d/%u/%u: not encoded from the same input "
                               "with the same options and program version",
                               t->shard, s, rec.level, rec.tx, rec.ty);
            continue;
        }
        t->have = 1;
        t->shard = (uint16_t)s;
        t->offset = rec.offset;
        t->len = rec.len;
        t->crc = rec.crc;
        struct gv_encode_result *res = m->res;
        res->tiles++;
        res->rate_tiles[rec.rate]++;
        res->level_bytes[rec.level] += rec.len;
        if (!(m->info->flags & GV_SHARD_FLAG_RD) && rec.samples &&
            (double)rec.sse / (double)rec.samples > target_mse)
            res->below_target++;
        if (rec.level == 0)
            m->sse0 += rec.sse0;
    }
    return got;
}

/* Write every page, in store order, then the root. */
static int write_store(struct merge *m, struct gv_store_writer *w)
{
    size_t lens[GV_PAGE_SLOTS];
    for (int k = m->g.root - 1; k >= 0; k--) {
        const struct gv_level *l = &m->g.level[k];
        for (uint32_t py = 0; py < l->pages_y; py++)
            for (uint32_t px = 0; px < l->pages_x; px++) {
                for (int s = 0; s < GV_PAGE_SLOTS; s++) {
                    uint32_t tx = px * GV_PAGE_TILES + (uint32_t)(s % GV_PAGE_TILES);
                    uint32_t ty = py * GV_PAGE_TILES + (uint32_t)(s / GV_PAGE_TILES);
                    lens[s] = 0;
                    if (tx >= l->tiles_x || ty >= l->tiles_y)
                        continue;
                    const struct slot *t = &m->tab[k][(uint64_t)ty * l->tiles_x + tx];
                    struct gv_shard_record rec = {.level = k, .tx = tx, .ty = ty,
                                                  .len = t->len, .crc = t->crc,
                                                  .offset = t->offset};
                    if (gv_shard_read_tile(m->r[t->shard], &rec, m->bufs[s], m->err) < 0)
                        return -1;
                    lens[s] = t->len;
                }
                if (gv_store_writer_page(w, k, px, py, (const uint8_t *const *)m->bufs,
                                         lens, m->err) < 0)
                    return -1;
            }
    }
    size_t rootlen, metalen;
    if (gv_store_writer_root(w, gv_shard_root(m->r[0], &rootlen), m->err) < 0)
        return -1;
    /* After the root, as a single encode writes it (stream_encoder.c). */
    const uint8_t *meta = gv_shard_meta(m->r[0], &metalen);
    return meta ? gv_store_writer_meta(w, meta, metalen, m->err) : 0;
}

/* Buffers for copying tiles, and one slot per tile of every level. */
static int alloc_tables(struct merge *m)
{
    m->cmp = malloc(GV_TILEBUF_MAX);
    if (!m->cmp)
        return gv_fail(m->err, GV_ENOMEM, "merge: out of memory");
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        if (!(m->bufs[s] = malloc(GV_TILEBUF_MAX)))
            return gv_fail(m->err, GV_ENOMEM, "merge: out of memory");
    for (int k = 0; k < m->g.root; k++) {
        const struct gv_level *l = &m->g.level[k];
        m->tab[k] = calloc((size_t)l->tiles_x * l->tiles_y, sizeof *m->tab[k]);
        if (!m->tab[k])
            return gv_fail(m->err, GV_ENOMEM, "merge: out of memory for the "
                           "tile table");
    }
    return 0;
}

/* Every tile of the pyramid must be in some shard. */
static int check_complete(struct merge *m)
{
    for (int k = 0; k < m->g.root; k++) {
        const struct gv_level *l = &m->g.level[k];
        for (uint32_t ty = 0; ty < l->tiles_y; ty++)
            for (uint32_t tx = 0; tx < l->tiles_x; tx++)
                if (!m->tab[k][(uint64_t)ty * l->tiles_x + tx].have)
                    return gv_fail(m->err, GV_EINVAL, "merge: tile %d/%u/%u is "
                                   "in none of the shards", k, tx, ty);
    }
    return 0;
}

/* The geometry and the source description, from the shards' header. */
static int describe_source(struct merge *m)
{
    const struct gv_header *h = &m->info->header;
    struct gv_encode_result *res = m->res;
    if (gv_geometry_init(&m->g, h->width, h->height, h->channels,
                         h->root_side) < 0)
        return gv_fail(m->err, GV_ECORRUPT, "merge: bad dimensions %ux%u",
                       h->width, h->height);
    res->geometry = m->g;
    res->source.width = h->width;
    res->source.height = h->height;
    res->source.channels = h->channels;
    res->source.src_bits = h->src_bits;
    res->source.src_float = h->src_float;
    res->source.tone = (enum gv_tone_rule)h->tone;
    res->per_tile = !(m->info->flags & GV_SHARD_FLAG_RD);
    return 0;
}

static void merge_free(struct merge *m)
{
    for (int k = 0; k < GV_MAX_LEVELS; k++)
        free(m->tab[k]);
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        free(m->bufs[s]);
    free(m->cmp);
    if (m->r)
        for (int i = 0; i < m->n; i++)
            gv_shard_close(m->r[i]);
    free(m->r);
}

int gv_shard_merge(const char *const *paths, int n, const char *output,
                   struct gv_encode_result *res, struct gv_error *err)
{
    struct merge m;
    memset(&m, 0, sizeof m);
    memset(res, 0, sizeof *res);
    m.paths = paths;
    m.n = n;
    m.res = res;
    m.err = err;
    double t0 = gv_encode_now();
    int rc = -1;
    struct gv_store_writer *w = NULL;
    if (n < 1)
        return gv_fail(err, GV_EINVAL, "merge: no shard files");
    if (open_shards(&m) < 0 || describe_source(&m) < 0 || alloc_tables(&m) < 0)
        goto out;
    for (int s = 0; s < n; s++)
        if (scan_shard(&m, s) < 0)
            goto out;
    if (check_complete(&m) < 0)
        goto out;
    w = gv_store_writer_new(output, &m.info->header, err);
    if (!w || write_store(&m, w) < 0)
        goto out;
    res->psnr0 = gv_encode_psnr0(m.g.root == 0 ? 0 : m.sse0,
                                 (uint64_t)m.g.width * m.g.height * m.g.channels);
    struct gv_store_writer *done = w;
    w = NULL;
    if (gv_encode_publish_store(done, output, res, err) < 0)
        goto out;
    rc = 0;
out:
    res->seconds = gv_encode_now() - t0;
    gv_store_writer_abort(w);
    merge_free(&m);
    return rc;
}
