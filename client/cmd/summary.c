/*
 * summary.c - the store summary shared by encode and merge (summary.h).
 */
#include <stdio.h>

#include "summary.h"

void print_store_summary(const char *output, const struct gv_encode_result *r,
                         double target)
{
    const struct gv_geometry *g = &r->geometry;
    double mp = (double)g->width * g->height / 1e6;
    printf("store      %s\n", output);
    printf("image      %u x %u, %s, %.1f MP\n", g->width, g->height,
           g->channels == 1 ? "gray" : "RGB", mp);
    printf("levels     %d tiled + root %u x %u\n", g->root,
           g->level[g->root].width, g->level[g->root].height);
    printf("tiles      %llu", (unsigned long long)r->tiles);
    const char *sep = " (rate:tiles";
    for (int k = 0; k <= GV_RATE_DCT; k++)
        if (r->rate_tiles[k]) {
            if (k == GV_RATE_DCT)
                printf("%s D:%llu", sep, (unsigned long long)r->rate_tiles[k]);
            else
                printf("%s %d:%llu", sep, k, (unsigned long long)r->rate_tiles[k]);
            sep = "";
        }
    printf("%s\n", r->tiles ? ")" : "");
    if (r->below_target)
        printf("warning    %llu tiles reached the rate cap before the %.1f dB target\n",
               (unsigned long long)r->below_target, target);
    printf("size       %llu bytes, %.3f bits per source pixel\n",
           (unsigned long long)r->file_bytes, r->bpp);
    if (r->per_tile)
        printf("psnr       %.2f dB at level 0 (every tile at least %.1f dB)\n",
               r->psnr0, target);
    else
        printf("psnr       %.2f dB at level 0 (target %.1f dB, %+.2f)\n", r->psnr0,
               target, r->psnr0 - target);
    if (r->lambda_tries)   /* not for a merge */
        printf("lambda     %.4g, after %d trial encode%s of a sample of tiles "
               "(the rate model's gave %.2f dB)\n", r->lambda, r->lambda_tries,
               r->lambda_tries == 1 ? "" : "s", r->model_psnr);
    if (r->scratch_bytes || r->level0_from_input)   /* not for a merge */
        printf("scratch    %.1f MB%s\n", (double)r->scratch_bytes / 1e6,
               r->level0_from_input ? ", level 0 read again from the input"
                                    : "");
    printf("time       %.2f s, %.2f MP/s\n", r->seconds,
           r->seconds > 0 ? mp / r->seconds : 0.0);
}
