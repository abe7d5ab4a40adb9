/*
 * region_arg.c - the --region argument of export and render (region_arg.h).
 */
#include <stdio.h>

#include "region_arg.h"

int region_arg_check(const char *me, const char *arg, int level, uint32_t lw,
                     uint32_t lh, uint64_t max_pixels, struct region *r)
{
    unsigned long long x = 0, y = 0, w = lw, h = lh;
    char tail;
    if (arg && sscanf(arg, "%llu,%llu,%llu,%llu%c", &x, &y, &w, &h, &tail) != 4) {
        fprintf(stderr, "%s: --region wants X,Y,W,H, not '%s'\n", me, arg);
        return 2;
    }
    if (w == 0 || h == 0 || x >= lw || y >= lh || w > lw - x || h > lh - y) {
        fprintf(stderr, "%s: region %llu,%llu,%llu,%llu is outside level %d "
                "(%u x %u)\n", me, x, y, w, h, level, lw, lh);
        return 1;
    }
    /* w <= lw and h <= lh: the product fits. */
    if (w * h > max_pixels) {
        fprintf(stderr, "%s: region of %llu pixels exceeds the limit of %llu "
                "(--max-pixels)\n", me, w * h, (unsigned long long)max_pixels);
        return 1;
    }
    *r = (struct region){(uint32_t)x, (uint32_t)y, (uint32_t)w, (uint32_t)h};
    return 0;
}
