/*
 * tin_build_bench.c - the meshing alone, in one process: gv_tin_build (or
 * gv_tin_build_tiled on one thread) of a 1025 x 1025 float grid, best of
 * REPS by the thread's CPU time.  Linked against two versions of
 * lib/mesh/tin.c, it compares them on the same input without the process
 * start, the PNG decode and the glb write of `gigaview mesh`, as
 * bench/README.md's TIN sections report ("in one process").
 *
 *   make -C build bench/tin_build_bench       (this tree's tin.c)
 *   cc -std=c11 -O3 -D_GNU_SOURCE -Ilib -Ibuild -Ibuild/lib \
 *       bench/tin_build_bench.c OTHER/tin.c build/lib/mesh/libgvmesh.a \
 *       build/lib/base/libgvbase.a -lm -pthread   (another version's)
 *   gdal_translate -of ENVI -ot Float32 -srcwin 1140 960 1025 1025 \
 *       ../shared/data/elevation/etopo5-4320x2161-u16.png andes.bin
 *   bench/tin_build_bench andes.bin E TILE REPS [OUT]
 *
 * TILE 0: one crack-free mesh (border first); -1: one mesh by plain greedy
 * insertion (--no-border-first); above 0: crack-free tiles of TILE cells.
 * Heights are offset by -11000 as bench/tin-speed.sh's are; prints the
 * triangle count and the best time.  OUT, if given, receives the last
 * mesh raw (counts, measured error, positions, triangles), so that the
 * outputs of two versions can be compared with cmp(1).
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "mesh/tin.h"

/* The mesh raw, in this machine's byte order.  Returns 0 or -1. */
static int dump(const char *path, const struct gv_mesh *m)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    uint32_t n[2] = {m->nverts, m->ntris};
    int ok = fwrite(n, sizeof n, 1, f) == 1 &&
             fwrite(&m->max_error, sizeof m->max_error, 1, f) == 1 &&
             fwrite(m->pos, 3 * sizeof *m->pos, m->nverts, f) == m->nverts &&
             fwrite(m->tris, 3 * sizeof *m->tris, m->ntris, f) == m->ntris;
    return fclose(f) == 0 && ok ? 0 : -1;
}

int main(int argc, char **argv)
{
    const uint32_t n = 1025;
    if (argc != 5 && argc != 6) {
        fprintf(stderr, "usage: %s GRID.bin E TILE REPS [OUT]\n", argv[0]);
        return 2;
    }
    float *h = malloc((size_t)n * n * sizeof *h);
    FILE *f = fopen(argv[1], "rb");
    if (!h || !f || fread(h, sizeof *h, (size_t)n * n, f) != (size_t)n * n) {
        fprintf(stderr, "%s: cannot read %u x %u floats\n", argv[1], n, n);
        return 1;
    }
    fclose(f);
    for (size_t i = 0; i < (size_t)n * n; i++)
        h[i] -= 11000;
    int tile = atoi(argv[3]), reps = atoi(argv[4]);
    struct gv_tin_params p = {atof(argv[2]), 0, tile >= 0, 0};
    double best = 1e30;
    uint32_t nt = 0;
    for (int r = 0; r < reps; r++) {
        struct gv_mesh m;
        struct gv_error e;
        struct timespec a, b;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &a);
        int rc = tile > 0 ? gv_tin_build_tiled(h, n, n, n, &p, (uint32_t)tile, 1,
                                           &m, &e)
                      : gv_tin_build(h, n, n, n, &p, &m, &e);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &b);
        if (rc) {
            fprintf(stderr, "mesh failed\n");
            return 1;
        }
        double ms = (double)(b.tv_sec - a.tv_sec) * 1e3 +
                    (double)(b.tv_nsec - a.tv_nsec) * 1e-6;
        if (ms < best)
            best = ms;
        nt = m.ntris;
        if (argc == 6 && r == reps - 1 && dump(argv[5], &m) < 0) {
            fprintf(stderr, "%s: cannot write the mesh\n", argv[5]);
            return 1;
        }
        gv_mesh_free(&m);
    }
    printf("%u triangles, %.1f ms CPU (best of %d)\n", nt, best, reps);
    free(h);
    return 0;
}
