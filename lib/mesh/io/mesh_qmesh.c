/*
 * mesh_qmesh.c - a grid mesh (mesh/mesh.h: a TIN, a z-field mesh) as a
 * Cesium quantized-mesh-1.0 tile.
 *
 * Layout (the quantized-mesh-1.0 specification, all little endian): an
 * 88-byte header (center, min and max height, bounding sphere, horizon
 * occlusion point, in Earth-centred fixed WGS84 metres); the vertex count
 * and three arrays u, v, height of 16-bit values in 0..32767, each stored
 * as zig-zag coded deltas; the triangle count and the indices, 16-bit (32
 * when over 65536 vertices, after padding to 4 bytes) in high-water-mark
 * coding, which needs the vertices numbered in order of first use; then the
 * indices of the vertices on the west, south, east and north edges (plain,
 * each list sorted along its edge), which Cesium uses to join tiles with
 * skirts.  Then the extensions the place asks for, each an id byte and a
 * 32-bit length: the oct-encoded vertex normals (id 1: two bytes a vertex,
 * in the vertices' order), the water mask (id 2), and always the metadata
 * (id 4: a 32-bit length and JSON with the measured error, and what the
 * caller adds, e.g. tile availability).  u runs west to east, v south to
 * north, so grid row 0 is v = 32767 and triangles are written reversed,
 * counter-clockwise in (u, v).
 *
 * A normal is the sum of the normals of the triangles around the vertex,
 * each as long as twice its area (the cross product of two edges), taken
 * in the vertex's own east-north-up frame (ground distances on WGS84,
 * height up) and turned into Earth-centred fixed axes: a level surface
 * gets the ellipsoid's normal even from a triangle many degrees wide
 * (whose chord would tilt it), and a slope tilts it by its angle; then
 * oct-encoded as CesiumJS's AttributeCompression.octEncode does (8 bits a
 * component).
 *
 * Without has_geo the grid is not on the globe: the header then holds the
 * bounding sphere in grid units and the occlusion point at its centre.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_io.h"

#define QMAX 32767.0

static uint16_t zigzag(int32_t d)
{
    return (uint16_t)(((uint32_t)d << 1) ^ (uint32_t)(d >> 31));
}

/* WGS84 geodetic (degrees, metres) to Earth-centred fixed metres. */
static void ecef(double lon, double lat, double h, double o[3])
{
    const double a = 6378137.0, e2 = 6.69437999014e-3;
    double la = lat * M_PI / 180, lo = lon * M_PI / 180;
    double n = a / sqrt(1 - e2 * sin(la) * sin(la));
    o[0] = (n + h) * cos(la) * cos(lo);
    o[1] = (n + h) * cos(la) * sin(lo);
    o[2] = (n * (1 - e2) + h) * sin(la);
}

/* Cesium's EllipsoidalOccluder.computeMagnitude, in scaled space. */
static double occl_magnitude(const double p[3], const double dir[3])
{
    const double r[3] = {6378137.0, 6378137.0, 6356752.3142451793};
    double s[3] = {p[0] / r[0], p[1] / r[1], p[2] / r[2]};
    double m2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
    double m = sqrt(m2);
    double d[3] = {s[0] / m, s[1] / m, s[2] / m};
    if (m2 < 1) m2 = 1;
    if (m < 1) m = 1;
    double cosa = d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2];
    double cx = d[1] * dir[2] - d[2] * dir[1];
    double cy = d[2] * dir[0] - d[0] * dir[2];
    double cz = d[0] * dir[1] - d[1] * dir[0];
    double sina = sqrt(cx * cx + cy * cy + cz * cz);
    double cosb = 1 / m, sinb = sqrt(m2 - 1) * cosb;
    return 1 / (cosa * cosb - sina * sinb);
}

static void put_index(struct mbuf *b, uint32_t i, int wide)
{
    if (wide)
        mb_u32(b, i);
    else
        mb_u16(b, (uint16_t)i);
}

/* Number the vertices in order of first use (high-water mark): newi[v]
 * is the new number of vertex v, old[k] the vertex numbered k. */
static void number_vertices(const struct gv_mesh *t, uint32_t *newi,
                            uint32_t *old)
{
    uint32_t nv = t->nverts;
    for (uint32_t i = 0; i < nv; i++)
        newi[i] = UINT32_MAX;
    uint32_t k = 0;
    for (uint32_t i = 0; i < 3 * t->ntris; i++) {
        uint32_t v = t->tris[i - i % 3 + (3 - i % 3) % 3];
        if (newi[v] == UINT32_MAX) {
            newi[v] = k;
            old[k++] = v;
        }
    }
    for (uint32_t i = 0; i < nv; i++)
        if (newi[i] == UINT32_MAX) {
            newi[i] = k;
            old[k++] = i;
        }
}

/* The u, v and height arrays (nv each, in the new order) into q. */
static void quantize(const struct gv_mesh *t, const uint32_t *old,
                     uint16_t *q)
{
    uint32_t nv = t->nverts, W = t->width - 1, H = t->height - 1;
    double zr = (double)t->zmax - t->zmin;
    for (uint32_t i = 0; i < nv; i++) {
        uint32_t v = old[i];
        double z = (double)gv_mesh_gz(t, v) - t->zmin;
        q[i] = (uint16_t)lround((double)gv_mesh_gx(t, v) / W * QMAX);
        q[nv + i] = (uint16_t)lround((double)(H - gv_mesh_gy(t, v)) / H * QMAX);
        q[2 * nv + i] = zr > 0 ? (uint16_t)lround(z / zr * QMAX) : 0;
    }
}

/* The header's bounds on the globe: centre, bounding sphere (centre and
 * radius) and horizon occlusion point. */
static void bounds_geo(const struct gv_mesh *t, const struct gv_mesh_place *pl,
                       double center[3], double sphere[3], double *radius,
                       double occl[3])
{
    uint32_t nv = t->nverts, W = t->width - 1, H = t->height - 1;
    double lon0 = pl->west, lat0 = pl->north;
    double dlon = (pl->east - pl->west) / W;
    double dlat = (pl->south - pl->north) / H;
    ecef((pl->west + pl->east) / 2, (pl->south + pl->north) / 2,
         ((double)t->zmin + t->zmax) / 2, center);
    const double r[3] = {6378137.0, 6378137.0, 6356752.3142451793};
    double dir[3] = {center[0] / r[0], center[1] / r[1], center[2] / r[2]};
    double dl = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    double mag = 0;
    int bad = 0;
    for (int j = 0; j < 3; j++)
        dir[j] /= dl;
    for (uint32_t i = 0; i < nv; i++) {
        double p[3];
        ecef(lon0 + dlon * gv_mesh_gx(t, i), lat0 + dlat * gv_mesh_gy(t, i),
             gv_mesh_gz(t, i), p);
        double dx = p[0] - center[0], dy = p[1] - center[1];
        double dz = p[2] - center[2];
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        if (d > *radius) *radius = d;
        double mm = occl_magnitude(p, dir);
        if (!(mm > 0) || !isfinite(mm)) bad = 1;
        else if (mm > mag) mag = mm;
    }
    if (bad) /* over a hemisphere or so: nothing occludes it */
        mag = 1e3;
    for (int j = 0; j < 3; j++) {
        sphere[j] = center[j];
        occl[j] = dir[j] * mag;
    }
}

/* The 88-byte header. */
static void put_header(struct mbuf *b, const struct gv_mesh *t,
                       const struct gv_mesh_place *pl)
{
    uint32_t nv = t->nverts, W = t->width - 1, H = t->height - 1;
    double center[3], sphere[3], radius = 0, occl[3];
    if (pl->has_geo) {
        bounds_geo(t, pl, center, sphere, &radius, occl);
    } else {
        center[0] = (pl->x0 + W / 2.0);
        center[1] = (pl->y0 + H / 2.0);
        center[2] = ((double)t->zmin + t->zmax) / 2;
        for (uint32_t i = 0; i < nv; i++) {
            double dx = pl->x0 + (double)gv_mesh_gx(t, i) - center[0];
            double dy = pl->y0 + (double)gv_mesh_gy(t, i) - center[1];
            double dz = gv_mesh_gz(t, i) - center[2];
            double d = sqrt(dx * dx + dy * dy + dz * dz);
            if (d > radius) radius = d;
        }
        for (int j = 0; j < 3; j++)
            sphere[j] = occl[j] = center[j];
    }
    for (int j = 0; j < 3; j++)
        mb_f64(b, center[j]);
    mb_f32(b, t->zmin);
    mb_f32(b, t->zmax);
    for (int j = 0; j < 3; j++)
        mb_f64(b, sphere[j]);
    mb_f64(b, radius);
    for (int j = 0; j < 3; j++)
        mb_f64(b, occl[j]);
}

/* Edges: west (x = 0), south (y = H), east (x = W), north (y = 0); west
 * and east sorted by v (south to north), south and north by u: one slot
 * per sample along the edge, filled in one pass.  -1 when out of memory. */
static int put_edges(struct mbuf *b, const struct gv_mesh *t,
                     const uint32_t *old, int wide)
{
    uint32_t nv = t->nverts, W = t->width - 1, H = t->height - 1;
    uint32_t side = W > H ? W : H;
    uint32_t *slot = malloc(((size_t)side + 1) * sizeof *slot);
    if (!slot)
        return -1;
    for (int e = 0; e < 4; e++) {
        uint32_t len = (e == 0 || e == 2) ? H : W, cnt = 0;
        for (uint32_t s = 0; s <= len; s++)
            slot[s] = UINT32_MAX;
        for (uint32_t i = 0; i < nv; i++) {
            uint32_t v = old[i], x = gv_mesh_gx(t, v), y = gv_mesh_gy(t, v);
            if (e == 0 && x == 0) slot[H - y] = i;
            else if (e == 1 && y == H) slot[x] = i;
            else if (e == 2 && x == W) slot[H - y] = i;
            else if (e == 3 && y == 0) slot[x] = i;
        }
        for (uint32_t s = 0; s <= len; s++)
            cnt += slot[s] != UINT32_MAX;
        mb_u32(b, cnt);
        for (uint32_t s = 0; s <= len; s++)
            if (slot[s] != UINT32_MAX)
                put_index(b, slot[s], wide);
    }
    free(slot);
    return 0;
}

/* Geodetic longitude and latitude (radians, WGS84) of vertex i, with
 * has_geo; else its grid x and -y scaled by xy_scale (east, north). */
static void vertex_en(const struct gv_mesh *t, const struct gv_mesh_place *pl,
                      uint32_t i, double *e, double *n)
{
    if (pl->has_geo) {
        double W = t->width - 1, H = t->height - 1;
        *e = (pl->west + (pl->east - pl->west) * gv_mesh_gx(t, i) / W) *
             M_PI / 180;
        *n = (pl->north + (pl->south - pl->north) * gv_mesh_gy(t, i) / H) *
             M_PI / 180;
    } else {
        double s = pl->xy_scale > 0 ? pl->xy_scale : 1;
        *e = gv_mesh_gx(t, i) * s;
        *n = -(double)gv_mesh_gy(t, i) * s;
    }
}

/* Vertex j relative to vertex v in v's east-north-up frame, metres:
 * on the globe the east offset is the longitude difference along the
 * parallel halfway between them, the north one along v's meridian
 * (WGS84 radii of curvature at v), so that a level surface is level
 * however large the triangle; off the globe, grid units. */
static void enu_offset(const struct gv_mesh *t, const struct gv_mesh_place *pl,
                       uint32_t v, uint32_t j, double o[3])
{
    double ev, nv, ej, nj;
    vertex_en(t, pl, v, &ev, &nv);
    vertex_en(t, pl, j, &ej, &nj);
    o[2] = (double)gv_mesh_gz(t, j) - gv_mesh_gz(t, v);
    if (!pl->has_geo) {
        o[0] = ej - ev;
        o[1] = nj - nv;
        return;
    }
    const double a = 6378137.0, e2 = 6.69437999014e-3;
    double w = 1 - e2 * sin(nv) * sin(nv);
    double rn = a / sqrt(w), rm = a * (1 - e2) / (w * sqrt(w));
    o[0] = (ej - ev) * rn * cos((nj + nv) / 2);
    o[1] = (nj - nv) * rm;
}

/* One component in -1 .. 1 as CesiumJS's AttributeCompression.toSNorm
 * (rangeMaximum 255). */
static uint8_t snorm8(double v)
{
    v = v < -1 ? -1 : v > 1 ? 1 : v;
    return (uint8_t)lround((v * 0.5 + 0.5) * 255.0);
}

/* The normals extension (id 1) of the vertices numbered old[0 .. nv-1]:
 * at each vertex the sum of its triangles' normals (cross products: twice
 * their areas) in the vertex's east-north-up frame, then turned into
 * Earth-centred fixed axes on the globe.  -1 when out of memory. */
static int put_normals(struct mbuf *b, const struct gv_mesh *t,
                       const struct gv_mesh_place *pl, const uint32_t *old)
{
    uint32_t nv = t->nverts;
    double *n = calloc((size_t)nv * 3, sizeof *n);
    if (!n)
        return -1;
    for (uint32_t k = 0; k < t->ntris; k++) {
        /* in the order written, counter-clockwise seen from above */
        const uint32_t *tr = t->tris + 3 * (size_t)k;
        const uint32_t w[3] = {tr[0], tr[2], tr[1]};
        for (int c = 0; c < 3; c++) {
            double e1[3], e2[3];
            enu_offset(t, pl, w[c], w[(c + 1) % 3], e1);
            enu_offset(t, pl, w[c], w[(c + 2) % 3], e2);
            double *f = n + 3 * (size_t)w[c];
            f[0] += e1[1] * e2[2] - e1[2] * e2[1];
            f[1] += e1[2] * e2[0] - e1[0] * e2[2];
            f[2] += e1[0] * e2[1] - e1[1] * e2[0];
        }
    }
    mb_u8(b, 1);
    mb_u32(b, 2 * nv);
    for (uint32_t i = 0; i < nv; i++) {
        const double *v = n + 3 * (size_t)old[i];
        double x = v[0], y = v[1], z = v[2];
        if (!(fabs(x) + fabs(y) + fabs(z) > 0)) { /* in no triangle: up */
            x = y = 0;
            z = 1;
        }
        if (pl->has_geo) { /* east, north, up to Earth-centred fixed */
            double lo, la;
            vertex_en(t, pl, old[i], &lo, &la);
            double so = sin(lo), co = cos(lo), sa = sin(la), ca = cos(la);
            double gx = -so * x - sa * co * y + ca * co * z;
            double gy = co * x - sa * so * y + ca * so * z;
            double gz = ca * y + sa * z;
            x = gx;
            y = gy;
            z = gz;
        }
        double l1 = fabs(x) + fabs(y) + fabs(z);
        double ox = x / l1, oy = y / l1;
        if (z < 0) {
            double tx = ox;
            ox = (1 - fabs(oy)) * (tx < 0 ? -1 : 1);
            oy = (1 - fabs(tx)) * (oy < 0 ? -1 : 1);
        }
        mb_u8(b, snorm8(ox));
        mb_u8(b, snorm8(oy));
    }
    free(n);
    return 0;
}

int mesh_write_qmesh(struct mbuf *b, const struct gv_mesh *t,
                     const struct gv_mesh_place *pl, const char **why)
{
    uint32_t nv = t->nverts;
    uint32_t *newi = malloc((size_t)nv * sizeof *newi);
    uint32_t *old = malloc((size_t)nv * sizeof *old);
    uint16_t *q = malloc((size_t)nv * 3 * sizeof *q);
    int rc = 0;
    if (!newi || !old || !q) {
        b->oom = 1;
        goto out;
    }
    number_vertices(t, newi, old);
    quantize(t, old, q);
    put_header(b, t, pl);

    /* vertex data */
    mb_u32(b, nv);
    for (int a = 0; a < 3; a++) {
        int32_t prev = 0;
        for (uint32_t i = 0; i < nv; i++) {
            int32_t cur = q[(size_t)a * nv + i];
            mb_u16(b, zigzag(cur - prev));
            prev = cur;
        }
    }

    /* indices, high-water mark */
    int wide = nv > 65536;
    if (wide)
        while (b->n % 4)
            mb_u8(b, 0);
    mb_u32(b, t->ntris);
    uint32_t highest = 0;
    for (uint32_t i = 0; i < 3 * t->ntris; i++) {
        uint32_t v = newi[t->tris[i - i % 3 + (3 - i % 3) % 3]];
        put_index(b, highest - v, wide);
        if (v == highest)
            highest++;
    }
    if (put_edges(b, t, old, wide) < 0) {
        b->oom = 1;
        goto out;
    }

    if (pl->normals && put_normals(b, t, pl, old) < 0) {
        b->oom = 1;
        goto out;
    }
    if (pl->water_mask) {
        if (pl->water_mask_len != 1 && pl->water_mask_len != 256 * 256) {
            *why = "a water mask is 1 or 65536 bytes";
            rc = -1;
            goto out;
        }
        mb_u8(b, 2);
        mb_u32(b, (uint32_t)pl->water_mask_len);
        mb_put(b, pl->water_mask, pl->water_mask_len);
    }

    /* metadata extension (id 4): JSON */
    char json[256];
    int jn = snprintf(json, sizeof json,
                      "{\"maxError\":%.9g,\"level\":%u,"
                      "\"region\":[%u,%u,%u,%u]",
                      t->max_error, pl->level, pl->x0, pl->y0, t->width,
                      t->height);
    size_t more = pl->metadata_more ? strlen(pl->metadata_more) : 0;
    if (jn < 0 || (size_t)jn >= sizeof json || more > UINT32_MAX / 2) {
        *why = "metadata too long";
        rc = -1;
        goto out;
    }
    uint32_t total = (uint32_t)jn + (more ? 1 + (uint32_t)more : 0) + 1;
    mb_u8(b, 4);
    mb_u32(b, 4 + total);
    mb_u32(b, total);
    mb_put(b, json, (size_t)jn);
    if (more) {
        mb_u8(b, ',');
        mb_put(b, pl->metadata_more, more);
    }
    mb_u8(b, '}');
out:
    free(newi);
    free(old);
    free(q);
    return rc;
}
