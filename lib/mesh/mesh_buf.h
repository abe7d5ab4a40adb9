/*
 * mesh_buf.h - the growing byte buffer the mesh writers share (private to
 * lib/mesh).  A failed allocation sets oom and later appends do nothing,
 * so a writer checks once at the end.
 */
#ifndef GV_MESH_BUF_H
#define GV_MESH_BUF_H

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Position of a vertex in the writers' shared frame: x east, y south in
 * units (samples times the scale), z the height. */
struct mesh_xyz {
    double x, y, z;
};

struct gv_tin;
struct gv_mesh_place;

/* The writers of mesh_glb.c and mesh_qmesh.c: append the file to *b.
 * Return 0, or -1 for a mesh the format cannot hold (*why says which). */
int mesh_write_glb(struct mbuf *b, const struct gv_tin *t,
                   const struct gv_mesh_place *pl, const char **why);
int mesh_write_qmesh(struct mbuf *b, const struct gv_tin *t,
                     const struct gv_mesh_place *pl, const char **why);

/*
 * The end of a one-primitive GLB (mesh_glb.c), shared by the TIN writer
 * and the simplifier's (cluster_write.c): *js holds the JSON up to its
 * buffers, *bin nverts float VEC3 positions (the first pos_len bytes, with
 * their min mn and max mx) and then the uint32 indices.  Appends the
 * buffers, bufferViews and accessors, closes the JSON, and writes the GLB
 * container to *b; frees js and bin.  Returns 0, or -1 past GLB's 4 GiB;
 * b->oom is set when a chunk ran out of memory.
 */
int mesh_glb_finish(struct mbuf *b, struct mbuf *js, struct mbuf *bin,
                    size_t pos_len, uint32_t nverts, uint32_t ntris,
                    const float mn[3], const float mx[3]);

#endif
