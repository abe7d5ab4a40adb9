/*
 * mesh_grow.c - the growing mesh the readers of mesh_read_*.c share
 * (mesh_read_int.h): vertices and triangles appended under the limits,
 * and the final check of the indices.  Apart from mesh_read.c so that
 * the readers and the sniffing that calls them do not need each other.
 */
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_read.h"
#include "mesh/io/mesh_read_int.h"

static int grow(void **p, uint32_t *cap, uint64_t need, size_t elem)
{
    if (need <= *cap)
        return 0;
    uint64_t c = *cap ? *cap : 1024;
    while (c < need)
        c *= 2;
    if (c > UINT32_MAX)
        c = UINT32_MAX;
    void *q = realloc(*p, (size_t)c * elem);
    if (!q)
        return -1;
    *p = q;
    *cap = (uint32_t)c;
    return 0;
}

int mesh_grow_reserve(struct mesh_grow *g, uint64_t nv, uint64_t nt,
                      struct gv_error *err)
{
    uint64_t v = g->m->nverts + nv, t = g->m->ntris + nt;
    if (v > g->lim->max_verts)
        return gv_fail(err, GV_ELIMIT, "mesh: more than %u vertices (limit)",
                       g->lim->max_verts);
    if (t > g->lim->max_tris)
        return gv_fail(err, GV_ELIMIT, "mesh: more than %u triangles (limit)",
                       g->lim->max_tris);
    if (grow((void **)&g->m->pos, &g->vcap, v, 3 * sizeof(float)) < 0 ||
        grow((void **)&g->m->tris, &g->tcap, t, 3 * sizeof(uint32_t)) < 0)
        return gv_fail(err, GV_ENOMEM, "mesh: out of memory for %llu "
                       "vertices, %llu triangles", (unsigned long long)v,
                       (unsigned long long)t);
    return 0;
}

int mesh_grow_vert(struct mesh_grow *g, float x, float y, float z,
                   struct gv_error *err)
{
    if (g->m->nverts >= g->vcap && mesh_grow_reserve(g, 1, 0, err) < 0)
        return -1;
    if (g->m->nverts >= g->lim->max_verts)
        return gv_fail(err, GV_ELIMIT, "mesh: more than %u vertices (limit)",
                       g->lim->max_verts);
    float *p = g->m->pos + 3 * (size_t)g->m->nverts++;
    p[0] = x;
    p[1] = y;
    p[2] = z;
    return 0;
}

int mesh_grow_tri(struct mesh_grow *g, uint32_t a, uint32_t b, uint32_t c,
                  struct gv_error *err)
{
    if (g->m->ntris >= g->tcap && mesh_grow_reserve(g, 0, 1, err) < 0)
        return -1;
    if (g->m->ntris >= g->lim->max_tris)
        return gv_fail(err, GV_ELIMIT, "mesh: more than %u triangles (limit)",
                       g->lim->max_tris);
    uint32_t *t = g->m->tris + 3 * (size_t)g->m->ntris++;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    return 0;
}

int mesh_check_indices(const struct gv_mesh *m, const char *fmt_name,
                       struct gv_error *err)
{
    for (size_t i = 0; i < 3 * (size_t)m->ntris; i++)
        if (m->tris[i] >= m->nverts)
            return gv_fail(err, GV_ECORRUPT, "mesh: %s: triangle %zu names "
                           "vertex %u of %u", fmt_name, i / 3, m->tris[i],
                           m->nverts);
    return 0;
}
