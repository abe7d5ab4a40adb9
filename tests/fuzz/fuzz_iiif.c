/*
 * fuzz_iiif.c - libFuzzer target for iiif_parse (server/iiif.c).
 *
 * The input is the four IIIF path segments separated by newlines:
 * region, size, rotation and quality.format (a missing segment is empty;
 * anything after a fourth newline belongs to the last segment).  Each is
 * copied into a NUL-terminated buffer of at most 4 KiB (a longer URI
 * segment would be refused by the HTTP layer long before this parser), and
 * the request is parsed for a few image sizes and limit sets.  A success
 * must describe a request the renderer can honour: the region inside the
 * image and not empty, the output size at least 1x1 and within every
 * limit, a rotation of 0/90/180/270, a known quality and format.
 * Anything else aborts.  An error must carry a message naming the module.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "store/geometry.h"
#include "iiif.h"

#define MAX_SEGMENT 4096   /* bytes per segment, NUL excluded */

static void check_one(char *const seg[4], uint32_t W, uint32_t H,
                      const struct iiif_limits *lim)
{
    struct iiif_request r;
    struct gv_error err = {0};
    gv_error_clear(&err);
    if (iiif_parse(seg[0], seg[1], seg[2], seg[3], W, H, lim, &r, &err)
        != 0) {
        if (err.code == GV_OK || strncmp(err.text, "iiif: ", 6) != 0)
            abort();
        if (err.code != GV_EINVAL && err.code != GV_EFORMAT
            && err.code != GV_ELIMIT)
            abort();
        return;
    }
    const struct gv_render_req *q = &r.render;
    if (q->w == 0 || q->h == 0 || q->x >= W || q->y >= H || q->w > W - q->x
        || q->h > H - q->y)
        abort();
    if (q->out_w == 0 || q->out_h == 0 || q->out_w > GV_MAX_DIM
        || q->out_h > GV_MAX_DIM)
        abort();
    if (lim->max_width && q->out_w > lim->max_width)
        abort();
    if (lim->max_height && q->out_h > lim->max_height)
        abort();
    if (lim->max_area && (uint64_t)q->out_w * q->out_h > lim->max_area)
        abort();
    /* enlargement past the region only within max_upscale (>= 1) */
    double up = lim->max_upscale >= 1.0 ? lim->max_upscale : 1.0;
    if ((double)q->out_w > q->w * up + 1e-6
        || (double)q->out_h > q->h * up + 1e-6)
        abort();
    if (q->rotation != 0 && q->rotation != 90 && q->rotation != 180
        && q->rotation != 270)
        abort();
    if (q->mirror != 0 && q->mirror != 1)
        abort();
    if (q->quality < GV_QUALITY_DEFAULT || q->quality > GV_QUALITY_BITONAL)
        abort();
    if (strcmp(r.format, "jpg") && strcmp(r.format, "png")
        && strcmp(r.format, "webp") && strcmp(r.format, "tif"))
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char buf[4][MAX_SEGMENT + 1];
    char *seg[4] = {buf[0], buf[1], buf[2], buf[3]};
    size_t start = 0;
    for (int i = 0; i < 4; i++) {
        size_t end = start;
        if (i < 3)
            while (end < size && data[end] != '\n')
                end++;
        else
            end = size;
        size_t n = end > start ? end - start : 0;
        if (n > MAX_SEGMENT)
            n = MAX_SEGMENT;
        if (n)
            memcpy(buf[i], data + start, n);
        buf[i][n] = '\0';
        start = end < size ? end + 1 : size;
    }
    static const struct iiif_limits lims[] = {
        {0, 0, 0, 0.0},
        {1000, 1000, 0, 4.0},
        {400, 300, 100000, 2.0},
        {0, 0, 1, 1.0},
        {0, 0, 0, 1e300},
        {7, 3, 5, NAN},
    };
    static const uint32_t sizes[][2] = {
        {300, 200}, {1, 1}, {200, 300}, {GV_MAX_DIM, GV_MAX_DIM},
        {1, GV_MAX_DIM}, {1500, 1100},
    };
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (size_t l = 0; l < sizeof lims / sizeof lims[0]; l++)
            check_one(seg, sizes[s][0], sizes[s][1], &lims[l]);
    return 0;
}
