/*
 * test_tin_io.c - the mesh writers (lib/mesh/io/mesh_write.h) read back.
 *
 * A small TIN is written in every format and parsed again by the minimal
 * readers below, written from the format specifications and not from the
 * writers: GLB (header, chunk lengths and alignment, the JSON's counts and
 * bounds, positions and indices from the BIN chunk), quantized-mesh-1.0
 * (zig-zag deltas, high-water-mark indices, the four edge lists, the
 * metadata extension; also gzip'ed), PLY and OBJ.  Each must give back the
 * same vertices, the same triangles facing up, and the measured error.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "mesh/io/mesh_write.h"
#include "mesh/tin.h"
#include "util.h"

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}

static uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

static float rdf(const uint8_t *p)
{
    uint32_t v = rd32(p);
    float f;
    memcpy(&f, &v, 4);
    return f;
}

static double rdd(const uint8_t *p)
{
    uint64_t v = rd32(p) | (uint64_t)rd32(p + 4) << 32;
    double d;
    memcpy(&d, &v, 8);
    return d;
}

/* Does the set of triangles (a, b, c) of the file, as vertex positions,
 * equal the TIN's with the winding reversed (a, c, b)?  Positions are
 * compared through map[file vertex] = tin vertex. */
static int same_tris(const struct gv_mesh *t, const uint32_t *idx,
                     const uint32_t *map)
{
    for (uint32_t i = 0; i < t->ntris; i++) {
        const uint32_t *v = t->tris + 3 * i;
        if (map[idx[3 * i]] != v[0] || map[idx[3 * i + 1]] != v[2] ||
            map[idx[3 * i + 2]] != v[1])
            return 0;
    }
    return 1;
}

static void test_glb(const struct gv_mesh *t, const struct gv_mesh_place *pl)
{
    uint8_t *b;
    size_t n;
    struct gv_error err = {0};
    check(gv_mesh_encode(GV_MESH_GLB, t, pl, NULL, &b, &n, &err) == 0, "glb: wrote");
    check(n >= 28 && rd32(b) == 0x46546C67u && rd32(b + 4) == 2 &&
          rd32(b + 8) == n, "glb: header, version 2, length %zu", n);
    uint32_t jl = rd32(b + 12);
    check(rd32(b + 16) == 0x4E4F534Au && jl % 4 == 0 && 20 + jl + 8 <= n,
          "glb: JSON chunk of %u bytes, 4-aligned", jl);
    char *js = malloc(jl + 1);
    memcpy(js, b + 20, jl);
    js[jl] = 0;
    const uint8_t *bc = b + 20 + jl;
    uint32_t bl = rd32(bc);
    check(rd32(bc + 4) == 0x004E4942u && 20 + jl + 8 + bl == n && bl % 4 == 0,
          "glb: BIN chunk of %u bytes ends the file", bl);
    char want[96];
    snprintf(want, sizeof want, "\"maxError\":%.9g", t->max_error);
    check(strstr(js, want) != NULL, "glb: asset.extras holds %s", want);
    snprintf(want, sizeof want, "\"count\":%u,\"type\":\"VEC3\"", t->nverts);
    char want2[64];
    snprintf(want2, sizeof want2, "\"count\":%u,\"type\":\"SCALAR\"",
             3 * t->ntris);
    check(strstr(js, want) && strstr(js, want2) &&
          strstr(js, "\"version\":\"2.0\""), "glb: accessors count %u "
          "positions and %u indices", t->nverts, 3 * t->ntris);
    const uint8_t *bin = bc + 8;
    int ok = 1;
    for (uint32_t i = 0; i < t->nverts; i++) {
        ok &= rdf(bin + 12 * i) == (float)(pl->x0 + gv_mesh_gx(t, i)) &&
              rdf(bin + 12 * i + 4) == gv_mesh_gz(t, i) &&
              rdf(bin + 12 * i + 8) == (float)(pl->y0 + gv_mesh_gy(t, i));
    }
    check(ok, "glb: positions (x, height, y)");
    uint32_t *idx = malloc((size_t)t->ntris * 3 * 4), *map;
    map = malloc((size_t)t->nverts * 4);
    for (uint32_t i = 0; i < 3 * t->ntris; i++)
        idx[i] = rd32(bin + 12 * t->nverts + 4 * i);
    for (uint32_t i = 0; i < t->nverts; i++)
        map[i] = i;
    check(same_tris(t, idx, map), "glb: indices, counter-clockwise from +Y");
    /* up: the cross product of the first triangle's edges points to +Y */
    const uint8_t *p0 = bin + 12 * idx[0], *p1 = bin + 12 * idx[1],
                  *p2 = bin + 12 * idx[2];
    double ux = rdf(p1) - rdf(p0), uz = rdf(p1 + 8) - rdf(p0 + 8);
    double vx = rdf(p2) - rdf(p0), vz = rdf(p2 + 8) - rdf(p0 + 8);
    check(uz * vx - ux * vz > 0, "glb: triangles face +Y");
    free(idx);
    free(map);
    free(js);
    free(b);
}

static int unzig(uint16_t v) { return (v >> 1) ^ -(int)(v & 1); }

/* Decode a quantized-mesh tile and compare it with t. */
static void check_qmesh(const struct gv_mesh *t, const uint8_t *b, size_t n,
                        const char *what)
{
    check(n > 92, "%s: longer than the header", what);
    float zmin = rdf(b + 24), zmax = rdf(b + 28);
    check(zmin == t->zmin && zmax == t->zmax && rdd(b + 56) > 0,
          "%s: header heights %g..%g, radius %g", what, (double)zmin,
          (double)zmax, rdd(b + 56));
    uint32_t nv = rd32(b + 88);
    check(nv == t->nverts, "%s: %u vertices", what, nv);
    const uint8_t *p = b + 92;
    int32_t *q = malloc((size_t)nv * 3 * sizeof *q);
    for (int a = 0; a < 3; a++) {
        int32_t acc = 0;
        for (uint32_t i = 0; i < nv; i++) {
            acc += unzig(rd16(p));
            p += 2;
            q[(size_t)a * nv + i] = acc;
        }
    }
    /* map file vertex -> tin vertex by its grid position */
    uint32_t W = t->width - 1, H = t->height - 1;
    uint32_t *map = malloc((size_t)nv * 4);
    int ok = 1;
    for (uint32_t i = 0; i < nv; i++) {
        map[i] = UINT32_MAX;
        for (uint32_t v = 0; v < t->nverts; v++)
            if (lround((double)gv_mesh_gx(t, v) / W * 32767) == q[i] &&
                lround((double)(H - gv_mesh_gy(t, v)) / H * 32767) == q[nv + i])
                map[i] = v;
        ok &= map[i] != UINT32_MAX && q[i] >= 0 && q[i] <= 32767;
        if (map[i] != UINT32_MAX) {
            double z = zmin + (zmax - zmin) * q[2 * nv + i] / 32767.0;
            ok &= fabs(z - gv_mesh_gz(t, map[i])) <= (zmax - zmin) / 32767.0;
        }
    }
    check(ok, "%s: u, v, height of every vertex", what);
    if ((size_t)(p - b) % 2)
        p++;
    uint32_t nt = rd32(p);
    p += 4;
    uint32_t *idx = malloc((size_t)nt * 3 * 4), highest = 0;
    for (uint32_t i = 0; i < 3 * nt; i++) {
        uint16_t code = rd16(p);
        p += 2;
        idx[i] = highest - code;
        if (code == 0)
            highest++;
        ok &= idx[i] < nv;
    }
    check(ok && nt == t->ntris && same_tris(t, idx, map),
          "%s: %u triangles, high-water mark, counter-clockwise in (u, v)",
          what, nt);
    /* edges: west u = 0 ascending v, south v = 0 ascending u, east, north */
    for (int e = 0; e < 4; e++) {
        uint32_t c = rd32(p), want = 0;
        p += 4;
        int good = 1;
        int32_t last = -1;
        for (uint32_t i = 0; i < c; i++) {
            uint32_t k = rd16(p);
            p += 2;
            int32_t u = q[k], v = q[nv + k];
            int on = e == 0 ? u == 0 : e == 1 ? v == 0 : e == 2 ? u == 32767
                                                                 : v == 32767;
            int32_t along = (e == 0 || e == 2) ? v : u;
            good &= on && along > last;
            last = along;
        }
        for (uint32_t v = 0; v < t->nverts; v++)
            want += e == 0 ? gv_mesh_gx(t, v) == 0 : e == 1 ? gv_mesh_gy(t, v) == H
                  : e == 2 ? gv_mesh_gx(t, v) == W : gv_mesh_gy(t, v) == 0;
        check(good && c == want, "%s: edge %d lists its %u vertices in order",
              what, e, c);
    }
    check(p[0] == 4 && rd32(p + 1) == rd32(p + 5) + 4 &&
          p + 9 + rd32(p + 5) == b + n, "%s: metadata extension ends the file",
          what);
    char want[64];
    snprintf(want, sizeof want, "\"maxError\":%.9g", t->max_error);
    check(memmem(p + 9, rd32(p + 5), want, strlen(want)) != NULL,
          "%s: metadata holds %s", what, want);
    free(q);
    free(map);
    free(idx);
}

static void test_qmesh(const struct gv_mesh *t, struct gv_mesh_place pl)
{
    uint8_t *b, *z;
    size_t n, zn;
    struct gv_error err = {0};
    pl.has_geo = 1;
    pl.west = 5;
    pl.east = 6;
    pl.south = 45;
    pl.north = 46;
    check(gv_mesh_encode(GV_MESH_QMESH, t, &pl, NULL, &b, &n, &err) == 0,
          "qmesh: wrote");
    check_qmesh(t, b, n, "qmesh");
    /* the centre lies near the surface at 45.5 N, 5.5 E */
    double cx = rdd(b), cy = rdd(b + 8), cz = rdd(b + 16);
    double r = sqrt(cx * cx + cy * cy + cz * cz);
    check(r > 6.36e6 && r < 6.38e6 && cz > 0 && cy > 0,
          "qmesh: centre in ECEF (%.0f m from the Earth's centre)", r);
    pl.gzip = 1;
    check(gv_mesh_encode(GV_MESH_QMESH, t, &pl, NULL, &z, &zn, &err) == 0 &&
          zn > 18 && z[0] == 0x1f && z[1] == 0x8b, "qmesh: gzip'ed");
    uint8_t *u = malloc(n + 16);
    z_stream s;
    memset(&s, 0, sizeof s);
    inflateInit2(&s, 15 + 16);
    s.next_in = z;
    s.avail_in = (uInt)zn;
    s.next_out = u;
    s.avail_out = (uInt)(n + 16);
    int zr = inflate(&s, Z_FINISH);
    check(zr == Z_STREAM_END && s.total_out == n && memcmp(u, b, n) == 0,
          "qmesh: gunzip gives the plain tile");
    inflateEnd(&s);
    free(u);
    free(z);
    free(b);
}

static void test_ply(const struct gv_mesh *t, const struct gv_mesh_place *pl)
{
    uint8_t *b;
    size_t n;
    struct gv_error err = {0};
    check(gv_mesh_encode(GV_MESH_PLY, t, pl, NULL, &b, &n, &err) == 0, "ply: wrote");
    const char *end = memmem(b, n, "end_header\n", 11);
    check(end != NULL, "ply: a header");
    if (!end)
        return;
    char *hdr = strndup((const char *)b, (size_t)(end - (const char *)b));
    unsigned nv = 0, nf = 0;
    const char *ev = strstr(hdr, "element vertex "), *ef = strstr(hdr,
                                                       "element face ");
    if (ev) sscanf(ev, "element vertex %u", &nv);
    if (ef) sscanf(ef, "element face %u", &nf);
    char want[64];
    snprintf(want, sizeof want, "comment max_error %.9g\n", t->max_error);
    check(strncmp(hdr, "ply\nformat binary_little_endian 1.0\n", 36) == 0 &&
          nv == t->nverts && nf == t->ntris && strstr(hdr, want),
          "ply: binary little endian, %u vertices, %u faces, the error", nv,
          nf);
    const uint8_t *p = (const uint8_t *)end + 11;
    check((size_t)(p - b) + 12 * nv + 13 * nf == n, "ply: body length");
    int ok = 1;
    for (uint32_t i = 0; i < nv; i++, p += 12)
        ok &= rdf(p) == (float)(pl->x0 + gv_mesh_gx(t, i)) &&
              rdf(p + 4) == -(float)(pl->y0 + gv_mesh_gy(t, i)) && rdf(p + 8) == gv_mesh_gz(t, i);
    uint32_t *idx = malloc((size_t)nf * 12), *map = malloc((size_t)nv * 4);
    for (uint32_t i = 0; i < nf; i++, p += 13) {
        ok &= p[0] == 3;
        for (int k = 0; k < 3; k++)
            idx[3 * i + k] = rd32(p + 1 + 4 * k);
    }
    for (uint32_t i = 0; i < nv; i++)
        map[i] = i;
    check(ok && same_tris(t, idx, map), "ply: vertices (x, -y, z), faces up");
    free(idx);
    free(map);
    free(hdr);
    free(b);
}

static void test_obj(const struct gv_mesh *t, const struct gv_mesh_place *pl)
{
    uint8_t *b;
    size_t n;
    struct gv_error err = {0};
    check(gv_mesh_encode(GV_MESH_OBJ, t, pl, NULL, &b, &n, &err) == 0, "obj: wrote");
    char *s = strndup((const char *)b, n);
    uint32_t nv = 0, nf = 0;
    uint32_t *idx = malloc((size_t)t->ntris * 12), *map = malloc(
        (size_t)t->nverts * 4);
    int ok = 1;
    char want[64];
    snprintf(want, sizeof want, "# max_error %.9g\n", t->max_error);
    for (char *line = strtok(s, "\n"); line; line = strtok(NULL, "\n")) {
        double x, y, z;
        unsigned a, c, d;
        if (sscanf(line, "v %lf %lf %lf", &x, &y, &z) == 3) {
            ok &= nv < t->nverts && x == pl->x0 + gv_mesh_gx(t, nv) &&
                  y == -(double)(pl->y0 + gv_mesh_gy(t, nv)) && (float)z == gv_mesh_gz(t, nv);
            nv++;
        } else if (sscanf(line, "f %u %u %u", &a, &c, &d) == 3) {
            ok &= nf < t->ntris;
            if (nf < t->ntris) {
                idx[3 * nf] = a - 1;
                idx[3 * nf + 1] = c - 1;
                idx[3 * nf + 2] = d - 1;
            }
            nf++;
        }
    }
    for (uint32_t i = 0; i < t->nverts; i++)
        map[i] = i;
    check(ok && nv == t->nverts && nf == t->ntris && same_tris(t, idx, map),
          "obj: %u vertices, %u faces, 1-based, faces up", nv, nf);
    check(memmem(b, n, want, strlen(want)) != NULL, "obj: comment %s", want);
    free(idx);
    free(map);
    free(s);
    free(b);
}

int main(void)
{
    uint32_t w = 37, h = 29;
    float *f = malloc((size_t)w * h * sizeof *f);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            f[y * w + x] = (float)(300 + 80 * sin(x * 0.3) * cos(y * 0.25) +
                                   (x * 7 + y * 3) % 5);
    struct gv_mesh t;
    struct gv_error err = {0};
    struct gv_tin_params p = {.max_error = 3, .border_first = 1};
    int built = gv_tin_build(f, w, h, w, &p, &t, &err) == 0;
    check(built && t.ntris > 20, "a TIN of %u triangles", t.ntris);
    struct gv_mesh_place pl = {.x0 = 100, .y0 = 40, .level = 2};
    test_glb(&t, &pl);
    test_qmesh(&t, pl);
    test_ply(&t, &pl);
    test_obj(&t, &pl);
    enum gv_mesh_format fmt;
    check(gv_mesh_format_parse("qmesh", &fmt) == 0 && fmt == GV_MESH_QMESH &&
          gv_mesh_format_parse("terrain", &fmt) == 0 &&
          gv_mesh_format_parse("stl", &fmt) < 0, "format names");
    gv_mesh_free(&t);
    free(f);
    return tap_done();
}
