/*
 * iiif.h - parsing IIIF Image API 3.0 requests (compliance level 2).
 *
 * A request URI is {base}/{identifier}/{region}/{size}/{rotation}/
 * {quality}.{format}.  iiif_parse takes the four path segments after the
 * identifier, the image's full size and the configured limits, and
 * produces a canonical, validated request, or an error classified as the
 * specification wants: GV_EINVAL -> 400 Bad Request, GV_EFORMAT -> 501 Not
 * Implemented (a valid form this server does not support, e.g. arbitrary
 * rotation), GV_ELIMIT -> 400 on the IIIF routes, which know no 413 (past
 * maxWidth/maxHeight/maxArea or the upscaling limit).  Pure function, no
 * I/O: fuzzed directly.
 */
#ifndef GV_IIIF_H
#define GV_IIIF_H

#include <stdint.h>

#include "base/error.h"
#include "render/region.h"

struct iiif_limits {
    uint32_t max_width, max_height; /* advertised maxWidth / maxHeight; 0: none */
    uint64_t max_area;              /* advertised maxArea; 0: none */
    double max_upscale;             /* largest '^' scale factor allowed per
                                     * axis; below 1 (or 0): no upscaling */
};

struct iiif_request {
    struct gv_render_req render;    /* region, size, rotation, quality */
    char format[8];                 /* "jpg", "png", "webp" or "tif" */
};

/*
 * Parse region, size, rotation and "quality.format" (each one path
 * segment, already percent-decoded) for an image of width x height.
 * Returns 0, or -1 with *err filled (message says which parameter and why;
 * client text in it is truncated and reduced to printable ASCII).  On
 * success out->render.max_decode_pixels is 0: the caller sets its policy.
 * Any thread; no allocation.
 */
int iiif_parse(const char *region, const char *size, const char *rotation,
               const char *quality_format, uint32_t width, uint32_t height,
               const struct iiif_limits *limits, struct iiif_request *out,
               struct gv_error *err);

#endif
