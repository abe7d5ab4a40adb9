/*
 * route_tiles.c - compressed tiles, exactly as a GPU decodes them.
 *
 *   GET  /v1/images/{id}/tiles/{level}/{tx}/{ty}   one tile buffer
 *   POST /v1/images/{id}/batch  {"tiles": [[level, tx, ty], ...]}
 *   GET  /v1/images/{id}/batch?t=L,X,Y;L,X,Y;...   the same, cacheable
 *
 * A tile response points into the cached page (page_cache.h) and holds a
 * reference to it until libmicrohttpd has sent it: no copy.  The strong
 * ETag is derived from the store's identity (gv_store_identity: a hash
 * of its header, root CRC and page index), the page CRC and the tile
 * coordinates, so it changes whenever the bytes could; it is known from
 * the page index alone, so a 304 costs no disk read.
 *
 * A batch answers one framed binary body (docs/API.md):
 *   "GVB1", u32 count, then per tile: u8 level, 3 zero bytes, u32 tx,
 *   u32 ty, u32 status, u32 length, length bytes, zero padding to 4.
 * All integers little-endian.  A tile that fails has the status the error
 * table (http.c) gives its failure (404 outside the grid, 500 corrupt
 * page) and length 0; the others still serve.
 * With ?etag=1 the body is "GVB2": the same frames, but the byte after
 * the level holds the length of the tile's ETag, which follows the 20
 * header bytes (zero-padded to 4) before the tile bytes; and a tile whose
 * ETag the request's If-None-Match lists is a frame of status 304 with no
 * bytes (and no page read), so a client with a disk cache revalidates a
 * whole view in one request.  A GVB2 reader reads GVB1 as well (ETag
 * length 0); a client that does not ask never sees GVB2.
 * The body is an iovec over the cached pages: no copy either.  The tile
 * list itself is parsed by batch_request.c (fuzzed on its own).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "batch_request.h"
#include "routes.h"
#include "store/geometry.h"
#include "store/store_format.h"

#define IMMUTABLE "public, max-age=31536000, immutable"
/* A tile ETag and its NUL: quotes, 24 hex digits, 3 dashes and 3 numbers
 * (a level of 2 digits, tx and ty of up to 10) make 51 bytes at most, and
 * GVB2 frames carry the length in a byte. */
#define ETAG_MAX 64
#define FRAME_HEAD 20

/* `digits` lower-case hex digits of v at p; returns the end. */
static char *put_hex(char *p, uint64_t v, int digits)
{
    static const char hex[] = "0123456789abcdef";
    for (int i = digits - 1; i >= 0; i--, v >>= 4)
        p[i] = hex[v & 15];
    return p + digits;
}

/* v in decimal at p; returns the end. */
static char *put_dec(char *p, uint32_t v)
{
    char t[10];
    int n = 0;
    do
        t[n++] = (char)('0' + v % 10);
    while (v /= 10);
    while (n)
        *p++ = t[--n];
    return p;
}

/* Tile (level, tx, ty)'s strong ETag into etag (ETAG_MAX bytes): the
 * store's identity, the page CRC and the coordinates, as
 * "%016llx%08x-%u-%u-%u" in quotes (written by hand: snprintf was 2 % of
 * the server's CPU on raw tiles).  Returns its length. */
static size_t tile_etag(char *etag, const struct image *img, uint32_t crc,
                        uint32_t level, uint32_t tx, uint32_t ty)
{
    char *p = etag;
    *p++ = '"';
    p = put_hex(p, img->identity, 16);
    p = put_hex(p, crc, 8);
    *p++ = '-';
    p = put_dec(p, level);
    *p++ = '-';
    p = put_dec(p, tx);
    *p++ = '-';
    p = put_dec(p, ty);
    *p++ = '"';
    *p = '\0';
    return (size_t)(p - etag);
}

static void release_page(void *cls)
{
    page_release(cls);
}

/* Check (level, tx, ty) against the grid and find its page.  Returns 0,
 * or -1 with *err (GV_ENOTFOUND). */
static int locate(const struct image *img, uint32_t level, uint32_t tx,
                  uint32_t ty, uint32_t *crc, struct gv_error *err)
{
    const struct gv_geometry *g = &img->info->geometry;
    if (level >= (uint32_t)g->root)
        return gv_fail(err, GV_ENOTFOUND,
                       "tiles: level %u has no tiles (tiled levels 0..%d; the "
                       "root level is served at /root)", level, g->root - 1);
    const struct gv_level *l = &g->level[level];
    if (tx >= l->tiles_x || ty >= l->tiles_y)
        return gv_fail(err, GV_ENOTFOUND,
                       "tiles: tile (%u,%u) outside level %u's %ux%u grid", tx,
                       ty, level, l->tiles_x, l->tiles_y);
    uint64_t off;
    uint32_t size;
    uint64_t pn = gv_page_number(g, (int)level, tx / GV_PAGE_TILES,
                                 ty / GV_PAGE_TILES);
    if (gv_store_page_extent(img->store, pn, &off, &size, crc) < 0)
        return gv_fail(err, GV_ENOTFOUND, "tiles: no page %llu",
                       (unsigned long long)pn);
    return 0;
}

/* Fetch a tile: *page referenced (release it), *tile inside it. */
static int fetch(struct server *srv, const struct image *img, uint32_t level,
                 uint32_t tx, uint32_t ty, struct page **page,
                 const uint8_t **tile, size_t *len, struct gv_error *err)
{
    struct page *p = page_get(srv->pages, img->store, img->serial, (int)level,
                              tx / GV_PAGE_TILES, ty / GV_PAGE_TILES, err);
    if (!p)
        return -1;
    if (gv_page_tile(p->data, p->len, img->info->geometry.channels,
                     (int)(tx % GV_PAGE_TILES), (int)(ty % GV_PAGE_TILES), tile,
                     len, err) < 0) {
        page_release(p);
        /* the catalog sent us to this slot: whatever is wrong with it
         * is damage to the page */
        gv_error_recode(err, GV_ENOTFOUND, GV_ECORRUPT);
        gv_error_recode(err, GV_EINVAL, GV_ECORRUPT);
        return -1;
    }
    *page = p;
    return 0;
}

/* A tile's failure: counted and logged when the page was at fault. */
static void log_page_error(const struct image *img, uint32_t level,
                           uint32_t tx, uint32_t ty, const struct gv_error *err)
{
    char where[64];
    snprintf(where, sizeof where, "tile %u/%u/%u: ", level, tx, ty);
    http_page_error(img, "tiles", where, err);
}

enum MHD_Result route_tile(struct req *r)
{
    enum MHD_Result ret;
    uint32_t level, tx, ty, crc;
    struct gv_error err = {0};
    if (http_parse_u32(r->param[1], BATCH_LEVEL_MAX, &level) < 0 ||
        http_parse_u32(r->param[2], GV_MAX_DIM, &tx) < 0 ||
        http_parse_u32(r->param[3], GV_MAX_DIM, &ty) < 0)
        return http_send_errorf(r, GV_EINVAL,
                                "tiles: level, tx and ty must be non-negative "
                                "decimal integers in range");
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    if (locate(img, level, tx, ty, &crc, &err) < 0) {
        ret = http_send_error(r, &err);
        goto out;
    }
    char etag[ETAG_MAX];
    tile_etag(etag, img, crc, level, tx, ty);
    if (http_etag_listed(http_header(r, "If-None-Match"), etag)) {
        struct MHD_Response *resp = MHD_create_response_from_buffer(
            0, (void *)"", MHD_RESPMEM_PERSISTENT);
        if (resp) {
            MHD_add_response_header(resp, "ETag", etag);
            MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, IMMUTABLE);
        }
        ret = http_send(r, 304, resp, 0);
        goto out;
    }
    struct page *page;
    const uint8_t *tile;
    size_t len;
    if (fetch(r->srv, img, level, tx, ty, &page, &tile, &len, &err) < 0) {
        log_page_error(img, level, tx, ty, &err);
        ret = http_send_error(r, &err);
        goto out;
    }
    struct MHD_Response *resp = MHD_create_response_from_buffer_with_free_callback_cls(
        len, (void *)tile, release_page, page);
    if (!resp) {
        page_release(page);
    } else {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
                                "application/octet-stream");
        MHD_add_response_header(resp, "ETag", etag);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, IMMUTABLE);
    }
    ret = http_send(r, 200, resp, len);
out:
    image_put(img);
    return ret;
}

/* ------------------------------------------------------------------ batch */

struct batch {
    struct batch_tile *want;  /* batch_request.h */
    size_t n;
    struct page **pages;      /* distinct pages referenced */
    size_t npages;
    int etags;                /* GVB2: frames carry ETags */
    const char *inm;          /* If-None-Match (GVB2 only), or NULL */
    size_t slot;              /* bytes per frame in `frames` */
    uint8_t *frames;          /* 8 + slot per tile header bytes */
};

static void batch_free(void *cls)
{
    struct batch *b = cls;
    for (size_t i = 0; i < b->npages; i++)
        page_release(b->pages[i]);
    free(b->pages);
    free(b->frames);
    free(b->want);
    free(b);
}

static struct page *batch_page(struct batch *b, const struct page *p)
{
    for (size_t i = 0; i < b->npages; i++)
        if (b->pages[i] == p)
            return b->pages[i];
    return NULL;
}

/* The tile list of a GET (?t=) or POST (JSON) batch into b, and whether
 * it asks for ETags (?etag=1, either method).  0 or -1. */
static int batch_parse(struct req *r, struct batch *b, struct gv_error *err)
{
    size_t max = (size_t)r->srv->cfg->batch_max_tiles;
    const char *e = http_query(r, "etag");
    if (e && strcmp(e, "0") && strcmp(e, "1"))
        return gv_fail(err, GV_EINVAL, "batch: etag must be 0 or 1");
    b->etags = e && !strcmp(e, "1");
    b->inm = b->etags ? http_header(r, "If-None-Match") : NULL;
    b->slot = FRAME_HEAD + (b->etags ? ETAG_MAX : 0);
    if (!strcmp(r->method, "POST"))
        return batch_parse_json(r->body, r->body_len, max, &b->want, &b->n, err);
    const char *t = http_query(r, "t");
    if (!t)
        return gv_fail(err, GV_EINVAL, "batch: missing t=L,X,Y;L,X,Y...");
    return batch_parse_query(t, max, &b->want, &b->n, err);
}

/* The body under construction: iovecs over frame headers (b->frames) and
 * cached tiles. */
struct body {
    struct MHD_IoVec *iov;
    unsigned n;
    size_t total;
    int last_frames;   /* iov[n - 1] holds frame headers */
};

static void body_add(struct body *y, const void *p, size_t len)
{
    y->iov[y->n].iov_base = p;
    y->iov[y->n++].iov_len = len;
    y->total += len;
}

/* Tile i of b: its frame (status 200, 304 for an ETag the client listed,
 * or the table's status of its failure; in GVB2 its ETag) and its bytes.
 * Returns 1 if the frame is not a 200, else 0. */
static int batch_tile(struct req *r, const struct image *img, struct batch *b,
                      size_t i, struct body *y)
{
    static const uint8_t zeros[4];
    uint32_t level = b->want[i].level, tx = b->want[i].tx, ty = b->want[i].ty;
    uint8_t *f = b->frames + 8 + b->slot * i;
    uint32_t crc, status = 200;
    const uint8_t *tile = NULL;
    size_t len = 0, elen = 0;
    struct page *p = NULL;
    struct gv_error err = {0};
    int found = locate(img, level, tx, ty, &crc, &err) == 0;
    if (found && b->etags)
        elen = tile_etag((char *)f + FRAME_HEAD, img, crc, level, tx, ty);
    if (found && b->etags && http_etag_listed(b->inm, (char *)f + FRAME_HEAD)) {
        status = 304;
    } else if (!found ||
               fetch(r->srv, img, level, tx, ty, &p, &tile, &len, &err) < 0) {
        log_page_error(img, level, tx, ty, &err);
        status = http_error_status(r, err.code);
        tile = NULL;
        len = 0;
    } else if (batch_page(b, p)) {
        page_release(p); /* already holding it */
    } else {
        b->pages[b->npages++] = p;
    }
    if (elen && status != 200 && status != 304) {
        memset(f + FRAME_HEAD, 0, ETAG_MAX); /* a failed tile has no ETag */
        elen = 0;
    }
    size_t head = FRAME_HEAD + (elen + 3) / 4 * 4; /* etag zero-padded */
    f[0] = (uint8_t)level;
    f[1] = (uint8_t)elen;
    gv_put32(f + 4, tx);
    gv_put32(f + 8, ty);
    gv_put32(f + 12, status);
    gv_put32(f + 16, (uint32_t)len);
    /* Consecutive frame headers stay one iovec when a tile is empty and
     * they lie back to back (GVB1 frames do). */
    const struct MHD_IoVec *last = y->n ? &y->iov[y->n - 1] : NULL;
    if (y->last_frames && last &&
        (const uint8_t *)last->iov_base + last->iov_len == f) {
        y->iov[y->n - 1].iov_len += head;
        y->total += head;
    } else {
        body_add(y, f, head);
    }
    y->last_frames = 1;
    if (len) {
        y->last_frames = 0;
        body_add(y, tile, len);
        if (len % 4) /* tile buffers are whole words; belt and braces */
            body_add(y, zeros, 4 - len % 4);
    }
    return status != 200;
}

enum MHD_Result route_batch(struct req *r)
{
    enum MHD_Result ret;
    struct gv_error err = {0};
    struct batch *b = calloc(1, sizeof *b);
    if (!b)
        return http_send_errorf(r, GV_ENOMEM, "batch: out of memory");
    if (batch_parse(r, b, &err) < 0) {
        batch_free(b);
        return http_send_error(r, &err);
    }
    struct image *img = http_image(r, &ret);
    if (!img) {
        batch_free(b);
        return ret;
    }
    b->frames = calloc(1, 8 + b->slot * b->n);
    b->pages = calloc(b->n, sizeof *b->pages);
    struct body y = {calloc(3 * b->n + 1, sizeof *y.iov), 0, 0, 1};
    if (!b->frames || !b->pages || !y.iov) {
        free(y.iov);
        batch_free(b);
        image_put(img);
        return http_send_errorf(r, GV_ENOMEM, "batch: out of memory");
    }
    memcpy(b->frames, b->etags ? "GVB2" : "GVB1", 4);
    gv_put32(b->frames + 4, (uint32_t)b->n);
    body_add(&y, b->frames, 8);
    int not200 = 0;
    for (size_t i = 0; i < b->n; i++)
        not200 += batch_tile(r, img, b, i, &y);
    struct MHD_Response *resp = MHD_create_response_from_iovec(y.iov, y.n,
                                                               batch_free, b);
    free(y.iov);
    if (!resp) {
        batch_free(b);
    } else {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
                                "application/x-gigaview-batch");
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                                strcmp(r->method, "POST") && !not200
                                    ? IMMUTABLE : "no-store");
    }
    ret = http_send(r, 200, resp, y.total);
    image_put(img);
    return ret;
}
