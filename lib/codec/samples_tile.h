/*
 * samples_tile.h - the tile of a sample store (docs/FORMAT.md section 13):
 * one height-tile buffer (height_tile.h) per channel, channel 0 first,
 * one after another with nothing between them.  Each buffer says its own
 * length (gv_height_tile_span), so a tile needs no table of its own, and
 * a one-channel sample tile is exactly a height tile.  Every channel is
 * predicted from the same channel of the decoded parent and coded with
 * the store's half-step e, so each GPU or browser decoder of height tiles
 * decodes a sample store's channels bit for bit as the CPU does.
 *
 * Pixels here are interleaved: a tile is 513 x 513 pixels of c uint16_t
 * codes, channel 0 first, as the decoder's tile cache and the regions
 * hold them.  All functions are thread-safe.
 */
#ifndef GV_SAMPLES_TILE_H
#define GV_SAMPLES_TILE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* The most channels a sample store holds (docs/FORMAT.md section 13). */
#define GV_SAMPLES_MAX_CHANNELS 8

/* Split a tile of c channels (1..8) into its channel buffers: part[k] and
 * part_len[k] for k < c.  0, or -1 with GV_ECORRUPT when a buffer's
 * header is malformed or the buffers do not fill len exactly. */
int gv_samples_tile_split(const uint8_t *buf, size_t len, int c,
                          const uint8_t **part, size_t *part_len,
                          struct gv_error *err);

/* Check a tile of c channels: its split and every channel's buffer
 * (gv_height_tile_check).  0 or -1 (GV_ECORRUPT). */
int gv_samples_tile_check(const uint8_t *buf, size_t len, int c,
                          struct gv_error *err);

/*
 * Decode a tile of c channels against quadrant (qx,qy) of the decoded
 * `parent` (interleaved) into `out` (interleaved, 513 x 513 x c codes).
 * Checks everything; a damaged tile fails with GV_ECORRUPT.  Allocates
 * about 1 MB of scratch for the call (GV_ENOMEM).  0 or -1.
 */
int gv_samples_tile_decode(const uint8_t *buf, size_t len, int c,
                           const uint16_t *parent, int qx, int qy,
                           uint16_t *out, struct gv_error *err);

/* Channel k of n interleaved c-channel pixels into a plane of n codes, and
 * back.  What the decoder and the encoder use to code a channel alone. */
void gv_samples_plane_get(const uint16_t *px, size_t n, int c, int k,
                          uint16_t *plane);
void gv_samples_plane_put(const uint16_t *plane, size_t n, int c, int k,
                          uint16_t *px);

#endif
