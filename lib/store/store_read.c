/*
 * store_read.c - open, validate and read store files (see store_read.h).
 *
 * Every size and offset read from the file is checked against the file's
 * real length before use, with 64-bit arithmetic, so a hostile file can
 * make open fail but never makes the reader touch memory it does not own.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/file_io.h"
#include "store/store_meta.h"
#include "store/store_read.h"
#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "codec/tile.h"

struct gv_store {
    int fd;
    struct gv_store_info info;
    uint8_t *root;            /* all root mips */
    uint64_t root_mip_off[GV_MAX_LEVELS + 2];
    uint8_t *index;           /* pages * 16 bytes */
    uint32_t root_crc;        /* the root section's CRC, as stored */
    uint64_t identity;        /* gv_store_identity */
    char *path;
    char *meta;               /* gv_store_meta: the metadata's JSON */
};

static int read_exact(int fd, void *buf, size_t len, uint64_t off,
                      const char *what, struct gv_error *err)
{
    int rc = gv_pread_full(fd, buf, len, off);
    if (rc < 0)
        return gv_fail_errno(err, errno, "store: reading %s", what);
    if (rc > 0)
        return gv_fail(err, GV_ECORRUPT, "store: %s is truncated", what);
    return 0;
}

static int check_header(struct gv_store *s, uint64_t file_size,
                        struct gv_error *err)
{
    const struct gv_header *h = &s->info.header;
    struct gv_geometry *g = &s->info.geometry;
    if (gv_geometry_init(g, h->width, h->height, h->channels, h->root_side) < 0)
        return gv_fail(err, GV_ECORRUPT, "store: bad dimensions %ux%u or "
                       "channels %u", h->width, h->height, h->channels);
    if (g->root != h->root || g->root_mips != h->root_mips)
        return gv_fail(err, GV_ECORRUPT, "store: level count does not match "
                       "the dimensions");
    if (h->pages != g->pages)
        return gv_fail(err, GV_ECORRUPT, "store: page count %llu, expected "
                       "%llu", (unsigned long long)h->pages,
                       (unsigned long long)g->pages);
    if (h->file_size != file_size)
        return gv_fail(err, GV_ECORRUPT, "store: file is %llu bytes, header "
                       "says %llu (truncated?)", (unsigned long long)file_size,
                       (unsigned long long)h->file_size);
    /* Lossless WebP never needs twice the raw samples, nor deflate twice
     * the raw codes. */
    const uint64_t root_max = gv_header_codes(h)
        ? (uint64_t)4 * GV_ROOT_MAX * GV_ROOT_MAX * (unsigned)h->channels + 4096
        : 2 * GV_ROOT_MAX_BYTES + 4096;
    if (h->root_size < 5 || h->root_size > root_max ||
        h->root_offset < GV_HEADER_SIZE ||
        h->root_offset > file_size || h->root_size > file_size - h->root_offset)
        return gv_fail(err, GV_ECORRUPT, "store: root section out of bounds");
    uint64_t index_bytes = h->pages * GV_INDEX_ENTRY + 4;
    if (h->index_offset < GV_HEADER_SIZE || h->index_offset > file_size ||
        index_bytes > file_size - h->index_offset)
        return gv_fail(err, GV_ECORRUPT, "store: page index out of bounds");
    if (h->meta_size != 0 &&
        (h->meta_size > GV_META_MAX_SECTION || h->meta_offset < GV_HEADER_SIZE ||
         h->meta_offset > file_size || h->meta_size > file_size - h->meta_offset))
        return gv_fail(err, GV_ECORRUPT, "store: metadata section out of bounds");
    return 0;
}

/* Read and check the metadata section, if any (a newer version of it is
 * ignored: s->meta stays NULL). */
static int load_meta(struct gv_store *s, struct gv_error *err)
{
    const struct gv_header *h = &s->info.header;
    if (h->meta_size == 0)
        return 0;
    uint8_t *b = malloc(h->meta_size);
    if (!b)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for metadata");
    int rc = read_exact(s->fd, b, h->meta_size, h->meta_offset,
                        "metadata section", err);
    if (rc == 0 && gv_crc32(0, b, h->meta_size) != h->meta_crc)
        rc = gv_fail(err, GV_ECORRUPT, "store: metadata section CRC mismatch");
    if (rc == 0)
        rc = gv_meta_unpack(b, h->meta_size, &s->meta, err);
    free(b);
    return rc;
}

/* Same shape as open_file in encode/shard_file.c: deliberately separate, the
 * messages differ and only a store must be a regular file. */
/* Open path as a regular file of at least a header's size; *size is its
 * length. */
static int open_file(struct gv_store *s, const char *path, uint64_t *size,
                     struct gv_error *err)
{
    s->fd = open(path, O_RDONLY | O_CLOEXEC);
    if (s->fd < 0) {
        int e = errno;
        gv_fail_errno(err, e, "store: %s", path);
        if (e == ENOENT)
            gv_error_recode(err, GV_EIO, GV_ENOTFOUND);
        return -1;
    }
    struct stat st;
    if (fstat(s->fd, &st) < 0)
        return gv_fail_errno(err, errno, "store: %s", path);
    if (!S_ISREG(st.st_mode))
        return gv_fail(err, GV_EFORMAT, "store: %s is not a regular file", path);
    if ((uint64_t)st.st_size < GV_HEADER_SIZE)
        return gv_fail(err, GV_EFORMAT, "store: %s is too short to be a store",
                       path);
    *size = (uint64_t)st.st_size;
    return 0;
}

/* Build the mips of a root of codes in place (c interleaved channels, as
 * gv_root_build_mips does for 8-bit samples). */
static void code_mips(uint16_t *buf, uint32_t w, uint32_t h, int c)
{
    while (w > 1 || h > 1) {
        uint16_t *next = buf + (size_t)w * h * c;
        gv_codes_box_reduce(buf, w, h, c, next);
        buf = next;
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
}

/* Read, check and decompress the root, and derive its mips. */
static int load_root(struct gv_store *s, struct gv_error *err)
{
    const struct gv_header *h = &s->info.header;
    const struct gv_geometry *g = &s->info.geometry;
    const int codes = gv_header_codes(h);
    const int bpp = codes ? 2 * g->channels : g->channels;   /* bytes per pixel */
    uint32_t w = g->level[g->root].width, hh = g->level[g->root].height;
    uint8_t *packed = malloc(h->root_size);
    s->root = malloc(gv_root_pixels_size(w, hh, bpp));
    if (!packed || !s->root) {
        free(packed);
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
    }
    if (read_exact(s->fd, packed, h->root_size, h->root_offset, "root", err) < 0 ||
        (gv_crc32(0, packed, h->root_size - 4) != gv_get32(packed + h->root_size - 4) &&
         gv_fail(err, GV_ECORRUPT, "store: root CRC mismatch")) ||
        (codes ? gv_codes_root_unpack(packed, h->root_size - 4, w, hh,
                                      g->channels, (uint16_t *)(void *)s->root,
                                      err)
                : gv_root_unpack(packed, h->root_size - 4, w, hh, g->channels,
                                 s->root, err)) < 0) {
        free(packed);
        return -1;
    }
    s->root_crc = gv_get32(packed + h->root_size - 4);
    free(packed);
    if (codes)
        code_mips((uint16_t *)(void *)s->root, w, hh, g->channels);
    else
        gv_root_build_mips(s->root, w, hh, g->channels);
    uint64_t off = 0;
    for (int m = 0; m < g->root_mips; m++) {
        s->root_mip_off[m] = off;
        off += (uint64_t)w * hh * bpp;
        w = (w + 1) / 2;
        hh = (hh + 1) / 2;
    }
    return 0;
}

/* Read the page index, check its CRC, and check that every page lies
 * inside the file. */
static int load_index(struct gv_store *s, struct gv_error *err)
{
    const struct gv_header *h = &s->info.header;
    size_t ib = (size_t)h->pages * GV_INDEX_ENTRY + 4;
    s->index = malloc(ib);
    if (!s->index)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the page index");
    if (read_exact(s->fd, s->index, ib, h->index_offset, "page index", err) < 0)
        return -1;
    if (gv_crc32(0, s->index, ib - 4) != gv_get32(s->index + ib - 4))
        return gv_fail(err, GV_ECORRUPT, "store: page index CRC mismatch");
    for (uint64_t p = 0; p < h->pages; p++) {
        const uint8_t *e = s->index + p * GV_INDEX_ENTRY;
        uint64_t po = gv_get64(e);
        uint32_t ps = gv_get32(e + 8);
        if (po < GV_HEADER_SIZE || po > h->file_size ||
            ps > h->file_size - po || ps < GV_PAGE_TABLE)
            return gv_fail(err, GV_ECORRUPT, "store: page %llu lies outside "
                           "the file", (unsigned long long)p);
    }
    return 0;
}

/*
 * The store identity: a 64-bit hash of the header, the root's CRC and
 * the page index (every page's offset, size and CRC, then the index's
 * CRC), fed as little-endian 64-bit words in that order.  Each piece ends
 * with a word of its length, so two pieces never run into each other.
 * A word is mixed by multiply-rotate-multiply into a state that is
 * rotated, multiplied by 5 and offset, and the state is avalanched at the
 * end by the xor-shift-multiply finalizer; the odd multipliers are
 * MurmurHash3's 64-bit constants, chosen there for their measured
 * avalanche.
 */
static uint64_t rotl64(uint64_t x, int r)
{
    return x << r | x >> (64 - r);
}

static uint64_t id_word(uint64_t h, uint64_t w)
{
    w *= 0x87c37b91114253d5ull;
    w = rotl64(w, 31);
    w *= 0x4cf5ad432745937full;
    h ^= w;
    h = rotl64(h, 27);
    return h * 5 + 0x52dce729;
}

static uint64_t id_bytes(uint64_t h, const uint8_t *p, size_t n)
{
    size_t left = n;
    for (; left >= 8; p += 8, left -= 8)
        h = id_word(h, gv_get64(p));
    uint64_t tail = 0;
    for (size_t i = 0; i < left; i++)
        tail |= (uint64_t)p[i] << (8 * i);
    if (left)
        h = id_word(h, tail);
    return id_word(h, (uint64_t)n);
}

/* Same shape as hash2 in encode/height_encode.c and mix32 in encode/source.c:
 * deliberately separate, a 64-bit finaliser whose output is a store's identity.
 */
static uint64_t id_final(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

/* The identity of s, whose header bytes are hb (as read). */
static uint64_t identity(const struct gv_store *s, const uint8_t *hb)
{
    uint8_t crc[4];
    gv_put32(crc, s->root_crc);
    uint64_t h = id_bytes(0x6769676176696577ull, hb, GV_HEADER_SIZE);
    h = id_bytes(h, crc, sizeof crc);
    h = id_bytes(h, s->index,
                 (size_t)s->info.header.pages * GV_INDEX_ENTRY + 4);
    return id_final(h);
}

struct gv_store *gv_store_open(const char *path, struct gv_error *err)
{
    struct gv_store *s = calloc(1, sizeof *s);
    if (!s) {
        gv_fail(err, GV_ENOMEM, "store: out of memory");
        return NULL;
    }
    uint64_t size = 0;
    uint8_t hb[GV_HEADER_SIZE];
    if (open_file(s, path, &size, err) < 0 ||
        read_exact(s->fd, hb, sizeof hb, 0, "header", err) < 0 ||
        gv_header_unpack(hb, &s->info.header, err) < 0 ||
        check_header(s, size, err) < 0 || load_root(s, err) < 0 ||
        load_index(s, err) < 0 || load_meta(s, err) < 0) {
        gv_store_close(s);
        return NULL;
    }
    s->identity = identity(s, hb);
    s->path = strdup(path);
    return s;
}

/* Same shape as gv_shard_close in encode/shard_file.c and gv_raw_regions_free
 * in imageio/raw_regions.c: deliberately separate, each frees its own struct.
 */
void gv_store_close(struct gv_store *s)
{
    if (!s)
        return;
    if (s->fd >= 0)
        close(s->fd);
    free(s->root);
    free(s->index);
    free(s->path);
    free(s->meta);
    free(s);
}

const struct gv_store_info *gv_store_info(const struct gv_store *s)
{
    return &s->info;
}

const char *gv_store_meta(const struct gv_store *s)
{
    return s->meta;
}

uint64_t gv_store_identity(const struct gv_store *s)
{
    return s->identity;
}

const uint8_t *gv_store_root(const struct gv_store *s, int mip, uint32_t *w,
                             uint32_t *h)
{
    const struct gv_geometry *g = &s->info.geometry;
    if (mip < 0 || mip >= g->root_mips)
        return NULL;
    uint32_t mw = g->level[g->root].width, mh = g->level[g->root].height;
    for (int m = 0; m < mip; m++) {
        mw = (mw + 1) / 2;
        mh = (mh + 1) / 2;
    }
    *w = mw;
    *h = mh;
    return s->root + s->root_mip_off[mip];
}

int gv_store_read_root_webp(const struct gv_store *s, uint8_t **data,
                            size_t *len, struct gv_error *err)
{
    const struct gv_header *h = &s->info.header;
    if (gv_header_codes(h))
        return gv_fail(err, GV_EFORMAT, "store: a height or sample store's "
                       "root is not a WebP image");
    /* root_size (5 .. about 1.5 MiB, its CRC included) was checked at open. */
    uint8_t *b = malloc(h->root_size);
    if (!b)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for the root");
    if (read_exact(s->fd, b, h->root_size, h->root_offset, "root", err) < 0 ||
        (gv_crc32(0, b, h->root_size - 4) != gv_get32(b + h->root_size - 4) &&
         gv_fail(err, GV_ECORRUPT, "store: root CRC mismatch"))) {
        free(b);
        return -1;
    }
    *data = b;
    *len = h->root_size - 4;
    return 0;
}

int gv_store_page_extent(const struct gv_store *s, uint64_t page,
                         uint64_t *offset, uint32_t *size, uint32_t *crc)
{
    if (page >= s->info.header.pages)
        return -1;
    const uint8_t *e = s->index + page * GV_INDEX_ENTRY;
    *offset = gv_get64(e);
    *size = gv_get32(e + 8);
    *crc = gv_get32(e + 12);
    return 0;
}

uint64_t gv_store_level_bytes(const struct gv_store *s, int level)
{
    const struct gv_geometry *g = &s->info.geometry;
    if (level < 0 || level >= g->root)
        return 0;
    const struct gv_level *l = &g->level[level];
    uint64_t total = 0, n = (uint64_t)l->pages_x * l->pages_y;
    for (uint64_t p = 0; p < n; p++)
        total += gv_get32(s->index + (l->first_page + p) * GV_INDEX_ENTRY + 8);
    return total;
}

int gv_page_check(const struct gv_store *s, const uint8_t *page, size_t len,
                  int level, uint32_t px, uint32_t py, struct gv_error *err)
{
    const struct gv_geometry *g = &s->info.geometry;
    const struct gv_level *l = &g->level[level];
    if (len < GV_PAGE_TABLE || memcmp(page, GV_PAGE_MAGIC, 4) != 0 ||
        page[4] != level || gv_get32(page + 8) != px || gv_get32(page + 12) != py)
        return gv_fail(err, GV_ECORRUPT, "store: page %d/%u/%u has a bad "
                       "header", level, px, py);
    for (int j = 0; j < GV_PAGE_TILES; j++)
        for (int i = 0; i < GV_PAGE_TILES; i++) {
            uint32_t tx = px * GV_PAGE_TILES + (uint32_t)i;
            uint32_t ty = py * GV_PAGE_TILES + (uint32_t)j;
            const uint8_t *e = page + GV_PAGE_HEADER + 8 * (j * GV_PAGE_TILES + i);
            uint32_t to = gv_get32(e), ts = gv_get32(e + 4);
            int inside = tx < l->tiles_x && ty < l->tiles_y;
            if (!inside) {
                if (to || ts)
                    return gv_fail(err, GV_ECORRUPT, "store: page %d/%u/%u "
                                   "has a tile outside the grid", level, px, py);
                continue;
            }
            if (to < GV_PAGE_TABLE || (to & 3) || to > len || ts > len - to)
                return gv_fail(err, GV_ECORRUPT, "store: tile %d/%u/%u lies "
                               "outside its page", level, tx, ty);
            struct gv_error why = {0};
            if ((s->info.header.kind == GV_KIND_HEIGHT
                     ? gv_height_tile_check(page + to, ts, &why)
                     : s->info.header.kind == GV_KIND_SAMPLES
                     ? gv_samples_tile_check(page + to, ts, g->channels, &why)
                     : gv_tilebuf_check(page + to, ts, g->channels, &why)) < 0)
                /* why, not err: snprintf must not read the buffer it
                 * writes (found by fuzz_store's valgrind replay). */
                return gv_fail(err, GV_ECORRUPT, "store: tile %d/%u/%u: %s",
                               level, tx, ty, why.text);
        }
    return 0;
}

int gv_store_read_page(const struct gv_store *s, int level, uint32_t px,
                       uint32_t py, uint8_t **data, size_t *len,
                       struct gv_error *err)
{
    const struct gv_geometry *g = &s->info.geometry;
    if (level < 0 || level >= g->root || px >= g->level[level].pages_x ||
        py >= g->level[level].pages_y)
        return gv_fail(err, GV_ENOTFOUND, "store: no page %d/%u/%u", level,
                       px, py);
    uint64_t off;
    uint32_t size, crc;
    gv_store_page_extent(s, gv_page_number(g, level, px, py), &off, &size, &crc);
    uint8_t *buf = malloc(size);
    if (!buf)
        return gv_fail(err, GV_ENOMEM, "store: out of memory for a page");
    if (read_exact(s->fd, buf, size, off, "page", err) < 0)
        goto fail;
    if (gv_crc32(0, buf, size) != crc) {
        gv_fail(err, GV_ECORRUPT, "store: CRC mismatch in page %d/%u/%u",
                level, px, py);
        goto fail;
    }
    if (gv_page_check(s, buf, size, level, px, py, err) < 0)
        goto fail;
    *data = buf;
    *len = size;
    return 0;
fail:
    free(buf);
    return -1;
}

int gv_page_tile(const uint8_t *page, size_t len, int channels, int i, int j,
                 const uint8_t **tile, size_t *tile_len, struct gv_error *err)
{
    if (i < 0 || j < 0 || i >= GV_PAGE_TILES || j >= GV_PAGE_TILES ||
        len < GV_PAGE_TABLE)
        return gv_fail(err, GV_EINVAL, "store: bad tile slot %d,%d", i, j);
    const uint8_t *e = page + GV_PAGE_HEADER + 8 * (j * GV_PAGE_TILES + i);
    uint32_t to = gv_get32(e), ts = gv_get32(e + 4);
    if (ts == 0)
        return gv_fail(err, GV_ENOTFOUND, "store: empty tile slot %d,%d", i, j);
    if (to < GV_PAGE_TABLE || to > len || ts > len - to)
        return gv_fail(err, GV_ECORRUPT, "store: tile slot %d,%d outside page", i, j);
    (void)channels;
    *tile = page + to;
    *tile_len = ts;
    return 0;
}
