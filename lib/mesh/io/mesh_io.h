/*
 * mesh_io.h - what the mesh writers of lib/mesh/io share (private to
 * lib/mesh): the growing byte buffer, where a vertex of a mesh lies in a
 * file's axes, and the writer of each format behind gv_mesh_encode
 * (mesh_write.c).
 *
 * The byte buffer: a failed allocation sets oom and later appends do
 * nothing, so a writer checks once at the end.
 *
 * A new format: a file io/mesh_FORMAT.c with its mesh_write_FORMAT here,
 * an entry in the enum and the tables of io/mesh_write.h and mesh_write.c,
 * and its reader (if any) as io/mesh_read_FORMAT.c behind gv_mesh_read.
 */
#ifndef GV_MESH_IO_H
#define GV_MESH_IO_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_write.h"

struct mbuf {
    uint8_t *p;
    size_t n, cap;
    int oom;
};

static inline void mb_put(struct mbuf *b, const void *src, size_t n)
{
    if (b->oom)
        return;
    if (b->n + n > b->cap) {
        size_t c = b->cap ? b->cap : 4096;
        while (c < b->n + n)
            c *= 2;
        uint8_t *q = realloc(b->p, c);
        if (!q) {
            b->oom = 1;
            return;
        }
        b->p = q;
        b->cap = c;
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}

static inline void mb_u8(struct mbuf *b, uint8_t v) { mb_put(b, &v, 1); }

static inline void mb_u16(struct mbuf *b, uint16_t v)
{
    uint8_t x[2] = {(uint8_t)v, (uint8_t)(v >> 8)};
    mb_put(b, x, 2);
}

static inline void mb_u32(struct mbuf *b, uint32_t v)
{
    uint8_t x[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16),
                    (uint8_t)(v >> 24)};
    mb_put(b, x, 4);
}

static inline void mb_f32(struct mbuf *b, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    mb_u32(b, v);
}

static inline void mb_f64(struct mbuf *b, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    mb_u32(b, (uint32_t)v);
    mb_u32(b, (uint32_t)(v >> 32));
}

__attribute__((format(printf, 2, 3))) static inline void
mb_printf(struct mbuf *b, const char *fmt, ...)
{
    char tmp[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof tmp) {
        b->oom = 1; /* every caller's line fits; a longer one is a bug */
        return;
    }
    mb_put(b, tmp, (size_t)n);
}


/* Units per sample step of a placement (0 means 1). */
static inline double mesh_scale(const struct gv_mesh_place *pl)
{
    return pl->xy_scale > 0 ? pl->xy_scale : 1.0;
}

/* Vertex i of m in a +Z-up file (PLY, OBJ): with a placement, the grid
 * mesh at (x east, -y, height) in units; without, the mesh's own axes. */
static inline void mesh_vertex_zup(const struct gv_mesh *m,
                                   const struct gv_mesh_place *pl, uint32_t i,
                                   double o[3])
{
    const float *p = m->pos + 3 * (size_t)i;
    if (pl) {
        double s = mesh_scale(pl);
        o[0] = (pl->x0 + (double)p[0]) * s;
        o[1] = -(pl->y0 + (double)p[1]) * s;
        o[2] = (double)p[2];
    } else {
        for (int k = 0; k < 3; k++)
            o[k] = (double)p[k];
    }
}

/* Corner k (0..2) of triangle t as written: a placed grid mesh is
 * counter-clockwise in (x, y) with y up, so a file whose y runs the other
 * way (or whose up is the grid's y) takes its corners reversed. */
static inline uint32_t mesh_corner(const struct gv_mesh *m,
                                   const struct gv_mesh_place *pl,
                                   uint32_t t, int k)
{
    static const int rev[3] = {0, 2, 1};
    return m->tris[3 * (size_t)t + (pl ? rev[k] : k)];
}

/* The writers: append the file to *b.  pl: a grid mesh placed there (and
 * its header names the error, level and region), or NULL: a mesh in its
 * own axes with `comment` (may be NULL) in the header.  Return 0, or -1
 * for a mesh the format cannot hold (*why says which). */
int mesh_write_glb(struct mbuf *b, const struct gv_mesh *m,
                   const struct gv_mesh_place *pl, const char **why);
void mesh_write_ply(struct mbuf *b, const struct gv_mesh *m,
                    const struct gv_mesh_place *pl, const char *comment);
void mesh_write_obj(struct mbuf *b, const struct gv_mesh *m,
                    const struct gv_mesh_place *pl, const char *comment);
/* quantized-mesh: a grid mesh only (pl not NULL) */
int mesh_write_qmesh(struct mbuf *b, const struct gv_mesh *m,
                     const struct gv_mesh_place *pl, const char **why);

#endif
