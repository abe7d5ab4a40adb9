/*
 * mesh_write.h - a mesh (mesh/mesh.h) as a file: glTF 2.0 binary (GLB),
 * Cesium quantized-mesh-1.0, PLY (binary little endian) or OBJ; one writer
 * per format in lib/mesh/io (mesh_glb.c, mesh_qmesh.c, mesh_ply.c,
 * mesh_obj.c), the table and gzip in mesh_write.c.
 *
 * Every format is written to memory, for files and HTTP bodies alike.  A
 * mesh of a height grid (a TIN, a z-field mesh) is written placed
 * (struct gv_mesh_place) and carries the measured maximum error: glTF in
 * asset.extras, quantized-mesh in its metadata extension (id 4), PLY and
 * OBJ in comments.  Positions:
 * glTF is +Y up, so a vertex is (x, height, y), with x east and y south in
 * samples of the level times xy_scale; PLY and OBJ are +Z up: (x, -y,
 * height).  Triangles face up (counter-clockwise seen from above) in every
 * format.  Any other mesh (the simplifier's) is written without a
 * placement: positions and triangles as they are, and no quantized-mesh.
 * docs/MESHES.md is the normative description.
 */
#ifndef GV_MESH_WRITE_H
#define GV_MESH_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "mesh/mesh.h"

enum gv_mesh_format { GV_MESH_GLB, GV_MESH_QMESH, GV_MESH_PLY, GV_MESH_OBJ };

/* Where the mesh lies.  Zero-initialise, then set what is known. */
struct gv_mesh_place {
    uint32_t x0, y0;     /* the grid's first sample in the level */
    uint32_t level;      /* the level (recorded in the metadata only) */
    double xy_scale;     /* units per sample step in x and y; 0 means 1 */
    int has_geo;         /* quantized-mesh: the grid spans these bounds in
                            degrees (WGS84), corner samples on the corners */
    double west, south, east, north;
    int gzip;            /* quantized-mesh: gzip the whole file */
    /* quantized-mesh extensions, written in this order after the edges: */
    int normals;         /* the oct-encoded vertex normals (id 1): unit,
                            area-weighted in each vertex's east-north-up
                            frame; Earth-centred fixed with has_geo, else
                            (east, north, up) = (x, -y, z) */
    const uint8_t *water_mask; /* the water mask (id 2): water_mask_len
                            bytes, 1 (0 land, 255 water) or 256 x 256 (rows
                            north to south); NULL: none */
    size_t water_mask_len;
    const char *metadata_more; /* more members of the metadata JSON (id 4,
                            always written), e.g. "\"available\":[...]",
                            trusted; NULL: none */
};

/* "glb", "qmesh" (or "terrain"), "ply", "obj" -> *f.  Returns 0, or -1
 * for another name. */
int gv_mesh_format_parse(const char *name, enum gv_mesh_format *f);

/* The media type and the file extension (without dot) of a format. */
const char *gv_mesh_format_mime(enum gv_mesh_format f);
const char *gv_mesh_format_ext(enum gv_mesh_format f);

/*
 * Encode m as format f.  pl: m is a grid mesh placed there; NULL: m is
 * written in its own axes, with `comment` (may be NULL; ignored with pl)
 * in the header.  *out is malloc'ed (the caller frees it with free()) and
 * *len set.  Returns 0, or -1 with *err: GV_ENOMEM, GV_EINVAL (a GLB over
 * 4 GiB, gzip failing, a water mask of another length), GV_EFORMAT
 * (quantized-mesh without pl).
 * Thread-safe.
 */
int gv_mesh_encode(enum gv_mesh_format f, const struct gv_mesh *m,
                   const struct gv_mesh_place *pl, const char *comment,
                   uint8_t **out, size_t *len, struct gv_error *err);

#endif
