/*
 * samples_tile.c - splitting, checking and decoding the tiles of sample
 * stores (see samples_tile.h): the channel buffers are height tiles, so
 * this file only walks them and moves codes between interleaved pixels
 * and the planes the height codec works on.
 */
#include <stdlib.h>

#include "codec/height_tile.h"
#include "codec/samples_tile.h"

int gv_samples_tile_split(const uint8_t *buf, size_t len, int c,
                          const uint8_t **part, size_t *part_len,
                          struct gv_error *err)
{
    if (c < 1 || c > GV_SAMPLES_MAX_CHANNELS)
        return gv_fail(err, GV_ECORRUPT, "samples: %d channels", c);
    size_t at = 0;
    for (int k = 0; k < c; k++) {
        size_t n = gv_height_tile_span(buf + at, len - at);
        if (!n)
            return gv_fail(err, GV_ECORRUPT, "samples: channel %d's buffer "
                           "is malformed or runs past the tile", k);
        part[k] = buf + at;
        part_len[k] = n;
        at += n;
    }
    if (at != len)
        return gv_fail(err, GV_ECORRUPT, "samples: %zu bytes past the last "
                       "channel", len - at);
    return 0;
}

int gv_samples_tile_check(const uint8_t *buf, size_t len, int c,
                          struct gv_error *err)
{
    const uint8_t *part[GV_SAMPLES_MAX_CHANNELS];
    size_t plen[GV_SAMPLES_MAX_CHANNELS];
    if (gv_samples_tile_split(buf, len, c, part, plen, err) < 0)
        return -1;
    for (int k = 0; k < c; k++)
        if (gv_height_tile_check(part[k], plen[k], err) < 0)
            return -1;
    return 0;
}

void gv_samples_plane_get(const uint16_t *px, size_t n, int c, int k,
                          uint16_t *plane)
{
    for (size_t i = 0; i < n; i++)
        plane[i] = px[i * (size_t)c + (size_t)k];
}

void gv_samples_plane_put(const uint16_t *plane, size_t n, int c, int k,
                          uint16_t *px)
{
    for (size_t i = 0; i < n; i++)
        px[i * (size_t)c + (size_t)k] = plane[i];
}

int gv_samples_tile_decode(const uint8_t *buf, size_t len, int c,
                           const uint16_t *parent, int qx, int qy,
                           uint16_t *out, struct gv_error *err)
{
    const uint8_t *part[GV_SAMPLES_MAX_CHANNELS];
    size_t plen[GV_SAMPLES_MAX_CHANNELS];
    if (gv_samples_tile_split(buf, len, c, part, plen, err) < 0)
        return -1;
    if (c == 1)   /* a plane already */
        return gv_height_tile_decode(part[0], plen[0], parent, qx, qy, out, err);
    uint16_t *pp = malloc(2 * sizeof *pp * GV_HT_SAMPLES);
    if (!pp)
        return gv_fail(err, GV_ENOMEM, "samples: out of memory for a tile");
    uint16_t *op = pp + GV_HT_SAMPLES;
    int rc = 0;
    for (int k = 0; k < c && rc == 0; k++) {
        gv_samples_plane_get(parent, GV_HT_SAMPLES, c, k, pp);
        rc = gv_height_tile_decode(part[k], plen[k], pp, qx, qy, op, err);
        if (rc == 0)
            gv_samples_plane_put(op, GV_HT_SAMPLES, c, k, out);
    }
    free(pp);
    return rc;
}
