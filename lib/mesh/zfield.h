/*
 * zfield.h - view-independent and view-dependent simplification of a
 * z-field (a height grid) after Lindstrom et al., as adapted to graphics
 * hardware in "GPU z-field simplification" (../shared/reference/
 * gpu-zfield-simplification.md, "the paper" below).
 *
 * The grid is N x N samples with N = 2^k + 1.  Its full triangulation is
 * the block hierarchy of the paper's section 3 (figure 2): a right-triangle
 * bintree whose two root triangles split the square along the diagonal
 * (0,0)-(N-1,N-1).  Every vertex but the corners is the midpoint of one
 * hypotenuse A-C; removing it merges the (one or two) triangles on A-C
 * (figure 3).  Its simplification error (section 3) is
 *
 *     delta_B = B_z - (A_z + C_z) / 2,
 *
 * computed as |2 B_z - A_z - C_z| against twice the threshold, in float
 * arithmetic that every decoder evaluates identically (+, - and * only,
 * each correctly rounded; no fused operations: C11 mode and `precise` in
 * GLSL).
 *
 * A vertex is *activated* when its error exceeds the threshold, and
 * *enabled* when it is activated or one of its children is enabled; its
 * parents are the apexes of the triangles on its hypotenuse (figure 4),
 * its children the vertices whose parent it is.  Grouping the vertices by
 * level (section 3: level 0 = the edge midpoints of spacing 1, level 1 =
 * the block centres of spacing 1, level 2 = edge midpoints of spacing 2,
 * ..., level 2k-1 = the centre of the grid) evaluates children before
 * their parents, so one sweep over the levels decides every vertex with
 * no notifications (section 4).  The mesh is then the bintree cut at the
 * enabled vertices (section 5.3: a depth-first traversal), crack-free by
 * the dependencies.
 *
 * Two error modes: view-independent (a vertical threshold in the grid's
 * units) and view-dependent (the error projected to the screen in pixels
 * for a camera: activated when (|delta| K)^2 > tau^2 d^2, with d the
 * distance from the eye to the vertex and K = viewport height /
 * (2 tan(fovy / 2)), Lindstrom et al.'s isotropic projection of a vertical
 * error, squared so that no division or root takes part).
 *
 * The coarse phase (section 3) skips, on the CPU, the vertices inside
 * blocks whose largest error cannot exceed the threshold; it changes no
 * result (test_zfield checks it), only the work.
 */
#ifndef GV_MESH_ZFIELD_H
#define GV_MESH_ZFIELD_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"
#include "mesh/mesh.h"

/* Largest grid side: 2^15 + 1 samples (flags fit in memory; levels < 32). */
#define GV_ZFIELD_MAX_SIDE 32769u

enum gv_zfield_mode { GV_ZFIELD_VERTICAL, GV_ZFIELD_SCREEN };

struct gv_zfield_params {
    enum gv_zfield_mode mode;
    float threshold;      /* VERTICAL: grid units; SCREEN: pixels; >= 0 */
    /* SCREEN only: the eye in world units (x = column * xy_scale,
     * y = row * xy_scale, z = height) and K (see above). */
    float eye[3];
    float k;
    float xy_scale;       /* world units per sample step; 0 means 1 */
    int no_coarse;        /* evaluate every vertex (for tests) */
};

/* 1 if n = 2^k + 1 with 1 <= k and n <= GV_ZFIELD_MAX_SIDE, else 0. */
int gv_zfield_side_ok(uint32_t n);

/* K of a camera: viewport height in pixels over 2 tan(fovy / 2). */
float gv_zfield_k(double viewport_height, double fovy_radians);

/*
 * Decide every vertex's enabled state on the CPU: enabled[y * n + x] is 1
 * or 0 (corners always 1).  z holds n x n heights, row-major, finite.
 * Returns 0, or -1 with *err (GV_EINVAL: n not 2^k + 1, bad parameters).
 */
int gv_zfield_enable(const float *z, uint32_t n, const struct gv_zfield_params *p,
                     uint8_t *enabled, struct gv_error *err);

/*
 * The mesh of the enabled vertices: the bintree cut where the hypotenuse
 * midpoint is disabled, triangles in depth-first order from the root
 * triangles, vertices numbered by first use.  Fills *out with a grid
 * mesh like gv_tin_build (mesh/mesh.h: triangles counter-clockwise; free
 * with gv_mesh_free); max_error is measured against every sample when
 * `measure` (a pass over the grid), else -1 (per-frame use).  Returns 0,
 * or -1 with *err (GV_ENOMEM, GV_EINVAL).
 */
int gv_zfield_mesh(const float *z, uint32_t n, const uint8_t *enabled, int measure,
                   struct gv_mesh *out, struct gv_error *err);

/*
 * Vertex geometry shared with the GPU sweep: level `lev` (0 .. 2k-1) of a
 * grid of side n = 2^k + 1 has spacing s = 2^(lev / 2); even levels are
 * the midpoints of horizontal edges (x = s (2i+1), y = 2 s j) and of
 * vertical edges (x = 2 s i, y = s (2j+1)), odd levels the block centres
 * (x = s (2i+1), y = s (2j+1)), whose hypotenuse runs "\" when i + j is
 * even and "/" when odd.  Number of vertices of a level:
 */
uint64_t gv_zfield_level_count(uint32_t n, int lev);

/* The levels of a grid of side n: 2k. */
int gv_zfield_levels(uint32_t n);

#endif
