/*
 * shard_file.c - writing and reading shard files (see shard_file.h).
 *
 * The writer appends records as the encoder produces them and writes the
 * shard header last, so a reader can trust the record count and the file
 * size it finds there; the root section has a fixed size (the geometry
 * gives it) and is written in place when the pyramid is done.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/atomic_file.h"
#include "base/file_io.h"
#include "store/geometry.h"
#include "store/store_meta.h"
#include "encode/shard_file.h"
#include "encode/shard_plan.h"

#define SHARD_VERSION 1
#define TEMPLATE_AT GV_SHARD_HEADER
#define ROOT_AT (GV_SHARD_HEADER + GV_HEADER_SIZE)
#define RECORD_MAGIC "GVTR"

static uint64_t root_bytes(const struct gv_geometry *g)
{
    const struct gv_level *r = &g->level[g->root];
    return (uint64_t)r->width * r->height * (unsigned)g->channels;
}

/* ------------------------------------------------- header and records */

/* The fields of the 64-byte shard header (docs/FORMAT.md, appendix A)
 * besides magic, version, size and CRC. */
struct shard_head {
    uint32_t index, count, flags;
    uint64_t records, file_size;
    uint64_t first;           /* offset of the first record */
};

/* Same shape as gv_header_pack in store/store_format.c and record_pack below:
 * deliberately separate, each writes its own on-disk layout (docs/FORMAT.md).
 */
static void head_pack(const struct shard_head *s, uint8_t h[GV_SHARD_HEADER])
{
    memset(h, 0, GV_SHARD_HEADER);
    memcpy(h, GV_SHARD_MAGIC, 8);
    gv_put16(h + 8, SHARD_VERSION);
    gv_put16(h + 10, GV_SHARD_HEADER);
    gv_put32(h + 12, s->index);
    gv_put32(h + 16, s->count);
    gv_put32(h + 20, s->flags);
    gv_put64(h + 24, s->records);
    gv_put64(h + 32, s->file_size);
    gv_put64(h + 40, s->first);
    gv_put32(h + 60, gv_crc32(0, h, 60));
}

/* The fields only: magic, CRC and version are checked by the caller. */
/* Same shape as gv_header_unpack in store/store_format.c and record_unpack
 * below: deliberately separate, each reads its own on-disk layout. */
static void head_unpack(const uint8_t h[GV_SHARD_HEADER], struct shard_head *s)
{
    s->index = gv_get32(h + 12);
    s->count = gv_get32(h + 16);
    s->flags = gv_get32(h + 20);
    s->records = gv_get64(h + 24);
    s->file_size = gv_get64(h + 32);
    s->first = gv_get64(h + 40);
}

/* The 64-byte header of a tile record (rec->offset is not stored). */
/* Same shape as head_pack above and gv_header_pack in store/store_format.c:
 * deliberately separate, a record is its own layout. */
static void record_pack(const struct gv_shard_record *rec,
                        uint8_t h[GV_SHARD_RECORD])
{
    memset(h, 0, GV_SHARD_RECORD);
    memcpy(h, RECORD_MAGIC, 4);
    h[4] = (uint8_t)rec->level;
    h[5] = (uint8_t)rec->rate;
    gv_put32(h + 8, rec->tx);
    gv_put32(h + 12, rec->ty);
    gv_put32(h + 16, rec->len);
    gv_put32(h + 20, rec->crc);
    gv_put64(h + 24, rec->sse);
    gv_put64(h + 32, rec->samples);
    gv_put64(h + 40, rec->sse0);
    gv_put32(h + 60, gv_crc32(0, h, 60));
}

/* The fields only, offset 0: magic and CRC are checked by the caller. */
/* Same shape as head_unpack above and gv_header_unpack in store/store_format.c:
 * deliberately separate, a record is its own layout. */
static void record_unpack(const uint8_t h[GV_SHARD_RECORD],
                          struct gv_shard_record *rec)
{
    memset(rec, 0, sizeof *rec);
    rec->level = h[4];
    rec->rate = h[5];
    rec->tx = gv_get32(h + 8);
    rec->ty = gv_get32(h + 12);
    rec->len = gv_get32(h + 16);
    rec->crc = gv_get32(h + 20);
    rec->sse = gv_get64(h + 24);
    rec->samples = gv_get64(h + 32);
    rec->sse0 = gv_get64(h + 40);
}

/* ------------------------------------------------------------ writer */

struct gv_shard_writer {
    struct gv_atomic_file f;
    struct gv_geometry g;
    int index, count;
    uint32_t flags;
    uint64_t off, records;
    uint64_t first;           /* the first record: after root and metadata */
    int have_root;
};

struct gv_shard_writer *gv_shard_writer_new(const char *path,
                                            const struct gv_header *h,
                                            const uint8_t *meta,
                                            size_t meta_len, int index,
                                            int count, uint32_t flags,
                                            struct gv_error *err)
{
    if (meta_len > GV_META_MAX_SECTION) {
        gv_fail(err, GV_EINVAL, "shard: metadata section of %zu bytes",
                meta_len);
        return NULL;
    }
    struct gv_shard_writer *w = calloc(1, sizeof *w);
    if (!w) {
        gv_fail(err, GV_ENOMEM, "shard: out of memory");
        return NULL;
    }
    if (gv_geometry_init(&w->g, h->width, h->height, h->channels,
                         h->root_side) < 0) {
        gv_fail(err, GV_EINVAL, "shard: bad dimensions %ux%u", h->width, h->height);
        free(w);
        return NULL;
    }
    if (gv_atomic_file_open(&w->f, path, err) < 0) {
        free(w);
        return NULL;
    }
    w->index = index;
    w->count = count;
    w->flags = flags;
    /* The template: what gv_store_writer_new would start from. */
    struct gv_header t = *h;
    t.root_side = (uint16_t)w->g.root_side;
    t.version = gv_image_version(h->version, t.root_side);
    t.root = (uint8_t)w->g.root;
    t.root_mips = (uint8_t)w->g.root_mips;
    t.pages = w->g.pages;
    t.psnr0_mdb = 0;
    t.root_offset = t.root_size = t.index_offset = t.file_size = 0;
    t.meta_offset = 0;
    t.meta_size = (uint32_t)meta_len;
    t.meta_crc = meta_len ? gv_crc32(0, meta, meta_len) : 0;
    uint8_t head[ROOT_AT] = {0};
    gv_header_pack(&t, head + TEMPLATE_AT);
    const uint64_t meta_at = ROOT_AT + root_bytes(&w->g) + 4;
    if (gv_atomic_file_pwrite(&w->f, head, sizeof head, 0, err) < 0 ||
        (meta_len &&
         gv_atomic_file_pwrite(&w->f, meta, meta_len, meta_at, err) < 0)) {
        gv_shard_writer_abort(w);
        return NULL;
    }
    w->first = w->off = meta_at + meta_len;
    return w;
}

int gv_shard_writer_root(struct gv_shard_writer *w, const uint8_t *pixels,
                         struct gv_error *err)
{
    uint64_t n = root_bytes(&w->g);
    uint8_t crc[4];
    gv_put32(crc, gv_crc32(0, pixels, (size_t)n));
    if (gv_atomic_file_pwrite(&w->f, pixels, (size_t)n, ROOT_AT, err) < 0 ||
        gv_atomic_file_pwrite(&w->f, crc, 4, ROOT_AT + n, err) < 0)
        return -1;
    w->have_root = 1;
    return 0;
}

int gv_shard_writer_tile(struct gv_shard_writer *w, int level, uint32_t tx,
                         uint32_t ty, const uint8_t *buf, size_t len,
                         const struct gv_tile_stats *stats, uint64_t sse0,
                         struct gv_error *err)
{
    if (len > GV_TILEBUF_MAX || len == 0)
        return gv_fail(err, GV_EINVAL, "shard: tile buffer of %zu bytes", len);
    const struct gv_shard_record r = {
        .level = level, .tx = tx, .ty = ty, .rate = stats->rate,
        .len = (uint32_t)len, .crc = gv_crc32(0, buf, len),
        .sse = stats->sse, .samples = stats->samples, .sse0 = sse0};
    uint8_t rec[GV_SHARD_RECORD];
    record_pack(&r, rec);
    static const uint8_t pad[4] = {0};
    size_t padded = (len + 3) & ~(size_t)3;
    if (gv_atomic_file_pwrite(&w->f, rec, sizeof rec, w->off, err) < 0 ||
        gv_atomic_file_pwrite(&w->f, buf, len, w->off + sizeof rec, err) < 0 ||
        gv_atomic_file_pwrite(&w->f, pad, padded - len,
                              w->off + sizeof rec + len, err) < 0)
        return -1;
    w->off += sizeof rec + padded;
    w->records++;
    return 0;
}

uint64_t gv_shard_writer_bytes(const struct gv_shard_writer *w)
{
    return w->off;
}

int gv_shard_writer_finish(struct gv_shard_writer *w, struct gv_error *err)
{
    int rc = -1;
    if (!w->have_root) {
        gv_fail(err, GV_EINVAL, "shard: finishing without a root");
        goto out;
    }
    const struct shard_head head = {
        .index = (uint32_t)w->index, .count = (uint32_t)w->count,
        .flags = w->flags, .records = w->records, .file_size = w->off,
        .first = w->first};
    uint8_t h[GV_SHARD_HEADER];
    head_pack(&head, h);
    if (gv_atomic_file_pwrite(&w->f, h, sizeof h, 0, err) < 0)
        goto out;
    rc = gv_atomic_file_publish(&w->f, err);
out:
    if (rc < 0)
        gv_atomic_file_abort(&w->f);
    free(w);
    return rc;
}

void gv_shard_writer_abort(struct gv_shard_writer *w)
{
    if (!w)
        return;
    gv_atomic_file_abort(&w->f);
    free(w);
}

/* ------------------------------------------------------------ reader */

struct gv_shard_reader {
    int fd;
    char *path;
    struct gv_shard_info info;
    struct gv_geometry g;
    uint8_t *root;
    size_t root_len;
    uint8_t *meta;            /* the metadata section, or NULL */
    size_t meta_len;
    uint64_t next_off, seen;
};

static int read_at(struct gv_shard_reader *r, void *buf, size_t len,
                   uint64_t off, struct gv_error *err)
{
    int rc = gv_pread_full(r->fd, buf, len, off);
    if (rc < 0)
        return gv_fail_errno(err, errno, "shard: reading %s", r->path);
    if (rc > 0)
        return gv_fail(err, GV_ECORRUPT, "shard: %s is truncated", r->path);
    return 0;
}

/* Same shape as gv_store_close in store/store_read.c and gv_raw_regions_free in
 * imageio/raw_regions.c: deliberately separate, each frees its own struct. */
void gv_shard_close(struct gv_shard_reader *r)
{
    if (!r)
        return;
    if (r->fd >= 0)
        close(r->fd);
    free(r->path);
    free(r->root);
    free(r->meta);
    free(r);
}

/* Same shape as open_file in store/store_read.c: deliberately separate, the
 * messages differ ("shard: cannot open") and a store is also checked to be a
 * regular file. */
/* Open path; *size is its length. */
static int open_file(struct gv_shard_reader *r, const char *path,
                     uint64_t *size, struct gv_error *err)
{
    r->fd = open(path, O_RDONLY | O_CLOEXEC);
    if (r->fd < 0) {
        int e = errno;
        gv_fail_errno(err, e, "shard: cannot open %s", path);
        if (e == ENOENT)
            gv_error_recode(err, GV_EIO, GV_ENOTFOUND);
        return -1;
    }
    struct stat st;
    if (fstat(r->fd, &st) < 0)
        return gv_fail_errno(err, errno, "shard: %s", path);
    *size = (uint64_t)st.st_size;
    return 0;
}

/* Read and check the shard header and the store header after it; fills
 * r->info and r->g, and *first with the offset of the first record. */
static int read_headers(struct gv_shard_reader *r, uint64_t size,
                        uint64_t *first, struct gv_error *err)
{
    const char *path = r->path;
    uint8_t h[ROOT_AT];
    if (size < ROOT_AT || read_at(r, h, sizeof h, 0, err) < 0 ||
        memcmp(h, GV_SHARD_MAGIC, 8) != 0)
        return gv_fail(err, GV_EFORMAT, "shard: %s is not a shard file", path);
    if (gv_get32(h + 60) != gv_crc32(0, h, 60))
        return gv_fail(err, GV_ECORRUPT, "shard: %s: header CRC mismatch", path);
    if (gv_get16(h + 8) != SHARD_VERSION || gv_get16(h + 10) != GV_SHARD_HEADER)
        return gv_fail(err, GV_EFORMAT, "shard: %s: version %u is not "
                       "supported", path, gv_get16(h + 8));
    struct shard_head head;
    head_unpack(h, &head);
    if (head.count < 1 || head.count > GV_SHARD_MAX || head.index >= head.count ||
        head.file_size != size)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: bad shard number, count "
                       "or size", path);
    struct gv_shard_info *in = &r->info;
    in->index = (int)head.index;
    in->count = (int)head.count;
    in->flags = head.flags;
    in->records = head.records;
    in->file_size = head.file_size;
    memcpy(in->header_raw, h + TEMPLATE_AT, GV_HEADER_SIZE);
    if (gv_header_unpack(in->header_raw, &in->header, err) < 0)
        return -1;
    if (gv_geometry_init(&r->g, in->header.width, in->header.height,
                         in->header.channels, in->header.root_side) < 0 ||
        in->header.root != r->g.root || in->header.pages != r->g.pages)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: inconsistent store header",
                       path);
    *first = head.first;
    return 0;
}

/* Read the root level's pixels and check their CRC. */
static int read_root(struct gv_shard_reader *r, struct gv_error *err)
{
    uint8_t crc[4];
    r->root = malloc(r->root_len);
    if (!r->root)
        return gv_fail(err, GV_ENOMEM, "shard: out of memory");
    if (read_at(r, r->root, r->root_len, ROOT_AT, err) < 0 ||
        read_at(r, crc, 4, ROOT_AT + r->root_len, err) < 0)
        return -1;
    if (gv_get32(crc) != gv_crc32(0, r->root, r->root_len))
        return gv_fail(err, GV_ECORRUPT, "shard: %s: root CRC mismatch", r->path);
    return 0;
}

/* Read the metadata section, if any, and check its CRC. */
static int read_meta(struct gv_shard_reader *r, struct gv_error *err)
{
    if (r->meta_len == 0)
        return 0;
    r->meta = malloc(r->meta_len);
    if (!r->meta)
        return gv_fail(err, GV_ENOMEM, "shard: out of memory");
    if (read_at(r, r->meta, r->meta_len, ROOT_AT + r->root_len + 4, err) < 0)
        return -1;
    if (gv_crc32(0, r->meta, r->meta_len) != r->info.header.meta_crc)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: metadata CRC mismatch",
                       r->path);
    return 0;
}

struct gv_shard_reader *gv_shard_open(const char *path, struct gv_error *err)
{
    struct gv_shard_reader *r = calloc(1, sizeof *r);
    if (!r || !(r->path = strdup(path))) {
        free(r);
        gv_fail(err, GV_ENOMEM, "shard: out of memory");
        return NULL;
    }
    uint64_t size = 0, first = 0;
    if (open_file(r, path, &size, err) < 0 ||
        read_headers(r, size, &first, err) < 0)
        goto fail;
    r->root_len = (size_t)root_bytes(&r->g);
    r->meta_len = r->info.header.meta_size;
    if (r->meta_len > GV_META_MAX_SECTION ||
        first != ROOT_AT + r->root_len + 4 + r->meta_len ||
        first > r->info.file_size) {
        gv_fail(err, GV_ECORRUPT, "shard: %s: bad record offset", path);
        goto fail;
    }
    if (read_root(r, err) < 0 || read_meta(r, err) < 0)
        goto fail;
    r->next_off = first;
    return r;
fail:
    gv_shard_close(r);
    return NULL;
}

const struct gv_shard_info *gv_shard_get_info(const struct gv_shard_reader *r)
{
    return &r->info;
}

const uint8_t *gv_shard_meta(const struct gv_shard_reader *r, size_t *len)
{
    *len = r->meta_len;
    return r->meta;
}

const uint8_t *gv_shard_root(const struct gv_shard_reader *r, size_t *len)
{
    *len = r->root_len;
    return r->root;
}

int gv_shard_next(struct gv_shard_reader *r, struct gv_shard_record *rec,
                  struct gv_error *err)
{
    if (r->seen == r->info.records) {
        if (r->next_off != r->info.file_size)
            return gv_fail(err, GV_ECORRUPT, "shard: %s: data after the last "
                           "record", r->path);
        return 0;
    }
    uint8_t h[GV_SHARD_RECORD];
    if (r->next_off + GV_SHARD_RECORD > r->info.file_size)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: record %llu past the end",
                       r->path, (unsigned long long)r->seen);
    if (read_at(r, h, sizeof h, r->next_off, err) < 0)
        return -1;
    if (memcmp(h, RECORD_MAGIC, 4) != 0 || gv_get32(h + 60) != gv_crc32(0, h, 60))
        return gv_fail(err, GV_ECORRUPT, "shard: %s: record %llu is damaged",
                       r->path, (unsigned long long)r->seen);
    record_unpack(h, rec);
    rec->offset = r->next_off + GV_SHARD_RECORD;
    uint64_t padded = ((uint64_t)rec->len + 3) & ~(uint64_t)3;
    if (rec->level >= r->g.root || rec->tx >= r->g.level[rec->level].tiles_x ||
        rec->ty >= r->g.level[rec->level].tiles_y || rec->rate > GV_RATE_DCT ||
        rec->len == 0 || rec->len > GV_TILEBUF_MAX ||
        rec->offset + padded > r->info.file_size)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: record %llu is out of range",
                       r->path, (unsigned long long)r->seen);
    r->next_off = rec->offset + padded;
    r->seen++;
    return 1;
}

int gv_shard_read_tile(struct gv_shard_reader *r,
                       const struct gv_shard_record *rec, uint8_t *buf,
                       struct gv_error *err)
{
    if (read_at(r, buf, rec->len, rec->offset, err) < 0)
        return -1;
    if (gv_crc32(0, buf, rec->len) != rec->crc)
        return gv_fail(err, GV_ECORRUPT, "shard: %s: tile %d/%u/%u fails its CRC",
                       r->path, rec->level, rec->tx, rec->ty);
    return 0;
}
