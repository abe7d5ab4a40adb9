/*
 * region_arg.h - the --region X,Y,W,H argument that `gigaview export` and
 * `gigaview render` share: parsed, checked against the level it cuts and
 * against --max-pixels, with the same messages in both commands.
 */
#ifndef GV_REGION_ARG_H
#define GV_REGION_ARG_H

#include <stdint.h>

/* The default --max-pixels of export and render: 256 MP, 768 MiB of RGB.
 * A plain number, as the help quotes it (OPT_STR). */
#define REGION_DEFAULT_MAX_PIXELS 268435456

struct region {
    uint32_t x, y, w, h;
};

/* Cut `arg` ("X,Y,W,H"; NULL: the whole level) out of level `level`, which
 * is lw x lh pixels, and fill *r.  Returns 0; or prints "ME: ..." on
 * stderr and returns the exit status: 2 when arg is not four numbers, 1
 * when the region is empty or not inside the level, or has more than
 * max_pixels pixels. */
int region_arg_check(const char *me, const char *arg, int level, uint32_t lw,
                     uint32_t lh, uint64_t max_pixels, struct region *r);

#endif
