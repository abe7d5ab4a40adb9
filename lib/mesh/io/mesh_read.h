/*
 * mesh_read.h - arbitrary triangle meshes read from outside files: PLY
 * (ascii and binary little endian), Wavefront OBJ (v and f records) and
 * glTF 2.0 binary (GLB), for `gigaview simplify` and POST
 * /v1/meshes/simplify (docs/MESHES.md, "Simplification").  The sniffing is
 * mesh_read.c; each format's reader is mesh_read_FORMAT.c, declared in
 * mesh_read_int.h so that the readers never see gv_mesh_read.
 *
 * Every reader is a parser of outside input: it never reads past the
 * buffer, checks every count against the limits before it allocates, and
 * returns GV_ELIMIT past a limit and GV_ECORRUPT for a malformed file.
 * Polygons are fanned into triangles (v0, vi, vi+1); positions keep the
 * file's axes.  Faces whose indices repeat stay (the simplifier drops
 * them); an index outside the vertices is an error.
 */
#ifndef GV_MESH_READ_H
#define GV_MESH_READ_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "mesh/mesh.h"


/* Limits on what a reader accepts; 0 in a field means the default. */
struct gv_mesh_limits {
    uint64_t max_bytes;    /* the file (default 1 GiB) */
    uint32_t max_verts;    /* default 2^28 */
    uint32_t max_tris;     /* triangles after fanning (default 2^28) */
};

enum gv_mesh_in { GV_MESH_IN_AUTO, GV_MESH_IN_PLY, GV_MESH_IN_OBJ,
                  GV_MESH_IN_GLB };

/*
 * Parse the file in buf[0 .. len-1] (no terminator needed) as format `in`
 * (GV_MESH_IN_AUTO: "ply" at the start is PLY, "glTF" GLB, anything else
 * OBJ) into *out, a mesh in the file's axes with no grid (width and
 * height 0; free with gv_mesh_free).  Returns 0, or -1 with *err:
 * GV_ECORRUPT (malformed, or no triangle at all; the message says where),
 * GV_EFORMAT (valid but unsupported: big-endian PLY, sparse or external
 * glTF buffers), GV_ELIMIT, GV_ENOMEM.  Thread-safe.
 */
int gv_mesh_read(const uint8_t *buf, size_t len, enum gv_mesh_in in,
                 const struct gv_mesh_limits *lim, struct gv_mesh *out,
                 struct gv_error *err);

#endif
