/*
 * mesh.h - the one triangle mesh of lib/mesh: what the TIN (tin.h), the
 * z-field simplifier (zfield.h), the vertex-clustering simplifier
 * (cluster.h) and the readers (io/mesh_read.h) produce, and what the
 * writers (io/mesh_write.h) take.
 *
 * Float positions, three per vertex, and 32-bit indices, three per
 * triangle.  No other attribute (normal, uv) is carried: no producer or
 * format of gigaview has one today; a new one goes here as an optional
 * array (NULL when absent) that every writer skips when NULL.
 *
 * A mesh of a height grid (TIN, z-field) is in grid coordinates: x the
 * column and y the row of a sample (whole numbers, exact in a float up to
 * GV_MESH_MAX_GRID), z its height; its triangles are counter-clockwise in
 * (x, y) with y as a math axis, and width, height, max_error, zmin and
 * zmax describe the grid.  Any other mesh keeps the axes it was read
 * with, and its width and height are 0.
 */
#ifndef GV_MESH_MESH_H
#define GV_MESH_MESH_H

#include <stddef.h>
#include <stdint.h>

/* The largest grid side a mesh holds in grid coordinates: floats are
 * exact integers up to 2^24. */
#define GV_MESH_MAX_GRID (1u << 24)

struct gv_mesh {
    uint32_t nverts, ntris;
    float *pos;              /* 3 * nverts: x, y, z */
    uint32_t *tris;          /* 3 * ntris vertex indices */
    /* a mesh of a height grid only (else 0) */
    uint32_t width, height;  /* the grid in samples */
    double max_error;        /* measured: max over every sample of
                                |height - mesh|; -1 when not measured */
    float zmin, zmax;        /* range of the vertex heights */
};

/* Free the arrays of *m and zero it.  gv_mesh_free(NULL) does nothing. */
void gv_mesh_free(struct gv_mesh *m);

/* Column, row and height of vertex i of a grid mesh. */
static inline uint32_t gv_mesh_gx(const struct gv_mesh *m, uint32_t i)
{
    return (uint32_t)m->pos[3 * (size_t)i];
}
static inline uint32_t gv_mesh_gy(const struct gv_mesh *m, uint32_t i)
{
    return (uint32_t)m->pos[3 * (size_t)i + 1];
}
static inline float gv_mesh_gz(const struct gv_mesh *m, uint32_t i)
{
    return m->pos[3 * (size_t)i + 2];
}

#endif
