/*
 * tin.h - triangulated irregular networks (TINs) of a height grid by greedy
 * insertion (Garland & Heckbert, "Fast Polygonal Approximation of Terrains
 * and Height Fields", CMU-CS-95-181: section 4.4, algorithm III).
 *
 * The grid is W x H samples of float heights in source units.  The mesh
 * starts as two triangles over the corners; the point of largest vertical
 * error (section 3.1) is inserted, the Delaunay triangulation is updated
 * incrementally (section 4.2.1), and only the triangles that changed are
 * scanned again for their candidate, kept in a heap (section 4.3).
 *
 * Crack-free neighbours: with a maximum error, the border vertices are
 * chosen first, by 1D greedy insertion along each of the four edges from
 * the border samples alone, to the same error.  Two regions that share an
 * edge of samples therefore choose the same vertices on it, whatever lies
 * inside them.  Interior points are inserted after, and border samples are
 * never interior candidates (the hull edges are never flipped, so the
 * border of the mesh is exactly the 1D polylines).
 *
 * Determinism: coordinates are integers and every orientation and circle
 * test is exact (64/128-bit integers); an error tie goes to the smaller
 * sample index (y * W + x), and cocircular quadrilaterals are not flipped.
 * The same grid and parameters give the same mesh on every machine.
 */
#ifndef GV_MESH_TIN_H
#define GV_MESH_TIN_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "mesh/mesh.h"

/* The largest side of a grid: coordinates stay exact in the 128-bit
 * circle test and sample indices in 32 bits. */
#define GV_TIN_MAX_SIDE 65535u

struct gv_tin_params {
    double max_error;        /* stop once no sample is off by more than
                                this (source units); < 0: no error goal */
    uint32_t max_triangles;  /* stop before the mesh would exceed this many
                                triangles; 0: no limit */
    int border_first;        /* choose border vertices from the border alone
                                (needs max_error >= 0): crack-free tiles */
    double time_limit;       /* seconds of wall time; 0: none */
};

/*
 * Build the TIN of a W x H grid of heights (row i at h + i * stride
 * floats).  At least one goal must be set (max_error >= 0 or
 * max_triangles > 0); both may be, and the first reached stops.  W and H
 * are 2 .. GV_TIN_MAX_SIDE.  Heights must be finite.  *out is filled with
 * a grid mesh (mesh/mesh.h; free with gv_mesh_free): the vertices in
 * insertion order, the corners first: (0,0), (W-1,0), (W-1,H-1), (0,H-1);
 * the triangles counter-clockwise in (x, y) with y as a math axis
 * (orient(a, b, c) > 0); max_error measured over every sample.  Returns 0, or -1: GV_EINVAL for bad sizes or
 * goals, GV_ELIMIT when border_first's border vertices alone make more
 * than max_triangles triangles, GV_ETIMEOUT past time_limit, GV_ENOMEM.  Thread-safe (no shared state).
 */
int gv_tin_build(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                 const struct gv_tin_params *p, struct gv_mesh *out,
                 struct gv_error *err);

/*
 * The TIN of the same grid as tiles of `tile` x `tile` cells, each built by
 * gv_tin_build with border-first insertion on a pool of `threads` threads,
 * joined without cracks into one mesh (vertices on tile borders merged;
 * tin_tiled.c).  Needs max_error >= 0 and no max_triangles.  The result
 * is the same for any thread count; it is not the single-tile mesh (the
 * tile borders force their own vertices, and the union is Delaunay within
 * each tile only).  W and H are at most GV_MESH_MAX_GRID.  Returns 0, or
 * -1 as gv_tin_build.
 */
int gv_tin_build_tiled(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                       const struct gv_tin_params *p, uint32_t tile,
                       int threads, struct gv_mesh *out, struct gv_error *err);

/*
 * The 1D greedy insertion along one edge of samples s[0 .. n-1] (n >= 2):
 * the endpoints, then repeatedly the sample farthest from the polyline
 * (ties: the smaller position) until none is off by more than max_error.
 * Writes the chosen interior positions, sorted, to pos (room for n) and
 * their count to *count.  Returns 0, or -1 when out of memory.  Both
 * neighbours of a shared edge call it on the same samples and get the
 * same positions.
 */
int gv_tin_edge_greedy(const float *s, size_t step, uint32_t n,
                       double max_error, uint32_t *pos, uint32_t *count);

#endif
