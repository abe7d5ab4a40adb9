/*
 * mesh_obj.c - a mesh as Wavefront OBJ: plain text, v and f records with
 * 1-based indices, positions in %.9g.  A placed grid mesh names the
 * measured error, the level and the region in header comments, any other
 * mesh the simplifier and the caller's comment.  +Z is up: a grid vertex
 * is (x, -y, height).
 */
#include "mesh/io/mesh_io.h"

void mesh_write_obj(struct mbuf *b, const struct gv_mesh *m,
                    const struct gv_mesh_place *pl, const char *comment)
{
    if (pl) {
        mb_printf(b, "# gigaview TIN by greedy insertion\n"
                     "# max_error %.9g\n"
                     "# level %u region %u,%u,%u,%u xy_scale %.9g\n"
                     "# axes x east, y north, z height\n",
                  m->max_error, pl->level, pl->x0, pl->y0, m->width,
                  m->height, mesh_scale(pl));
    } else {
        mb_printf(b, "# gigaview simplify (vertex clustering)\n");
        if (comment)
            mb_printf(b, "# %.400s\n", comment);
    }
    mb_printf(b, "# %u vertices, %u triangles\n", m->nverts, m->ntris);
    for (uint32_t i = 0; i < m->nverts; i++) {
        double v[3];
        mesh_vertex_zup(m, pl, i, v);
        mb_printf(b, "v %.9g %.9g %.9g\n", v[0], v[1], v[2]);
    }
    for (uint32_t i = 0; i < m->ntris; i++)
        mb_printf(b, "f %u %u %u\n", mesh_corner(m, pl, i, 0) + 1,
                  mesh_corner(m, pl, i, 1) + 1, mesh_corner(m, pl, i, 2) + 1);
}
