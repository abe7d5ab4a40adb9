/*
 * batch_frames.c - the batch answer's frames (batch_frames.h).
 *
 * Layout (docs/API.md; integers little-endian): magic, u32 count, then
 * per tile a 20-byte header (u8 level, u8 ETag length (GVB2, else 0),
 * 2 zero bytes, u32 tx, u32 ty, u32 status, u32 length), the ETag
 * zero-padded to 4, the tile buffer zero-padded to 4.  The reader walks it
 * once with an offset that only ever advances by lengths it has checked
 * against the bytes left.
 */
#include <string.h>

#include "base/byteorder.h"
#include "batch_frames.h"

#define FRAME_HEAD 20

static size_t pad4(size_t n)
{
    return (n + 3) / 4 * 4;
}

/* Are body[off..off + n) all zero bytes? */
static int zeros(const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (p[i])
            return 0;
    return 1;
}

/* Read `n` bytes (padded to 4) at *off: their start, or NULL when fewer
 * than the padded length are left or the padding is not zero. */
static const uint8_t *take(const uint8_t *body, size_t len, size_t *off,
                           size_t n)
{
    size_t left = len - *off;
    if (n > left || pad4(n) > left)
        return NULL;
    const uint8_t *p = body + *off;
    if (!zeros(p + n, pad4(n) - n))
        return NULL;
    *off += pad4(n);
    return p;
}

int gv_batch_frames_parse(const uint8_t *body, size_t len, size_t count,
                          struct gv_batch_frame *f, struct gv_error *err)
{
    if (len < 8 || (memcmp(body, "GVB1", 4) && memcmp(body, "GVB2", 4)))
        return gv_fail(err, GV_ECORRUPT, "batch: not a batch answer (no GVB1 "
                       "or GVB2 magic)");
    int v2 = body[3] == '2';
    if (gv_get32(body + 4) != count)
        return gv_fail(err, GV_ECORRUPT, "batch: %u frames for %zu tiles",
                       (unsigned)gv_get32(body + 4), count);
    size_t off = 8;
    for (size_t i = 0; i < count; i++) {
        const uint8_t *h = take(body, len, &off, FRAME_HEAD);
        if (!h)
            return gv_fail(err, GV_ECORRUPT, "batch: frame %zu cut short", i);
        if (h[2] || h[3] || (!v2 && h[1]))
            return gv_fail(err, GV_ECORRUPT, "batch: frame %zu: reserved bytes "
                           "not zero", i);
        f[i].level = h[0];
        f[i].etag_len = h[1];
        f[i].tx = gv_get32(h + 4);
        f[i].ty = gv_get32(h + 8);
        f[i].status = gv_get32(h + 12);
        f[i].len = gv_get32(h + 16);
        f[i].etag = (const char *)take(body, len, &off, f[i].etag_len);
        f[i].data = take(body, len, &off, f[i].len);
        if (!f[i].etag || !f[i].data)
            return gv_fail(err, GV_ECORRUPT, "batch: frame %zu (tile %u/%u/%u) "
                           "cut short or badly padded", i, f[i].level,
                           f[i].tx, f[i].ty);
        if (f[i].len && f[i].status != 200)
            return gv_fail(err, GV_ECORRUPT, "batch: frame %zu: status %u with "
                           "%zu bytes", i, f[i].status, f[i].len);
    }
    if (off != len)
        return gv_fail(err, GV_ECORRUPT, "batch: %zu bytes after the last frame",
                       len - off);
    return 0;
}
