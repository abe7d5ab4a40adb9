/*
 * mesh_read.c - the format sniffing of gv_mesh_read, which calls the
 * reader of the format (mesh_read_FORMAT.c, declared in mesh_read_int.h);
 * the growing mesh the readers share is mesh_grow.c.
 */
#include "mesh/io/mesh_read.h"

#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_read_int.h"

int gv_mesh_read(const uint8_t *buf, size_t len, enum gv_mesh_in in,
                 const struct gv_mesh_limits *lim, struct gv_mesh *out,
                 struct gv_error *err)
{
    struct gv_mesh_limits l = {0};
    if (lim)
        l = *lim;
    if (!l.max_bytes)
        l.max_bytes = 1ull << 30;
    if (!l.max_verts)
        l.max_verts = 1u << 28;
    if (!l.max_tris)
        l.max_tris = 1u << 28;
    memset(out, 0, sizeof *out);
    if (len > l.max_bytes)
        return gv_fail(err, GV_ELIMIT, "mesh: file of %zu bytes over the "
                       "limit of %llu", len, (unsigned long long)l.max_bytes);
    if (in == GV_MESH_IN_AUTO) {
        if (len >= 3 && memcmp(buf, "ply", 3) == 0)
            in = GV_MESH_IN_PLY;
        else if (len >= 4 && memcmp(buf, "glTF", 4) == 0)
            in = GV_MESH_IN_GLB;
        else
            in = GV_MESH_IN_OBJ;
    }
    int rc;
    switch (in) {
    case GV_MESH_IN_PLY: rc = gv_mesh_read_ply(buf, len, &l, out, err); break;
    case GV_MESH_IN_GLB: rc = gv_mesh_read_glb(buf, len, &l, out, err); break;
    default: rc = gv_mesh_read_obj(buf, len, &l, out, err); break;
    }
    if (rc == 0 && out->ntris == 0)
        rc = gv_fail(err, GV_ECORRUPT, "mesh: no triangles: not a %s mesh, "
                     "or an empty one", in == GV_MESH_IN_PLY ? "PLY" :
                     in == GV_MESH_IN_GLB ? "glTF binary" : "Wavefront OBJ");
    if (rc < 0)
        gv_mesh_free(out);
    return rc;
}
