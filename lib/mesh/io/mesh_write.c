/*
 * mesh_write.c - the format table, gv_mesh_encode's dispatch to the
 * writer of each format (mesh_glb.c, mesh_qmesh.c, mesh_ply.c,
 * mesh_obj.c), and gzip for quantized-mesh.
 */
#include "mesh/io/mesh_write.h"

#include <string.h>
#include <zlib.h>

#include "mesh/io/mesh_io.h"

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

int gv_mesh_encode(enum gv_mesh_format f, const struct gv_mesh *m,
                   const struct gv_mesh_place *pl, const char *comment,
                   uint8_t **out, size_t *len, struct gv_error *err)
{
    struct mbuf b = {0};
    const char *why = NULL;
    int rc = 0;
    switch (f) {
    case GV_MESH_GLB:
        rc = mesh_write_glb(&b, m, pl, &why);
        break;
    case GV_MESH_QMESH:
        if (!pl)
            return gv_fail(err, GV_EFORMAT, "mesh: a simplified mesh is "
                           "written as glb, ply or obj");
        rc = mesh_write_qmesh(&b, m, pl, &why);
        if (rc == 0 && !b.oom && pl->gzip && gzip_buf(&b) < 0) {
            rc = -1;
            why = "gzip failed";
        }
        break;
    case GV_MESH_PLY:
        mesh_write_ply(&b, m, pl, comment);
        break;
    case GV_MESH_OBJ:
        mesh_write_obj(&b, m, pl, comment);
        break;
    }
    if (rc < 0) {
        free(b.p);
        return gv_fail(err, GV_EINVAL, "mesh: %s", why ? why : "cannot write");
    }
    if (b.oom) {
        free(b.p);
        return gv_fail(err, GV_ENOMEM, "mesh: out of memory writing %u "
                       "triangles", m->ntris);
    }
    *out = b.p;
    *len = b.n;
    return 0;
}
