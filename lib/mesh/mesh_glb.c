/*
 * mesh_glb.c - a TIN as glTF 2.0 binary (GLB): one scene, one node, one
 * triangle primitive with float POSITION (with its min and max, as glTF
 * requires) and uint32 indices.
 *
 * Layout (glTF 2.0 specification, "Binary glTF Layout"): the 12-byte header
 * (magic "glTF", version 2, total length), a JSON chunk padded with spaces
 * to 4 bytes, a BIN chunk padded with zeros.  The JSON is written by hand
 * (a fixed shape, numbers only), and asset.extras holds the measured
 * error, the level and the region.  +Y is up: vertex (x, height, y).
 */
#include <float.h>

#include "mesh/mesh_buf.h"
#include "mesh/mesh_write.h"

int mesh_write_glb(struct mbuf *b, const struct gv_tin *t,
                   const struct gv_mesh_place *pl, const char **why)
{
    double s = pl->xy_scale > 0 ? pl->xy_scale : 1.0;
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX};
    float mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    struct mbuf bin = {0}, js = {0};
    for (uint32_t i = 0; i < t->nverts; i++) {
        float v[3] = {(float)((pl->x0 + (double)t->vx[i]) * s), t->vz[i],
                      (float)((pl->y0 + (double)t->vy[i]) * s)};
        for (int k = 0; k < 3; k++) {
            if (v[k] < mn[k]) mn[k] = v[k];
            if (v[k] > mx[k]) mx[k] = v[k];
            mb_f32(&bin, v[k]);
        }
    }
    size_t pos_len = bin.n;
    for (uint32_t i = 0; i < t->ntris; i++) {
        mb_u32(&bin, t->tris[3 * i]);
        mb_u32(&bin, t->tris[3 * i + 2]);
        mb_u32(&bin, t->tris[3 * i + 1]);
    }
    mb_printf(&js,
              "{\"asset\":{\"version\":\"2.0\",\"generator\":\"gigaview\","
              "\"extras\":{\"maxError\":%.9g,\"level\":%u,"
              "\"region\":[%u,%u,%u,%u],\"xyScale\":%.9g,"
              "\"axes\":\"x east, y height, z south\"}},",
              t->max_error, pl->level, pl->x0, pl->y0, t->width, t->height, s);
    mb_printf(&js, "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                   "\"nodes\":[{\"mesh\":0}],"
                   "\"meshes\":[{\"primitives\":[{\"attributes\":"
                   "{\"POSITION\":0},\"indices\":1,\"mode\":4}]}],");
    if (mesh_glb_finish(b, &js, &bin, pos_len, t->nverts, t->ntris, mn, mx) < 0) {
        *why = "a GLB file holds at most 4 GiB";
        return -1;
    }
    return 0;
}

int mesh_glb_finish(struct mbuf *b, struct mbuf *js, struct mbuf *bin,
                    size_t pos_len, uint32_t nverts, uint32_t ntris,
                    const float mn[3], const float mx[3])
{
    const size_t idx_len = bin->n - pos_len;
    while (bin->n % 4)
        mb_u8(bin, 0);
    mb_printf(js, "\"buffers\":[{\"byteLength\":%zu}],", bin->n);
    mb_printf(js, "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,"
                  "\"byteLength\":%zu,\"target\":34962},"
                  "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu,"
                  "\"target\":34963}],",
              pos_len, pos_len, idx_len);
    mb_printf(js, "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
                  "\"count\":%u,\"type\":\"VEC3\","
                  "\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},",
              nverts, (double)mn[0], (double)mn[1], (double)mn[2],
              (double)mx[0], (double)mx[1], (double)mx[2]);
    mb_printf(js, "{\"bufferView\":1,\"componentType\":5125,\"count\":%u,"
                  "\"type\":\"SCALAR\"}]}",
              3 * ntris);
    while (js->n % 4)
        mb_u8(js, ' ');
    int rc = 0;
    if (js->oom || bin->oom) {
        b->oom = 1;
    } else if (12 + 8 + js->n + 8 + bin->n > UINT32_MAX) {
        rc = -1;
    } else {
        mb_u32(b, 0x46546C67u); /* "glTF" */
        mb_u32(b, 2);
        mb_u32(b, (uint32_t)(12 + 8 + js->n + 8 + bin->n));
        mb_u32(b, (uint32_t)js->n);
        mb_u32(b, 0x4E4F534Au); /* "JSON" */
        mb_put(b, js->p, js->n);
        mb_u32(b, (uint32_t)bin->n);
        mb_u32(b, 0x004E4942u); /* "BIN\0" */
        mb_put(b, bin->p, bin->n);
    }
    free(js->p);
    free(bin->p);
    return rc;
}
