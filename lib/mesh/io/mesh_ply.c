/*
 * mesh_ply.c - a mesh as PLY, binary little endian: float x, y, z and
 * uchar-counted uint lists.  A placed grid mesh names the measured error,
 * the level and the region in header comments (where tools such as
 * MeshLab and Blender ignore them), any other mesh the simplifier and the
 * caller's comment.  +Z is up: a grid vertex is (x, -y, height).
 */
#include "mesh/io/mesh_io.h"

static void put_header(struct mbuf *b, const struct gv_mesh *m,
                       const struct gv_mesh_place *pl, const char *comment)
{
    mb_printf(b, "ply\nformat binary_little_endian 1.0\n");
    if (pl) {
        mb_printf(b, "comment gigaview TIN by greedy insertion\n"
                     "comment max_error %.9g\n"
                     "comment level %u region %u,%u,%u,%u xy_scale %.9g\n"
                     "comment axes x east, y north, z height\n",
                  m->max_error, pl->level, pl->x0, pl->y0, m->width,
                  m->height, mesh_scale(pl));
    } else {
        mb_printf(b, "comment gigaview simplify (vertex clustering)\n");
        if (comment)
            mb_printf(b, "comment %.400s\n", comment);
    }
    mb_printf(b, "element vertex %u\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "element face %u\n"
                 "property list uchar uint vertex_indices\n"
                 "end_header\n", m->nverts, m->ntris);
}

void mesh_write_ply(struct mbuf *b, const struct gv_mesh *m,
                    const struct gv_mesh_place *pl, const char *comment)
{
    put_header(b, m, pl, comment);
    for (uint32_t i = 0; i < m->nverts; i++) {
        double v[3];
        mesh_vertex_zup(m, pl, i, v);
        for (int k = 0; k < 3; k++)
            mb_f32(b, (float)v[k]);
    }
    for (uint32_t i = 0; i < m->ntris; i++) {
        mb_u8(b, 3);
        for (int k = 0; k < 3; k++)
            mb_u32(b, mesh_corner(m, pl, i, k));
    }
}
