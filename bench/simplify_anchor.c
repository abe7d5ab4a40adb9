/*
 * simplify_anchor.c - the meshoptimizer anchors of bench/simplify-speed.sh:
 *
 *   simplify_anchor sloppy|quadric IN FACES OUT [REPEAT]
 *
 * Reads IN (PLY, OBJ, GLB through lib/mesh/io/mesh_read.h), runs
 * meshopt_simplifySloppy (vertex-grid clustering) or meshopt_simplify
 * (quadric edge collapse) to 3 * FACES indices with no error bound
 * (target_error 1), REPEAT times (default 3), and prints the best time in
 * ms and the faces achieved; writes the result, unused vertices dropped,
 * to OUT as binary PLY.
 */
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mesh/cluster.h"
#include "mesh/io/mesh_read.h"
#include "mesh/io/mesh_write.h"

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: simplify_anchor sloppy|quadric IN FACES OUT [REPEAT]\n");
        return 2;
    }
    int sloppy = strcmp(argv[1], "sloppy") == 0;
    size_t faces = strtoul(argv[3], NULL, 10);
    int repeat = argc > 5 ? atoi(argv[5]) : 3;
    FILE *f = fopen(argv[2], "rb");
    if (!f)
        return 1;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc((size_t)n + 1);
    size_t got = fread(b, 1, (size_t)n, f);
    fclose(f);
    struct gv_mesh m, o = {0};
    struct gv_error err = {0};
    if (gv_mesh_read(b, got, GV_MESH_IN_AUTO, NULL, &m, &err) < 0) {
        fprintf(stderr, "simplify_anchor: %s\n", err.text);
        return 1;
    }
    free(b);
    size_t ni = 3 * (size_t)m.ntris, res = 0;
    unsigned *dst = malloc(ni * sizeof *dst + 4);
    double best = 1e300;
    for (int r = 0; r < repeat; r++) {
        double t0 = now_ms();
        if (sloppy)
            res = meshopt_simplifySloppy(dst, m.tris, ni, m.pos, m.nverts, 12,
                                         3 * faces, 1.0f, NULL);
        else
            res = meshopt_simplify(dst, m.tris, ni, m.pos, m.nverts, 12,
                                   3 * faces, 1.0f, 0, NULL);
        double t = now_ms() - t0;
        best = t < best ? t : best;
    }
    uint32_t *remap = malloc((m.nverts + 1) * sizeof *remap);
    memset(remap, 0xff, (m.nverts + 1) * sizeof *remap);
    o.ntris = (uint32_t)(res / 3);
    o.tris = malloc(res * sizeof *o.tris + 4);
    o.pos = malloc(3 * (size_t)m.nverts * sizeof *o.pos + 4);
    for (size_t i = 0; i < res; i++) {
        uint32_t v = dst[i];
        if (remap[v] == UINT32_MAX) {
            remap[v] = o.nverts;
            memcpy(o.pos + 3 * (size_t)o.nverts++, m.pos + 3 * (size_t)v, 12);
        }
        o.tris[i] = remap[v];
    }
    uint8_t *out;
    size_t len;
    if (gv_mesh_encode(GV_MESH_PLY, &o, NULL, argv[1], &out, &len, &err) < 0)
        return 1;
    FILE *w = fopen(argv[4], "wb");
    if (!w || fwrite(out, 1, len, w) != len || fclose(w))
        return 1;
    printf("%s ms %.3f faces %u\n", argv[1], best, o.ntris);
    free(out);
    free(remap);
    free(dst);
    gv_mesh_free(&o);
    gv_mesh_free(&m);
    return 0;
}
