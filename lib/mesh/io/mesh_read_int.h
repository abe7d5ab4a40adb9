/*
 * mesh_read_int.h - what the mesh readers share (private to lib/mesh): a
 * growing mesh under the limits (mesh_grow.c), and the reader of each
 * format, which gv_mesh_read (mesh_read.c) calls.
 */
#ifndef GV_MESH_READ_INT_H
#define GV_MESH_READ_INT_H

#include "mesh/io/mesh_read.h"

struct mesh_grow {
    struct gv_mesh *m;
    const struct gv_mesh_limits *lim;
    uint32_t vcap, tcap;
};

/* Append a vertex / a triangle; -1 with *err (GV_ELIMIT, GV_ENOMEM). */
int mesh_grow_vert(struct mesh_grow *g, float x, float y, float z,
                   struct gv_error *err);
int mesh_grow_tri(struct mesh_grow *g, uint32_t a, uint32_t b, uint32_t c,
                  struct gv_error *err);

/* Reserve room for nv more vertices and nt more triangles after checking
 * the limits (readers that know their counts up front). */
int mesh_grow_reserve(struct mesh_grow *g, uint64_t nv, uint64_t nt,
                      struct gv_error *err);

/* Check every index < nverts: 0, or -1 with GV_ECORRUPT. */
int mesh_check_indices(const struct gv_mesh *m, const char *fmt_name,
                       struct gv_error *err);

/* The readers behind gv_mesh_read (same contract, lim already filled). */
int gv_mesh_read_ply(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err);
int gv_mesh_read_obj(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err);
int gv_mesh_read_glb(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err);

#endif
