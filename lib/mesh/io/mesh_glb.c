/*
 * mesh_glb.c - a mesh as glTF 2.0 binary (GLB): one scene, one node, one
 * triangle primitive with float POSITION (with its min and max, as glTF
 * requires) and uint32 indices.
 *
 * Layout (glTF 2.0 specification, "Binary glTF Layout"): the 12-byte header
 * (magic "glTF", version 2, total length), a JSON chunk padded with spaces
 * to 4 bytes, a BIN chunk padded with zeros.  The JSON is written by hand
 * (a fixed shape, numbers only).  A placed grid mesh has the measured
 * error, the level and the region in asset.extras, and +Y up: vertex
 * (x, height, y); any other mesh keeps its positions.
 */
#include <float.h>

#include "mesh/io/mesh_io.h"

/*
 * The end of the GLB: *js holds the JSON up to its buffers, *bin nverts
 * float VEC3 positions (the first pos_len bytes, with their min mn and max
 * mx) and then the uint32 indices.  Appends the buffers, bufferViews and
 * accessors, closes the JSON, and writes the GLB container to *b; frees
 * js and bin.  Returns 0, or -1 past GLB's 4 GiB; b->oom is set when a
 * chunk ran out of memory.
 */
static int glb_finish(struct mbuf *b, struct mbuf *js, struct mbuf *bin,
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

/* Vertex i of m as written: a placed grid mesh +Y up, else as it is. */
static void vertex_yup(const struct gv_mesh *m, const struct gv_mesh_place *pl,
                       uint32_t i, float v[3])
{
    const float *p = m->pos + 3 * (size_t)i;
    if (pl) {
        double s = mesh_scale(pl);
        v[0] = (float)((pl->x0 + (double)p[0]) * s);
        v[1] = p[2];
        v[2] = (float)((pl->y0 + (double)p[1]) * s);
    } else {
        for (int k = 0; k < 3; k++)
            v[k] = p[k];
    }
}

/* The JSON up to its buffers. */
static void put_json_head(struct mbuf *js, const struct gv_mesh *m,
                          const struct gv_mesh_place *pl)
{
    if (pl)
        mb_printf(js,
                  "{\"asset\":{\"version\":\"2.0\",\"generator\":\"gigaview\","
                  "\"extras\":{\"maxError\":%.9g,\"level\":%u,"
                  "\"region\":[%u,%u,%u,%u],\"xyScale\":%.9g,"
                  "\"axes\":\"x east, y height, z south\"}},",
                  m->max_error, pl->level, pl->x0, pl->y0, m->width,
                  m->height, mesh_scale(pl));
    else
        mb_printf(js, "{\"asset\":{\"version\":\"2.0\",\"generator\":"
                      "\"gigaview simplify\"},");
    mb_printf(js, "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                  "\"nodes\":[{\"mesh\":0}],"
                  "\"meshes\":[{\"primitives\":[{\"attributes\":"
                  "{\"POSITION\":0},\"indices\":1,\"mode\":4}]}],");
}

int mesh_write_glb(struct mbuf *b, const struct gv_mesh *m,
                   const struct gv_mesh_place *pl, const char **why)
{
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX};
    float mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    struct mbuf bin = {0}, js = {0};
    for (uint32_t i = 0; i < m->nverts; i++) {
        float v[3];
        vertex_yup(m, pl, i, v);
        for (int k = 0; k < 3; k++) {
            if (v[k] < mn[k]) mn[k] = v[k];
            if (v[k] > mx[k]) mx[k] = v[k];
            mb_f32(&bin, v[k]);
        }
    }
    if (!m->nverts && !pl)
        for (int k = 0; k < 3; k++)
            mn[k] = mx[k] = 0;
    size_t pos_len = bin.n;
    for (uint32_t i = 0; i < m->ntris; i++)
        for (int k = 0; k < 3; k++)
            mb_u32(&bin, mesh_corner(m, pl, i, k));
    put_json_head(&js, m, pl);
    if (glb_finish(b, &js, &bin, pos_len, m->nverts, m->ntris, mn, mx) < 0) {
        *why = "a GLB file holds at most 4 GiB";
        return -1;
    }
    return 0;
}
