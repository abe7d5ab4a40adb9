/*
 * simplify_volume.c - the multi-million-triangle mesh of
 * bench/simplify-speed.sh: the isosurface f = 0 of a synthetic volume (a
 * blobby sum of spheres with a ripple), extracted by marching tetrahedra
 * (each cube cut into six tetrahedra around its main diagonal, so
 * neighbouring cubes agree on their faces' diagonals), vertices shared on
 * grid edges.  Deterministic.
 *
 *   simplify_volume N OUT.ply     (an N^3 grid; N = 200 gives ~2.3M faces)
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int N;

static double field(int i, int j, int k)
{
    double x = (double)i / N, y = (double)j / N, z = (double)k / N, f = 0;
    static const double c[5][4] = {{.35, .4, .45, .05}, {.62, .55, .5, .04},
                                   {.5, .3, .62, .03}, {.45, .65, .35, .035},
                                   {.6, .42, .3, .03}};
    for (int s = 0; s < 5; s++) {
        double dx = x - c[s][0], dy = y - c[s][1], dz = z - c[s][2];
        f += c[s][3] / (dx * dx + dy * dy + dz * dz + 1e-6);
    }
    return f - 1.0 - 0.15 * sin(23 * x) * sin(19 * y) * sin(17 * z);
}

/* Vertex ids on grid edges: a hash map from (corner a, corner b). */
static uint64_t *hk;
static uint32_t *hv, hcap;
static float *pos;
static uint32_t nv, vcap;
static uint32_t *tris;
static size_t nt, tcap;
static float *val;

static uint64_t cid(int i, int j, int k)
{
    return ((uint64_t)k * (N + 1) + j) * (N + 1) + i;
}

static uint32_t edge_vertex(uint64_t a, uint64_t b)
{
    if (a > b) { uint64_t t = a; a = b; b = t; }
    uint64_t key = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull);
    uint64_t id = a * ((uint64_t)(N + 1) * (N + 1) * (N + 1)) + b;
    uint32_t h = (uint32_t)(key >> 20) & (hcap - 1);
    while (hk[h] != UINT64_MAX && hk[h] != id)
        h = (h + 1) & (hcap - 1);
    if (hk[h] == id)
        return hv[h];
    hk[h] = id;
    if (nv == vcap) {
        vcap *= 2;
        pos = realloc(pos, 3 * (size_t)vcap * sizeof *pos);
    }
    int s = N + 1;
    double fa = val[a], fb = val[b], t = fa / (fa - fb);
    double pa[3] = {(double)(a % s), (double)(a / s % s), (double)(a / s / s)};
    double pb[3] = {(double)(b % s), (double)(b / s % s), (double)(b / s / s)};
    for (int k = 0; k < 3; k++)
        pos[3 * (size_t)nv + k] = (float)((pa[k] + t * (pb[k] - pa[k])) / N);
    hv[h] = nv;
    return nv++;
}

static void tri(uint32_t a, uint32_t b, uint32_t c)
{
    if (nt == tcap) {
        tcap *= 2;
        tris = realloc(tris, 3 * tcap * sizeof *tris);
    }
    tris[3 * nt] = a;
    tris[3 * nt + 1] = b;
    tris[3 * nt + 2] = c;
    nt++;
}

static void tet(const uint64_t *v)
{
    int in[4], n = 0;
    for (int i = 0; i < 4; i++)
        n += in[i] = val[v[i]] < 0;
    if (n == 0 || n == 4)
        return;
    int a[4], na = 0, b[4], nb = 0;
    for (int i = 0; i < 4; i++) {
        if (in[i]) a[na++] = i; else b[nb++] = i;
    }
    if (n == 1 || n == 3) {
        const int *one = n == 1 ? a : b, *rest = n == 1 ? b : a;
        uint32_t e0 = edge_vertex(v[one[0]], v[rest[0]]);
        uint32_t e1 = edge_vertex(v[one[0]], v[rest[1]]);
        uint32_t e2 = edge_vertex(v[one[0]], v[rest[2]]);
        tri(e0, e1, e2);
    } else {
        uint32_t e0 = edge_vertex(v[a[0]], v[b[0]]);
        uint32_t e1 = edge_vertex(v[a[0]], v[b[1]]);
        uint32_t e2 = edge_vertex(v[a[1]], v[b[1]]);
        uint32_t e3 = edge_vertex(v[a[1]], v[b[0]]);
        tri(e0, e1, e2);
        tri(e0, e2, e3);
    }
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return 2;
    N = atoi(argv[1]);
    size_t nc = (size_t)(N + 1) * (N + 1) * (N + 1);
    val = malloc(nc * sizeof *val);
    for (int k = 0; k <= N; k++)
        for (int j = 0; j <= N; j++)
            for (int i = 0; i <= N; i++) {
                float f = (float)field(i, j, k);
                val[cid(i, j, k)] = f == 0 ? 1e-7f : f;
            }
    hcap = 1;
    while (hcap < 64u * (uint32_t)N * (uint32_t)N)
        hcap *= 2;
    hk = malloc(hcap * sizeof *hk);
    hv = malloc(hcap * sizeof *hv);
    memset(hk, 0xff, hcap * sizeof *hk);
    vcap = 1 << 16;
    pos = malloc(3 * (size_t)vcap * sizeof *pos);
    tcap = 1 << 16;
    tris = malloc(3 * tcap * sizeof *tris);
    static const int tets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                   {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) {
                uint64_t c[8];
                for (int q = 0; q < 8; q++)
                    c[q] = cid(i + (q & 1), j + (q >> 1 & 1), k + (q >> 2 & 1));
                for (int t = 0; t < 6; t++) {
                    uint64_t v[4] = {c[tets[t][0]], c[tets[t][1]],
                                     c[tets[t][2]], c[tets[t][3]]};
                    tet(v);
                }
            }
    FILE *f = fopen(argv[2], "wb");
    fprintf(f, "ply\nformat binary_little_endian 1.0\ncomment marching "
               "tetrahedra of bench/simplify_volume.c, N %d\nelement vertex "
               "%u\nproperty float x\nproperty float y\nproperty float z\n"
               "element face %zu\nproperty list uchar uint vertex_indices\n"
               "end_header\n", N, nv, nt);
    fwrite(pos, 12, nv, f);
    for (size_t t = 0; t < nt; t++) {
        uint8_t three = 3;
        fwrite(&three, 1, 1, f);
        fwrite(tris + 3 * t, 4, 3, f);
    }
    fclose(f);
    printf("%u vertices, %zu triangles\n", nv, nt);
    return 0;
}
