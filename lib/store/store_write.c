/*
 * store_write.c - streaming, crash-safe store writer (see store_write.h).
 */
#include <stdlib.h>
#include <string.h>

#include "base/atomic_file.h"
#include "store/geometry.h"
#include "store/store_meta.h"
#include "store/store_write.h"

/* Error messages of the file itself start "store:", as every other message
 * of the writer. */
static const struct gv_atomic_opts STORE_FILE = {.module = "store"};

struct gv_store_writer {
    struct gv_atomic_file f;
    struct gv_header h;
    struct gv_geometry g;
    uint64_t off;             /* append position */
    uint8_t *index;           /* pages * 16 bytes */
    uint8_t *written;         /* one flag per page */
    int have_root;
};

static int write_at(struct gv_store_writer *w, const void *buf, size_t len,
                    uint64_t off, struct gv_error *err)
{
    return gv_atomic_file_pwrite(&w->f, buf, len, off, err);
}

/* Free w; the file is closed already or abandoned here. */
static void writer_free(struct gv_store_writer *w)
{
    gv_atomic_file_abort(&w->f);
    free(w->index);
    free(w->written);
    free(w);
}

struct gv_store_writer *gv_store_writer_new(const char *path,
                                            const struct gv_header *h,
                                            struct gv_error *err)
{
    struct gv_store_writer *w = calloc(1, sizeof *w);
    if (!w) {
        gv_fail(err, GV_ENOMEM, "store: out of memory");
        return NULL;
    }
    w->f.fd = -1;
    w->h = *h;
    w->h.meta_offset = 0;   /* gv_store_writer_meta fills them */
    w->h.meta_size = w->h.meta_crc = 0;
    /* An image store is version 2 unless the caller asks for 5 (tiles in
     * layouts D and D2) or 6 (any root_side, gv_image_version). */
    if (h->kind == GV_KIND_HEIGHT || !h->root_side)
        w->h.root_side = GV_ROOT_MAX;
    w->h.version = h->kind == GV_KIND_HEIGHT ? GV_VERSION_HEIGHT :
                   h->kind == GV_KIND_SAMPLES ? GV_VERSION_SAMPLES :
                   gv_image_version(h->version, w->h.root_side);
    if ((h->kind == GV_KIND_IMAGE && h->channels != 1 && h->channels != 3) ||
        (h->kind == GV_KIND_HEIGHT && h->channels != 1)) {
        gv_fail(err, GV_EINVAL, "store: %u channels for this kind of store",
                h->channels);
        goto fail;
    }
    if (gv_geometry_init(&w->g, h->width, h->height, h->channels,
                         w->h.root_side) < 0) {
        gv_fail(err, GV_EINVAL, "store: bad dimensions %ux%u", h->width, h->height);
        goto fail;
    }
    w->h.root = (uint8_t)w->g.root;
    w->h.root_mips = (uint8_t)w->g.root_mips;
    w->h.pages = w->g.pages;
    w->index = calloc(w->g.pages ? w->g.pages : 1, GV_INDEX_ENTRY);
    w->written = calloc(w->g.pages ? w->g.pages : 1, 1);
    if (!w->index || !w->written) {
        gv_fail(err, GV_ENOMEM, "store: out of memory");
        goto fail;
    }
    if (gv_atomic_file_open_opts(&w->f, path, &STORE_FILE, err) < 0)
        goto fail;
    /* Reserve the header; it is written last. */
    uint8_t zero[GV_HEADER_SIZE] = {0};
    if (write_at(w, zero, sizeof zero, 0, err) < 0)
        goto fail;
    w->off = GV_HEADER_SIZE;
    return w;
fail:
    gv_store_writer_abort(w);
    return NULL;
}

int gv_store_writer_page(struct gv_store_writer *w, int level, uint32_t px,
                         uint32_t py, const uint8_t *const *tiles,
                         const size_t *lens, struct gv_error *err)
{
    if (level < 0 || level >= w->g.root || px >= w->g.level[level].pages_x ||
        py >= w->g.level[level].pages_y)
        return gv_fail(err, GV_EINVAL, "store: no page %d/%u/%u", level, px, py);
    uint64_t pn = gv_page_number(&w->g, level, px, py);
    if (w->written[pn])
        return gv_fail(err, GV_EINVAL, "store: page %d/%u/%u written twice",
                       level, px, py);
    size_t total = GV_PAGE_TABLE;
    for (int s = 0; s < GV_PAGE_SLOTS; s++)
        total += (lens[s] + 3) & ~(size_t)3;
    if (total > UINT32_MAX)
        return gv_fail(err, GV_ELIMIT, "store: page too large");
    uint8_t *buf = calloc(1, total);
    if (!buf)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for a page");
    memcpy(buf, GV_PAGE_MAGIC, 4);
    buf[4] = (uint8_t)level;
    gv_put32(buf + 8, px);
    gv_put32(buf + 12, py);
    size_t at = GV_PAGE_TABLE;
    for (int s = 0; s < GV_PAGE_SLOTS; s++) {
        if (!tiles[s] || !lens[s])
            continue;
        gv_put32(buf + GV_PAGE_HEADER + 8 * s, (uint32_t)at);
        gv_put32(buf + GV_PAGE_HEADER + 8 * s + 4, (uint32_t)lens[s]);
        memcpy(buf + at, tiles[s], lens[s]);
        at += (lens[s] + 3) & ~(size_t)3;
    }
    int rc = write_at(w, buf, total, w->off, err);
    if (rc == 0) {
        uint8_t *e = w->index + pn * GV_INDEX_ENTRY;
        gv_put64(e, w->off);
        gv_put32(e + 8, (uint32_t)total);
        gv_put32(e + 12, gv_crc32(0, buf, total));
        w->written[pn] = 1;
        w->off += total;
    }
    free(buf);
    return rc;
}

int gv_store_writer_root(struct gv_store_writer *w, const uint8_t *pixels,
                         struct gv_error *err)
{
    const struct gv_level *r = &w->g.level[w->g.root];
    uint8_t *z;
    size_t zlen;
    if ((gv_header_codes(&w->h)
             ? gv_codes_root_pack((const uint16_t *)(const void *)pixels,
                                  r->width, r->height, w->g.channels, &z,
                                  &zlen, err)
             : gv_root_pack(pixels, r->width, r->height, w->g.channels, &z,
                            &zlen, err)) < 0)
        return -1;
    int rc = gv_store_writer_root_packed(w, z, zlen, err);
    free(z);
    return rc;
}

int gv_store_writer_root_packed(struct gv_store_writer *w, const uint8_t *z,
                                size_t zlen, struct gv_error *err)
{
    uint8_t crc[4];
    gv_put32(crc, gv_crc32(0, z, zlen));
    int rc = write_at(w, z, zlen, w->off, err);
    if (rc == 0)
        rc = write_at(w, crc, 4, w->off + zlen, err);
    if (rc == 0) {
        w->h.root_offset = w->off;
        w->h.root_size = zlen + 4;
        w->off += zlen + 4;
        w->have_root = 1;
    }
    return rc;
}

int gv_store_writer_meta(struct gv_store_writer *w, const uint8_t *section,
                         size_t len, struct gv_error *err)
{
    if (w->h.kind == GV_KIND_HEIGHT || w->h.meta_offset != 0 ||
        len == 0 || len > GV_META_MAX_SECTION)
        return gv_fail(err, GV_EINVAL, "store: a metadata section of %zu "
                       "bytes cannot be written here", len);
    if (write_at(w, section, len, w->off, err) < 0)
        return -1;
    w->h.meta_offset = w->off;
    w->h.meta_size = (uint32_t)len;
    w->h.meta_crc = gv_crc32(0, section, len);
    w->off += len;
    return 0;
}

void gv_store_writer_set_psnr(struct gv_store_writer *w, uint32_t psnr0_mdb)
{
    w->h.psnr0_mdb = psnr0_mdb;
}

uint64_t gv_store_writer_bytes(const struct gv_store_writer *w)
{
    return w->off;
}

/* Append the page index and its CRC, then write the header over the
 * reserved first bytes. */
static int write_index_and_header(struct gv_store_writer *w,
                                  struct gv_error *err)
{
    size_t ib = (size_t)w->g.pages * GV_INDEX_ENTRY;
    uint8_t crc[4];
    gv_put32(crc, gv_crc32(0, w->index, ib));
    w->h.index_offset = w->off;
    if (write_at(w, w->index, ib, w->off, err) < 0 ||
        write_at(w, crc, 4, w->off + ib, err) < 0)
        return -1;
    w->off += ib + 4;
    w->h.file_size = w->off;
    uint8_t hb[GV_HEADER_SIZE];
    gv_header_pack(&w->h, hb);
    return write_at(w, hb, sizeof hb, 0, err);
}

int gv_store_writer_finish(struct gv_store_writer *w, struct gv_error *err)
{
    int rc = -1;
    if (!w->have_root) {
        gv_fail(err, GV_EINVAL, "store: finishing without a root");
        goto out;
    }
    for (uint64_t p = 0; p < w->g.pages; p++)
        if (!w->written[p]) {
            gv_fail(err, GV_EINVAL, "store: page %llu was never written",
                    (unsigned long long)p);
            goto out;
        }
    if (write_index_and_header(w, err) < 0)
        goto out;
    rc = gv_atomic_file_publish(&w->f, err);
out:
    writer_free(w);
    return rc;
}

void gv_store_writer_abort(struct gv_store_writer *w)
{
    if (w)
        writer_free(w);
}
