/*
 * mesh.c - the life of the one mesh type (mesh.h).
 */
#include "mesh/mesh.h"

#include <stdlib.h>
#include <string.h>

void gv_mesh_free(struct gv_mesh *m)
{
    if (!m)
        return;
    free(m->pos);
    free(m->tris);
    memset(m, 0, sizeof *m);
}
