/*
 * cluster_write.c - a general triangle mesh (mesh_read.h) as GLB, PLY or
 * OBJ, for the simplifier: the same layouts as the TIN writers
 * (mesh_write.c, mesh_glb.c, whose mesh_glb_finish ends both GLBs), on the
 * shared byte buffer (mesh_buf.h), but with float positions kept in the
 * file's own axes.
 */
#include <float.h>

#include "mesh/cluster.h"
#include "mesh/mesh_buf.h"

static void put_ply(struct mbuf *b, const struct gv_trimesh *m,
                    const char *comment)
{
    mb_printf(b, "ply\nformat binary_little_endian 1.0\n"
                 "comment gigaview simplify (vertex clustering)\n");
    if (comment)
        mb_printf(b, "comment %.400s\n", comment);
    mb_printf(b, "element vertex %u\n"
                 "property float x\nproperty float y\nproperty float z\n"
                 "element face %u\n"
                 "property list uchar uint vertex_indices\n"
                 "end_header\n", m->nverts, m->ntris);
    for (size_t i = 0; i < 3 * (size_t)m->nverts; i++)
        mb_f32(b, m->pos[i]);
    for (size_t i = 0; i < m->ntris; i++) {
        mb_u8(b, 3);
        for (int k = 0; k < 3; k++)
            mb_u32(b, m->tris[3 * i + k]);
    }
}

static void put_obj(struct mbuf *b, const struct gv_trimesh *m,
                    const char *comment)
{
    mb_printf(b, "# gigaview simplify (vertex clustering)\n");
    if (comment)
        mb_printf(b, "# %.400s\n", comment);
    mb_printf(b, "# %u vertices, %u triangles\n", m->nverts, m->ntris);
    for (size_t i = 0; i < m->nverts; i++)
        mb_printf(b, "v %.9g %.9g %.9g\n", (double)m->pos[3 * i],
                  (double)m->pos[3 * i + 1], (double)m->pos[3 * i + 2]);
    for (size_t i = 0; i < m->ntris; i++)
        mb_printf(b, "f %u %u %u\n", m->tris[3 * i] + 1,
                  m->tris[3 * i + 1] + 1, m->tris[3 * i + 2] + 1);
}

static int put_glb(struct mbuf *b, const struct gv_trimesh *m)
{
    float mn[3] = {FLT_MAX, FLT_MAX, FLT_MAX};
    float mx[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    struct mbuf bin = {0}, js = {0};
    for (size_t i = 0; i < m->nverts; i++)
        for (int k = 0; k < 3; k++) {
            float v = m->pos[3 * i + k];
            if (v < mn[k]) mn[k] = v;
            if (v > mx[k]) mx[k] = v;
            mb_f32(&bin, v);
        }
    if (!m->nverts)
        for (int k = 0; k < 3; k++)
            mn[k] = mx[k] = 0;
    size_t pos_len = bin.n;
    for (size_t i = 0; i < 3 * (size_t)m->ntris; i++)
        mb_u32(&bin, m->tris[i]);
    mb_printf(&js, "{\"asset\":{\"version\":\"2.0\",\"generator\":"
                   "\"gigaview simplify\"},\"scene\":0,"
                   "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                   "\"meshes\":[{\"primitives\":[{\"attributes\":"
                   "{\"POSITION\":0},\"indices\":1,\"mode\":4}]}],");
    return mesh_glb_finish(b, &js, &bin, pos_len, m->nverts, m->ntris, mn, mx);
}

int gv_trimesh_encode(enum gv_mesh_format f, const struct gv_trimesh *m,
                      const char *comment, uint8_t **out, size_t *len,
                      struct gv_error *err)
{
    struct mbuf b = {0};
    switch (f) {
    case GV_MESH_GLB:
        if (put_glb(&b, m) < 0) {
            free(b.p);
            return gv_fail(err, GV_EINVAL, "mesh: a GLB file holds at most "
                           "4 GiB");
        }
        break;
    case GV_MESH_PLY:
        put_ply(&b, m, comment);
        break;
    case GV_MESH_OBJ:
        put_obj(&b, m, comment);
        break;
    default:
        return gv_fail(err, GV_EFORMAT, "mesh: a simplified mesh is written "
                       "as glb, ply or obj");
    }
    if (b.oom) {
        free(b.p);
        return gv_fail(err, GV_ENOMEM, "mesh: out of memory writing %u "
                       "triangles", m->ntris);
    }
    *out = b.p;
    *len = b.n;
    return 0;
}
