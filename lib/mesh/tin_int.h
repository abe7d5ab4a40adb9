/*
 * tin_int.h - what tin.c shares with the tests but not with callers.
 *
 * gv_tin_build_brute is Garland & Heckbert's algorithm I (section 4.1):
 * after every insertion it evaluates every unused sample, locating it by a
 * linear search over all triangles.  It uses the same mesh code and the same
 * plane of each triangle as gv_tin_build, so on the same input both must
 * insert the same vertices in the same order; tests/test_tin.c checks it.
 * O(m^2 n): small grids only.
 */
#ifndef GV_MESH_TIN_INT_H
#define GV_MESH_TIN_INT_H

#include "mesh/tin.h"

int gv_tin_build_brute(const float *h, uint32_t w, uint32_t hgt,
                       size_t stride, const struct gv_tin_params *p,
                       struct gv_mesh *out, struct gv_error *err);

/*
 * gv_tin_build with the scans' row-segment bounds (tin.c, segmm) on any
 * grid (segs = 1) or on none (segs = 0); gv_tin_build uses them on grids
 * over SEG_GRID samples only.  The bounds skip only samples that cannot
 * win, so the mesh is the same either way; tests/test_tin.c checks both
 * against the brute force, and against each other on a larger grid.
 */
int gv_tin_build_segs(const float *h, uint32_t w, uint32_t hgt,
                      size_t stride, const struct gv_tin_params *p, int segs,
                      struct gv_mesh *out, struct gv_error *err);

#endif
