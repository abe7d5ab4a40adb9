/*
 * batch_frames.h - reading the body of a gigaviewd batch answer
 * (POST/GET /v1/images/{id}/batch, docs/API.md): "GVB1" frames, or
 * "GVB2" frames that also carry each tile's ETag (asked for with
 * ?etag=1).  The body comes from the network: every length is checked
 * against what is left, and nothing is copied.
 */
#ifndef GV_BATCH_FRAMES_H
#define GV_BATCH_FRAMES_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

/* One frame: pointers into the body given to gv_batch_frames_parse. */
struct gv_batch_frame {
    uint32_t level, tx, ty;
    uint32_t status;        /* 200, 304 (GVB2: the ETag listed), or an error */
    const uint8_t *data;    /* the tile buffer, len bytes (0 unless 200) */
    size_t len;
    const char *etag;       /* the ETag, etag_len bytes, not NUL-terminated */
    size_t etag_len;        /* 0 in GVB1 and for failed tiles */
};

/* Parse body[0..len) into f[0..count): the answer to a request for count
 * tiles.  Returns 0, or -1 with *err (GV_ECORRUPT) when the body is not
 * exactly "GVB1"/"GVB2", a count of `count`, and count whole frames: each
 * with zero reserved bytes, an ETag only in GVB2, a length no larger than
 * what is left, zero padding, and data only with status 200. */
int gv_batch_frames_parse(const uint8_t *body, size_t len, size_t count,
                          struct gv_batch_frame *f, struct gv_error *err);

#endif
