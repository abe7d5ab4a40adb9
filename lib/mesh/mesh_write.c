/*
 * mesh_write.c - the format table, PLY and OBJ, and gzip for
 * quantized-mesh.  glTF binary is in mesh_glb.c, quantized-mesh in
 * mesh_qmesh.c.
 *
 * PLY is binary little endian (float x, y, z; uchar-counted uint lists)
 * and OBJ plain text with 1-based indices; both name the measured error,
 * the level and the region in their header comments, where tools such as
 * MeshLab and Blender ignore them.
 */
#include "mesh/mesh_write.h"

#include <string.h>
#include <zlib.h>

#include "mesh/mesh_buf.h"

static const struct {
    const char *name;
    enum gv_mesh_format f;
} names[] = {
    {"glb", GV_MESH_GLB}, {"qmesh", GV_MESH_QMESH}, {"terrain", GV_MESH_QMESH},
    {"ply", GV_MESH_PLY}, {"obj", GV_MESH_OBJ},
};

int gv_mesh_format_parse(const char *name, enum gv_mesh_format *f)
{
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(name, names[i].name) == 0) {
            *f = names[i].f;
            return 0;
        }
    return -1;
}

const char *gv_mesh_format_mime(enum gv_mesh_format f)
{
    switch (f) {
    case GV_MESH_GLB: return "model/gltf-binary";
    case GV_MESH_QMESH: return "application/vnd.quantized-mesh";
    case GV_MESH_PLY: return "application/x-ply";
    case GV_MESH_OBJ: return "model/obj";
    }
    return "application/octet-stream";
}

const char *gv_mesh_format_ext(enum gv_mesh_format f)
{
    switch (f) {
    case GV_MESH_GLB: return "glb";
    case GV_MESH_QMESH: return "terrain";
    case GV_MESH_PLY: return "ply";
    case GV_MESH_OBJ: return "obj";
    }
    return "bin";
}

static double scale_of(const struct gv_mesh_place *pl)
{
    return pl->xy_scale > 0 ? pl->xy_scale : 1.0;
}

static void write_ply(struct mbuf *b, const struct gv_tin *t,
                      const struct gv_mesh_place *pl)
{
    double s = scale_of(pl);
    mb_printf(b, "ply\nformat binary_little_endian 1.0\n"
                 "comment gigaview TIN by greedy insertion\n"
                 "comment max_error %.9g\n"
                 "comment level %u region %u,%u,%u,%u xy_scale %.9g\n"
                 "comment axes x east, y north, z height\n"
                 "element vertex %u\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "element face %u\n"
                 "property list uchar uint vertex_indices\n"
                 "end_header\n",
              t->max_error, pl->level, pl->x0, pl->y0, t->width, t->height, s,
              t->nverts, t->ntris);
    for (uint32_t i = 0; i < t->nverts; i++) {
        mb_f32(b, (float)((pl->x0 + (double)t->vx[i]) * s));
        mb_f32(b, (float)(-(pl->y0 + (double)t->vy[i]) * s));
        mb_f32(b, t->vz[i]);
    }
    for (uint32_t i = 0; i < t->ntris; i++) {
        mb_u8(b, 3);
        mb_u32(b, t->tris[3 * i]);
        mb_u32(b, t->tris[3 * i + 2]);
        mb_u32(b, t->tris[3 * i + 1]);
    }
}

static void write_obj(struct mbuf *b, const struct gv_tin *t,
                      const struct gv_mesh_place *pl)
{
    double s = scale_of(pl);
    mb_printf(b, "# gigaview TIN by greedy insertion\n"
                 "# max_error %.9g\n"
                 "# level %u region %u,%u,%u,%u xy_scale %.9g\n"
                 "# axes x east, y north, z height\n"
                 "# %u vertices, %u triangles\n",
              t->max_error, pl->level, pl->x0, pl->y0, t->width, t->height, s,
              t->nverts, t->ntris);
    for (uint32_t i = 0; i < t->nverts; i++)
        mb_printf(b, "v %.9g %.9g %.9g\n", (pl->x0 + (double)t->vx[i]) * s,
                  -(pl->y0 + (double)t->vy[i]) * s, (double)t->vz[i]);
    for (uint32_t i = 0; i < t->ntris; i++)
        mb_printf(b, "f %u %u %u\n", t->tris[3 * i] + 1,
                  t->tris[3 * i + 2] + 1, t->tris[3 * i + 1] + 1);
}

static int gzip_buf(struct mbuf *b)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    if (deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) !=
        Z_OK)
        return -1;
    uLong cap = deflateBound(&z, (uLong)b->n) + 32;
    uint8_t *o = malloc(cap);
    if (!o) {
        deflateEnd(&z);
        return -1;
    }
    z.next_in = b->p;
    z.avail_in = (uInt)b->n;
    z.next_out = o;
    z.avail_out = (uInt)cap;
    int rc = deflate(&z, Z_FINISH);
    size_t n = z.total_out;
    deflateEnd(&z);
    if (rc != Z_STREAM_END) {
        free(o);
        return -1;
    }
    free(b->p);
    b->p = o;
    b->n = n;
    b->cap = cap;
    return 0;
}

int gv_mesh_encode(enum gv_mesh_format f, const struct gv_tin *t,
                   const struct gv_mesh_place *pl, uint8_t **out, size_t *len,
                   struct gv_error *err)
{
    struct mbuf b = {0};
    const char *why = NULL;
    int rc = 0;
    switch (f) {
    case GV_MESH_GLB:
        rc = mesh_write_glb(&b, t, pl, &why);
        break;
    case GV_MESH_QMESH:
        rc = mesh_write_qmesh(&b, t, pl, &why);
        if (rc == 0 && !b.oom && pl->gzip && gzip_buf(&b) < 0) {
            rc = -1;
            why = "gzip failed";
        }
        break;
    case GV_MESH_PLY:
        write_ply(&b, t, pl);
        break;
    case GV_MESH_OBJ:
        write_obj(&b, t, pl);
        break;
    }
    if (rc < 0) {
        free(b.p);
        return gv_fail(err, GV_EINVAL, "mesh: %s", why ? why : "cannot write");
    }
    if (b.oom) {
        free(b.p);
        return gv_fail(err, GV_ENOMEM, "mesh: out of memory writing %u "
                       "triangles", t->ntris);
    }
    *out = b.p;
    *len = b.n;
    return 0;
}
