/*
 * route_terrain.c - a Cesium terrain service over a height store:
 *   GET /v1/images/{id}/terrain/layer.json
 *   GET /v1/images/{id}/terrain/{z}/{x}/{y}.terrain
 *
 * The tiles are quantized-mesh-1.0 (lib/mesh/io/mesh_qmesh.c) in Cesium's
 * geographic tiling scheme (EPSG:4326, TMS: two root tiles of 180 degrees
 * side by side, tile y = 0 at the south, 2^(z+1) x 2^z tiles at level z),
 * so that CesiumJS's CesiumTerrainProvider loads them unchanged.
 *
 * Where the store lies (docs/MESHES.md, "Terrain tiles"): the whole of
 * level 0, W x H samples, is the whole world, north up, column 0 at
 * longitude lon0 (a query parameter of both routes, default -180; layer.json
 * passes it on in its tile template).  A global grid (W = 2 (H - 1), like
 * ETOPO5's 4320 x 2161, whose column 0 is at 0 degrees: lon0=0) has its
 * columns every 360 / W degrees, column W wrapping to column 0, and its
 * rows every 180 / (H - 1) degrees from the north pole to the south pole;
 * any other store is stretched corner sample to corner: 360 / (W - 1) and
 * 180 / (H - 1) degrees, and clamped beyond its columns.
 *
 * A tile is a grid of TERRAIN_STEPS + 1 samples a side (the 65 that
 * Cesium's level error assumes), each the bilinear interpolation of the
 * store level whose sample spacing is the largest not above the grid's
 * (a mipmap choice).  Grid points are numbered across the whole level, so
 * a point on the edge of two tiles has the same number, position and
 * height in both.  The grid is meshed by greedy insertion with border
 * vertices first (lib/mesh/tin.h): neighbours choose the same vertices on
 * their shared edge and join without cracks, and the edge index lists of
 * the quantized-mesh name them.  The vertical error bound of level z is
 * terrain_error_scale x 77067 m / 2^z: the scale times Cesium's own
 * geometric error of a level (its levelZeroMaximumGeometricError for two
 * root tiles of 65 samples).
 *
 * Extensions (layer.json lists them; docs/API.md): every tile carries the
 * metadata extension (id 4: JSON with the measured "maxError", and on
 * levels 0, 10, 20 the availability of the ten levels below the tile, as
 * layer.json's metadataAvailability 10 tells CesiumJS and cesium-native
 * to expect); the oct-encoded vertex normals (id 1) when the request asks
 * for "octvertexnormals" (server/terrain_ext.h: the Accept header, or the
 * query's extensions=); the water mask (id 2) when it asks for
 * "watermask" and terrain_water_below names a water height for the store:
 * 256 x 256 samples of the store at the mask's pixel centres, water where
 * below (1 byte when the tile is all land or all water).  The response
 * varies with Accept.
 *
 * Levels: 0 .. maxzoom, the first level whose grid spacing reaches the
 * store's level-0 spacing (Cesium upsamples beyond).  Tiles are gzipped
 * (Content-Encoding: gzip, Vary: Accept-Encoding) when the client accepts
 * gzip, as static terrain servers do; the ETag names the encoding.  Tiles
 * run on the render pool and stay in the output cache like /mesh.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_write.h"
#include "mesh/tin.h"
#include "output_cache.h"
#include "render/height_region.h"
#include "render_call.h"
#include "routes.h"
#include "store/geometry.h"
#include "terrain_ext.h"

#define TERRAIN_STEPS 64u     /* grid steps per tile side */
#define TERRAIN_MAX_ZOOM 24u
/* Cesium's levelZeroMaximumGeometricError for the geographic scheme:
 * maximumRadius * 2 pi * 0.25 / (65 * 2 root tiles), metres. */
#define LEVEL0_ERROR (6378137.0 * 2 * M_PI * 0.25 / (65.0 * 2))
#define TERRAIN_MIME "application/vnd.quantized-mesh"
/* Tiles of levels 0, 10, 20 carry the availability of the ten levels
 * below them (layer.json's metadataAvailability). */
#define AVAILABILITY_LEVELS 10u
#define MASK_SIDE 256u        /* the water mask's samples a side (the spec's) */

/* The store's frame: level 0 is W x H; global stores wrap in x. */
struct frame {
    uint32_t w, h;
    int global;
    double wx, hy;           /* level-0 sample steps across the world */
    double lon0;             /* longitude of column 0 (query lon0) */
    double shift;            /* level-0 columns from 180 W to column 0 */
    uint32_t maxzoom;
};

/* The frame of img, with column 0 at longitude lon0. */
static void frame_of(const struct image *img, double lon0, struct frame *f)
{
    const struct gv_geometry *g = &img->info->geometry;
    f->lon0 = lon0;
    f->w = g->width;
    f->h = g->height;
    f->global = f->h >= 2 && f->w == 2 * (f->h - 1);
    f->wx = f->global ? f->w : (double)f->w - 1;
    f->hy = (double)f->h - 1;
    f->shift = (lon0 + 180.0) * f->wx / 360.0;
    /* first z whose grid step (x and y) is at most one level-0 sample */
    f->maxzoom = 0;
    while (f->maxzoom < TERRAIN_MAX_ZOOM &&
           (f->wx / ((double)TERRAIN_STEPS * (2u << f->maxzoom)) > 1 ||
            f->hy / ((double)TERRAIN_STEPS * (1u << f->maxzoom)) > 1))
        f->maxzoom++;
}

/* The query's lon0 (default -180) into *lon0: 0, or -1 when it is not a
 * number in -360 .. 360. */
static int parse_lon0(struct req *r, double *lon0)
{
    const char *s = http_query(r, "lon0");
    *lon0 = -180.0;
    if (!s)
        return 0;
    char *end;
    *lon0 = strtod(s, &end);
    return end != s && !*end && isfinite(*lon0) && fabs(*lon0) <= 360 ? 0
                                                                       : -1;
}

/* 1 for a height store (filling *hm), 0 for another, -1 out of memory. */
static int height_meta(struct image *img, struct gv_height_meta *hm)
{
    struct gv_decoder *d = image_decoder_get(img);
    if (!d)
        return -1;
    int is = gv_height_meta_get(d, hm);
    image_decoder_put(img, d);
    return is;
}

static double level_error(const struct settings *cfg, uint32_t z)
{
    return cfg->terrain_error_scale * LEVEL0_ERROR / (double)(1u << z);
}

/* ------------------------------------------------------------ layer.json */

enum MHD_Result route_terrain_layer(struct req *r)
{
    enum MHD_Result ret;
    double lon0;
    if (parse_lon0(r, &lon0) < 0)
        return http_send_errorf(r, GV_EINVAL, "terrain: lon0 must be a "
                                "longitude in -360..360");
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    struct gv_height_meta hm;
    struct frame f;
    double water;
    int has_water = settings_water_below(r->srv->cfg->terrain_water_below,
                                         img->id, &water) > 0;
    int is = height_meta(img, &hm);
    if (is <= 0) {
        ret = is < 0 ? http_send_errorf(r, GV_ENOMEM, "terrain: out of memory")
                     : http_send_errorf(r, GV_EINVAL, "terrain: %s is not a "
                                        "height store", img->id);
        goto out;
    }
    frame_of(img, lon0, &f);
    char canon[128], etag[OUTPUT_ETAG_SIZE], tiles[96];
    snprintf(canon, sizeof canon, "terrain-layer %.17g %.17g w%d %.17g",
             r->srv->cfg->terrain_error_scale, lon0, has_water,
             has_water ? water : 0.0);
    if (http_query(r, "lon0"))
        snprintf(tiles, sizeof tiles, "{z}/{x}/{y}.terrain?v={version}"
                 "&lon0=%.17g", lon0);
    else
        snprintf(tiles, sizeof tiles, "{z}/{x}/{y}.terrain?v={version}");
    output_cache_etag(img->identity, canon, etag, sizeof etag);
    if (http_etag_listed(http_header(r, "If-None-Match"), etag)) {
        ret = http_send_empty(r, 304, MHD_HTTP_HEADER_ETAG, etag);
        goto out;
    }
    json_t *avail = json_array();
    for (uint32_t z = 0; avail && z <= f.maxzoom; z++)
        json_array_append_new(avail, json_pack(
            "[{s:i, s:i, s:I, s:I}]", "startX", 0, "startY", 0,
            "endX", (json_int_t)(2u << z) - 1, "endY",
            (json_int_t)(1u << z) - 1));
    json_t *errs = json_array();
    for (uint32_t z = 0; errs && z <= f.maxzoom; z++)
        json_array_append_new(errs, json_real(level_error(r->srv->cfg, z)));
    json_t *exts = has_water ? json_pack("[s,s,s]", "octvertexnormals",
                                         "watermask", "metadata")
                             : json_pack("[s,s]", "octvertexnormals",
                                         "metadata");
    json_t *j = json_pack(
        "{s:s, s:s, s:s, s:s, s:s, s:s, s:s, s:[s], s:s, s:[f,f,f,f], "
        "s:o, s:i, s:i, s:o, s:i, s:{s:s, s:o, s:f, s:f, s:f, s:i, s:b, s:f}}",
        "tilejson", "2.1.0", "name", img->id, "description",
        "gigaview height store as quantized-mesh tiles (docs/MESHES.md)",
        "version", "1.0.0", "format", "quantized-mesh-1.0", "attribution", "",
        "scheme", "tms", "tiles", tiles,
        "projection", "EPSG:4326", "bounds", -180.0, -90.0, 180.0, 90.0,
        "available", avail, "minzoom", 0, "maxzoom", (int)f.maxzoom,
        "extensions", exts, "metadataAvailability", (int)AVAILABILITY_LEVELS,
        "gigaview", "unit", hm.unit, "maxError", errs,
        "heightMin", hm.min, "heightMax", hm.max, "storeMaxError",
        hm.max_error, "gridSteps", (int)TERRAIN_STEPS, "global", f.global,
        "lon0", lon0);
    if (j && has_water)
        json_object_set_new(json_object_get(j, "gigaview"), "waterBelow",
                            json_real(water));
    size_t len;
    struct MHD_Response *resp = http_response_json(j, JSON_COMPACT,
                                                   "application/json", &len);
    http_header_etag_hour(resp, etag);
    ret = http_send(r, 200, resp, len);
out:
    image_put(img);
    return ret;
}

/* ------------------------------------------------------------ tiles */

struct tile_query {
    uint32_t z, x, y;        /* TMS */
    int gzip;
    unsigned ext;            /* TERRAIN_EXT_* asked for */
    int water;               /* a water mask: asked for, and configured */
    double water_below;      /* its height */
    struct frame f;
    double max_error;
    uint32_t max_triangles;
    double time_limit;
};

/* Level-0 sample coordinates of point gx, gy of level z's grid of
 * `steps` steps a tile (gy from the north). */
static double grid_px(const struct frame *f, uint32_t z, uint32_t steps,
                      double gx)
{
    return gx * f->wx / ((double)steps * (2u << z)) - f->shift;
}

static double grid_py(const struct frame *f, uint32_t z, uint32_t steps,
                      double gy)
{
    return gy * f->hy / ((double)steps * (1u << z));
}

/* Fill h[n^2] with the tile's heights at points i + off, j + off
 * (0 <= i, j < n) of a grid of `steps` steps a tile side, row 0 north:
 * the mesh's grid is steps = n - 1 = TERRAIN_STEPS, off = 0; the water
 * mask's pixel centres steps = n = MASK_SIDE, off = 0.5.  0, or -1 with
 * *err. */
static int tile_heights(struct gv_decoder *d, const struct image *img,
                        const struct tile_query *q,
                        const struct gv_height_meta *hm, uint32_t steps,
                        uint32_t n, double off, float *h,
                        struct gv_error *err)
{
    const struct gv_geometry *g = &img->info->geometry;
    const struct frame *f = &q->f;
    int last = g->root + g->root_mips - 1, s = 0;
    double step = fmin(f->wx / ((double)steps * (2u << q->z)),
                       f->hy / ((double)steps * (1u << q->z)));
    while (s < last && step >= 2.0) {
        step /= 2;
        s++;
    }
    uint32_t ws, hs;
    if (gv_level_size(g, s, &ws, &hs) < 0)
        return gv_fail(err, GV_EINVAL, "terrain: no level %d", s);
    double sx = (double)ws / f->w, sy = (double)hs / f->h;
    double gx0 = (double)q->x * steps;
    double gy0 = (double)((1u << q->z) - 1 - q->y) * steps;
    /* coordinates in level s of every column and row of the grid */
    double *qx = malloc(n * sizeof *qx), *qy = malloc(n * sizeof *qy);
    uint16_t *codes = NULL;
    int rc = -1;
    if (!qx || !qy) {
        gv_fail(err, GV_ENOMEM, "terrain: out of memory");
        goto out;
    }
    for (uint32_t i = 0; i < n; i++) {
        qx[i] = (grid_px(f, q->z, steps, gx0 + i + off) + 0.5) * sx - 0.5;
        qy[i] = (grid_py(f, q->z, steps, gy0 + i + off) + 0.5) * sy - 0.5;
    }
    /* the rectangle of samples to read: columns bx .. bx+bw-1 (the whole
     * width when a global grid wraps), rows by .. by+bh-1 */
    int64_t cx0 = (int64_t)floor(qx[0]), cx1 = (int64_t)floor(qx[n - 1]) + 1;
    int64_t cy0 = (int64_t)floor(qy[0]), cy1 = (int64_t)floor(qy[n - 1]) + 1;
    if (cy0 < 0) cy0 = 0;
    if (cy1 > (int64_t)hs - 1) cy1 = (int64_t)hs - 1;
    if (cx0 < 0 || cx1 > (int64_t)ws - 1) {
        if (f->global) {
            cx0 = 0;
            cx1 = (int64_t)ws - 1;
        } else {
            if (cx0 < 0) cx0 = 0;
            if (cx1 > (int64_t)ws - 1) cx1 = (int64_t)ws - 1;
        }
    }
    uint32_t bx = (uint32_t)cx0, by = (uint32_t)cy0;
    uint32_t bw = (uint32_t)(cx1 - cx0 + 1), bh = (uint32_t)(cy1 - cy0 + 1);
    codes = malloc((size_t)bw * bh * sizeof *codes);
    if (!codes) {
        gv_fail(err, GV_ENOMEM, "terrain: out of memory");
        goto out;
    }
    if (gv_height_region(d, s, bx, by, bw, bh, codes, err) < 0)
        goto out;
    for (uint32_t j = 0; j < n; j++) {
        double fy = floor(qy[j]), ty = qy[j] - fy;
        int64_t y0 = (int64_t)fy, y1 = y0 + 1;
        y0 = y0 < 0 ? 0 : y0 > (int64_t)hs - 1 ? (int64_t)hs - 1 : y0;
        y1 = y1 < 0 ? 0 : y1 > (int64_t)hs - 1 ? (int64_t)hs - 1 : y1;
        const uint16_t *r0 = codes + (size_t)(y0 - by) * bw;
        const uint16_t *r1 = codes + (size_t)(y1 - by) * bw;
        for (uint32_t i = 0; i < n; i++) {
            double fx = floor(qx[i]), tx = qx[i] - fx;
            int64_t x0 = (int64_t)fx, x1 = x0 + 1;
            if (f->global) {
                x0 = ((x0 % ws) + ws) % ws;
                x1 = ((x1 % ws) + ws) % ws;
            } else {
                x0 = x0 < 0 ? 0 : x0 > (int64_t)ws - 1 ? (int64_t)ws - 1 : x0;
                x1 = x1 < 0 ? 0 : x1 > (int64_t)ws - 1 ? (int64_t)ws - 1 : x1;
            }
            double a = r0[x0 - bx] + tx * ((double)r0[x1 - bx] - r0[x0 - bx]);
            double b = r1[x0 - bx] + tx * ((double)r1[x1 - bx] - r1[x0 - bx]);
            double c = a + ty * (b - a);
            h[(size_t)j * n + i] = (float)(c * hm->scale + hm->offset);
        }
    }
    rc = 0;
out:
    free(qx);
    free(qy);
    free(codes);
    return rc;
}

/* The metadata's "available" member for tile q: for each level z + 1 ..
 * z + AVAILABILITY_LEVELS up to maxzoom, the tile's descendants (one
 * range, TMS), into buf.  Only on levels 0, 10, 20 (else buf is ""). */
static void availability(const struct tile_query *q, char *buf, size_t size)
{
    size_t n = 0;
    buf[0] = 0;
    if (q->z % AVAILABILITY_LEVELS)
        return;
    n += (size_t)snprintf(buf, size, "\"available\":[");
    for (uint32_t k = 1; k <= AVAILABILITY_LEVELS && q->z + k <= q->f.maxzoom;
         k++) {
        unsigned long long x0 = (unsigned long long)q->x << k;
        unsigned long long y0 = (unsigned long long)q->y << k;
        unsigned long long side = 1ull << k;
        if (n < size)
            n += (size_t)snprintf(buf + n, size - n, "%s[{\"startX\":%llu,"
                                  "\"startY\":%llu,\"endX\":%llu,"
                                  "\"endY\":%llu}]", k > 1 ? "," : "", x0,
                                  y0, x0 + side - 1, y0 + side - 1);
    }
    if (n < size)
        snprintf(buf + n, size - n, "]");
}

/* The water mask of tile q into mask[MASK_SIDE^2] (255 water, 0 land,
 * rows north to south), returning its length: MASK_SIDE^2, or 1 when the
 * tile is all land or all water (mask[0]).  0 with *err on failure. */
static size_t water_mask(struct gv_decoder *d, const struct image *img,
                         const struct tile_query *q,
                         const struct gv_height_meta *hm, uint8_t *mask,
                         struct gv_error *err)
{
    const size_t n = (size_t)MASK_SIDE * MASK_SIDE;
    float *h = malloc(n * sizeof *h);
    size_t water = 0;
    if (!h) {
        gv_fail(err, GV_ENOMEM, "terrain: out of memory");
        return 0;
    }
    if (tile_heights(d, img, q, hm, MASK_SIDE, MASK_SIDE, 0.5, h, err) < 0) {
        free(h);
        return 0;
    }
    for (size_t i = 0; i < n; i++) {
        mask[i] = h[i] < q->water_below ? 255 : 0;
        water += mask[i] != 0;
    }
    free(h);
    return water == 0 || water == n ? 1 : n;
}

/* On a render thread: heights, TIN, quantized-mesh. */
static int render_tile(void *arg, struct image *img, uint8_t **out,
                       size_t *len, struct gv_error *err)
{
    const struct tile_query *q = arg;
    const uint32_t n = TERRAIN_STEPS + 1;
    struct gv_decoder *d = image_decoder_get(img);
    struct gv_height_meta hm;
    struct gv_mesh t = {0};
    float *h = malloc((size_t)n * n * sizeof *h);
    uint8_t *mask = q->water ? malloc((size_t)MASK_SIDE * MASK_SIDE) : NULL;
    size_t mask_len = 0;
    /* ten levels of one range each, about 90 bytes a level */
    char avail[AVAILABILITY_LEVELS * 128 + 32];
    int rc = -1;
    if (!d || !h || (q->water && !mask)) {
        gv_fail(err, GV_ENOMEM, "terrain: out of memory");
        goto out;
    }
    if (!gv_height_meta_get(d, &hm)) {
        gv_fail(err, GV_EINVAL, "terrain: %s is not a height store", img->id);
        goto out;
    }
    if (tile_heights(d, img, q, &hm, TERRAIN_STEPS, n, 0, h, err) < 0)
        goto out;
    if (q->water &&
        !(mask_len = water_mask(d, img, q, &hm, mask, err)))
        goto out;
    struct gv_tin_params p = {.max_error = q->max_error,
                              .max_triangles = q->max_triangles,
                              .border_first = 1,
                              .time_limit = q->time_limit};
    if (gv_tin_build(h, n, n, n, &p, &t, err) < 0)
        goto out;
    double side = 180.0 / (double)(1u << q->z);
    struct gv_mesh_place pl = {
        .x0 = q->x * TERRAIN_STEPS, .y0 = q->y * TERRAIN_STEPS, .level = q->z,
        .has_geo = 1, .west = -180.0 + q->x * side, .east = -180.0 + (q->x + 1) * side,
        .south = -90.0 + q->y * side, .north = -90.0 + (q->y + 1) * side,
        .gzip = q->gzip, .normals = !!(q->ext & TERRAIN_EXT_NORMALS),
        .water_mask = mask, .water_mask_len = mask_len};
    availability(q, avail, sizeof avail);
    pl.metadata_more = avail[0] ? avail : NULL;
    rc = gv_mesh_encode(GV_MESH_QMESH, &t, &pl, NULL, out, len, err);
out:
    gv_mesh_free(&t);
    free(h);
    free(mask);
    if (d)
        image_decoder_put(img, d);
    return rc;
}

static void tile_headers(void *arg, struct req *r, struct image *img,
                         struct MHD_Response *resp)
{
    const struct tile_query *q = arg;
    (void)r;
    (void)img;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=86400");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY,
                            "Accept-Encoding, Accept");
    if (q->gzip)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_ENCODING, "gzip");
}

/* Does Accept-Encoding value ae accept gzip (listed without q=0)? */
static int accepts_gzip(const char *ae)
{
    for (const char *p = ae; p && (p = strstr(p, "gzip")); p += 4) {
        if (p > ae && !strchr(" ,", p[-1]))
            continue;
        const char *e = p + 4;
        while (*e == ' ')
            e++;
        if (*e == ',' || !*e)
            return 1;
        if (*e == ';') {
            const char *qv = strstr(e, "q=");
            const char *next = strchr(e, ',');
            if (!qv || (next && qv > next))
                return 1;
            return strtod(qv + 2, NULL) > 0;
        }
    }
    return 0;
}

enum MHD_Result route_terrain_tile(struct req *r)
{
    if (render_call_resumed(r))
        return render_call_finish(r);
    struct tile_query q;
    memset(&q, 0, sizeof q);
    double lon0;
    if (parse_lon0(r, &lon0) < 0)
        return http_send_errorf(r, GV_EINVAL, "terrain: lon0 must be a "
                                "longitude in -360..360");
    const char *ys = r->param[3];
    size_t yl = strlen(ys);
    char ybuf[16];
    if (yl <= 8 || yl - 8 >= sizeof ybuf || strcmp(ys + yl - 8, ".terrain"))
        return http_send_errorf(r, GV_ENOTFOUND, "terrain: a tile is "
                                "{z}/{x}/{y}.terrain");
    memcpy(ybuf, ys, yl - 8);
    ybuf[yl - 8] = 0;
    if (http_parse_u32(r->param[1], TERRAIN_MAX_ZOOM, &q.z) < 0 ||
        http_parse_u32(r->param[2], UINT32_MAX, &q.x) < 0 ||
        http_parse_u32(ybuf, UINT32_MAX, &q.y) < 0)
        return http_send_errorf(r, GV_EINVAL, "terrain: z, x and y must be "
                                "non-negative integers, z at most %u",
                                TERRAIN_MAX_ZOOM);
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    struct gv_height_meta hm;
    int is = height_meta(img, &hm);
    if (is <= 0) {
        image_put(img);
        return is < 0 ? http_send_errorf(r, GV_ENOMEM, "terrain: out of memory")
                      : http_send_errorf(r, GV_EINVAL, "terrain: %s is not a "
                                         "height store", r->param[0]);
    }
    frame_of(img, lon0, &q.f);
    if (q.z > q.f.maxzoom || q.x >= (2u << q.z) || q.y >= (1u << q.z)) {
        image_put(img);
        return http_send_errorf(r, GV_ENOTFOUND, "terrain: no tile %u/%u/%u "
                                "(levels 0..%u, 2^(z+1) x 2^z tiles)", q.z,
                                q.x, q.y, q.f.maxzoom);
    }
    const struct settings *cfg = r->srv->cfg;
    q.gzip = accepts_gzip(http_header(r, "Accept-Encoding"));
    q.ext = terrain_extensions(http_header(r, "Accept"),
                               http_query(r, "extensions"));
    q.water = (q.ext & TERRAIN_EXT_WATERMASK) &&
              settings_water_below(cfg->terrain_water_below, img->id,
                                   &q.water_below) > 0;
    q.max_error = level_error(cfg, q.z);
    q.max_triangles = (uint32_t)cfg->max_mesh_triangles;
    q.time_limit = cfg->mesh_time_limit;
    struct tile_query *arg = malloc(sizeof *arg);
    if (!arg) {
        image_put(img);
        return http_send_errorf(r, GV_ENOMEM, "terrain: out of memory");
    }
    *arg = q;
    char canon[360], key[384], etag[OUTPUT_ETAG_SIZE];
    snprintf(canon, sizeof canon, "terrain/%s/%u/%u/%u e%.17g n%u l%.17g%s%s"
             " w%.17g", img->id, q.z, q.x, q.y, q.max_error, q.max_triangles,
             lon0, q.gzip ? " gz" : "",
             q.ext & TERRAIN_EXT_NORMALS ? " nrm" : "",
             q.water ? q.water_below : NAN);
    snprintf(key, sizeof key, "%llu %s", (unsigned long long)img->serial,
             canon);
    output_cache_etag(img->identity, canon, etag, sizeof etag);
    struct render_spec spec = {
        .module = "terrain", .key = key, .etag = etag, .mime = TERRAIN_MIME,
        .render = render_tile, .headers = tile_headers, .arg = arg};
    return render_call_serve(r, img, &spec);
}
