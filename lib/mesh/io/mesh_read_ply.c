/*
 * mesh_read_ply.c - PLY (Turk's polygon file format), "format ascii 1.0"
 * and "format binary_little_endian 1.0".  The header declares elements
 * and their properties; the "vertex" element's x, y, z (any scalar type)
 * are read and its other properties skipped, the "face" element's list
 * "vertex_indices" (or "vertex_index") is fanned into triangles, and every
 * other element is skipped by its declared layout.  binary_big_endian is
 * refused (GV_EFORMAT).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_read_int.h"

#define MAX_HEADER 65536
#define MAX_PROPS 64
#define MAX_ELEMS 32
#define MAX_CORNERS 256

enum ptype { T_NONE, T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64 };

static const struct { const char *name; enum ptype t; } type_names[] = {
    {"char", T_I8}, {"int8", T_I8}, {"uchar", T_U8}, {"uint8", T_U8},
    {"short", T_I16}, {"int16", T_I16}, {"ushort", T_U16}, {"uint16", T_U16},
    {"int", T_I32}, {"int32", T_I32}, {"uint", T_U32}, {"uint32", T_U32},
    {"float", T_F32}, {"float32", T_F32}, {"double", T_F64}, {"float64", T_F64},
};

static const int type_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};

struct prop {
    enum ptype t, count_t;   /* count_t != T_NONE: a list */
    int role;                /* 0 other, 1..3 x/y/z, 4 the face indices */
};

struct elem {
    char name[32];
    uint64_t count;
    int nprops;
    struct prop props[MAX_PROPS];
};

struct rd {
    const uint8_t *p, *end;
    int ascii;
    size_t line;  /* ascii: for messages */
};

static enum ptype parse_type(const char *s)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++)
        if (strcmp(s, type_names[i].name) == 0)
            return type_names[i].t;
    return T_NONE;
}

/* One scalar of type t as a double; -1 at the end of the data or on a bad
 * ascii token. */
static int read_scalar(struct rd *r, enum ptype t, double *v)
{
    if (r->ascii) {
        while (r->p < r->end && (*r->p == ' ' || *r->p == '\t' ||
                                 *r->p == '\r' || *r->p == '\n'))
            r->p++;
        char tok[64];
        size_t n = 0;
        while (r->p < r->end && !(*r->p == ' ' || *r->p == '\t' ||
                                  *r->p == '\r' || *r->p == '\n')) {
            if (n + 1 >= sizeof tok)
                return -1;
            tok[n++] = (char)*r->p++;
        }
        if (!n)
            return -1;
        tok[n] = 0;
        char *e;
        double d = strtod(tok, &e);
        if (*e || !isfinite(d))
            return -1;
        if (t != T_F32 && t != T_F64 && d != floor(d))
            return -1;
        *v = d;
        return 0;
    }
    int sz = type_size[t];
    if (r->end - r->p < sz)
        return -1;
    const uint8_t *b = r->p;
    r->p += sz;
    uint32_t u32 = 0;
    switch (t) {
    case T_I8: *v = (int8_t)b[0]; return 0;
    case T_U8: *v = b[0]; return 0;
    case T_I16: *v = (int16_t)(b[0] | b[1] << 8); return 0;
    case T_U16: *v = (uint16_t)(b[0] | b[1] << 8); return 0;
    case T_I32:
    case T_U32:
    case T_F32:
        u32 = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
              (uint32_t)b[3] << 24;
        if (t == T_I32)
            *v = (int32_t)u32;
        else if (t == T_U32)
            *v = u32;
        else {
            float f;
            memcpy(&f, &u32, 4);
            *v = f;
        }
        return 0;
    case T_F64: {
        uint64_t u = 0;
        for (int k = 7; k >= 0; k--)
            u = u << 8 | b[k];
        memcpy(v, &u, 8);
        return 0;
    }
    default: return -1;
    }
}

static int header_lines(char *hdr, struct elem *el, int *nel, int *ascii,
                        struct gv_error *err);

static int parse_header(const uint8_t *buf, size_t len, struct elem *el,
                        int *nel, int *ascii, size_t *data_at,
                        struct gv_error *err)
{
    size_t hl = len < MAX_HEADER ? len : MAX_HEADER;
    const uint8_t *endh = NULL;
    for (size_t i = 0; i + 10 <= hl; i++)
        if (memcmp(buf + i, "end_header", 10) == 0 &&
            (i == 0 || buf[i - 1] == '\n')) {
            endh = buf + i;
            break;
        }
    if (!endh)
        return gv_fail(err, GV_ECORRUPT, "mesh: ply: no end_header in the "
                       "first %d bytes", MAX_HEADER);
    const uint8_t *q = endh + 10;
    while (q < buf + len && *q == '\r')
        q++;
    if (q >= buf + len || *q != '\n')
        return gv_fail(err, GV_ECORRUPT, "mesh: ply: end_header not ended "
                       "by a newline");
    *data_at = (size_t)(q + 1 - buf);
    size_t n = (size_t)(endh - buf);
    if (memchr(buf, 0, n))
        return gv_fail(err, GV_ECORRUPT, "mesh: ply: NUL in the header");
    char *hdr = malloc(n + 1);
    if (!hdr)
        return gv_fail(err, GV_ENOMEM, "mesh: ply: out of memory");
    memcpy(hdr, buf, n);
    hdr[n] = 0;
    int rc = header_lines(hdr, el, nel, ascii, err);
    free(hdr);
    return rc;
}

static int header_lines(char *hdr, struct elem *el, int *nel, int *ascii,
                        struct gv_error *err)
{
    int have_format = 0;
    *nel = 0;
    char *save = NULL;
    for (char *ln = strtok_r(hdr, "\n", &save); ln;
         ln = strtok_r(NULL, "\n", &save)) {
        char *w[6];
        int nw = 0;
        char *s2 = NULL;
        for (char *t = strtok_r(ln, " \t\r", &s2); t && nw < 6;
             t = strtok_r(NULL, " \t\r", &s2))
            w[nw++] = t;
        if (!nw || strcmp(w[0], "ply") == 0 || strcmp(w[0], "comment") == 0 ||
            strcmp(w[0], "obj_info") == 0)
            continue;
        if (strcmp(w[0], "format") == 0 && nw >= 2) {
            if (strcmp(w[1], "ascii") == 0)
                *ascii = 1;
            else if (strcmp(w[1], "binary_little_endian") == 0)
                *ascii = 0;
            else if (strcmp(w[1], "binary_big_endian") == 0)
                return gv_fail(err, GV_EFORMAT, "mesh: ply: binary_big_endian "
                               "is not supported (ascii or little endian)");
            else
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: unknown format "
                               "'%.32s'", w[1]);
            have_format = 1;
        } else if (strcmp(w[0], "element") == 0 && nw >= 3) {
            if (*nel == MAX_ELEMS)
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: more than %d "
                               "elements", MAX_ELEMS);
            struct elem *e = &el[(*nel)++];
            memset(e, 0, sizeof *e);
            snprintf(e->name, sizeof e->name, "%s", w[1]);
            char *endp;
            errno = 0;
            unsigned long long c = strtoull(w[2], &endp, 10);
            if (*endp || errno || w[2][0] == '-')
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: bad element "
                               "count");
            e->count = c;
        } else if (strcmp(w[0], "property") == 0 && nw >= 3) {
            if (!*nel)
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: property before "
                               "any element");
            struct elem *e = &el[*nel - 1];
            if (e->nprops == MAX_PROPS)
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: more than %d "
                               "properties", MAX_PROPS);
            struct prop *p = &e->props[e->nprops++];
            memset(p, 0, sizeof *p);
            const char *pname;
            if (strcmp(w[1], "list") == 0) {
                if (nw < 5)
                    return gv_fail(err, GV_ECORRUPT, "mesh: ply: short list");
                p->count_t = parse_type(w[2]);
                p->t = parse_type(w[3]);
                pname = w[4];
                if (p->count_t == T_F32 || p->count_t == T_F64)
                    p->count_t = T_NONE;
            } else {
                p->t = parse_type(w[1]);
                pname = w[2];
            }
            if (p->t == T_NONE || (strcmp(w[1], "list") == 0 &&
                                   p->count_t == T_NONE))
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: bad property "
                               "type");
            if (strcmp(e->name, "vertex") == 0 && p->count_t == T_NONE) {
                if (strcmp(pname, "x") == 0) p->role = 1;
                if (strcmp(pname, "y") == 0) p->role = 2;
                if (strcmp(pname, "z") == 0) p->role = 3;
            }
            if (strcmp(e->name, "face") == 0 && p->count_t != T_NONE &&
                (strcmp(pname, "vertex_indices") == 0 ||
                 strcmp(pname, "vertex_index") == 0) &&
                p->t != T_F32 && p->t != T_F64)
                p->role = 4;
        }   /* other lines (some writers add free text) are skipped */
    }
    if (!have_format)
        return gv_fail(err, GV_ECORRUPT, "mesh: ply: no format line");
    return 0;
}

static int read_body(const uint8_t *buf, size_t len, size_t at,
                     struct elem *el, int nel, int ascii,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err);

int gv_mesh_read_ply(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err)
{
    if (len < 4 || memcmp(buf, "ply", 3) != 0 ||
        (buf[3] != '\n' && buf[3] != '\r'))
        return gv_fail(err, GV_ECORRUPT, "mesh: ply: no 'ply' magic line");
    struct elem *el = calloc(MAX_ELEMS, sizeof *el);
    if (!el)
        return gv_fail(err, GV_ENOMEM, "mesh: ply: out of memory");
    int nel = 0, ascii = -1;
    size_t at = 0;
    int rc = parse_header(buf, len, el, &nel, &ascii, &at, err);
    if (rc == 0)
        rc = read_body(buf, len, at, el, nel, ascii, lim, out, err);
    free(el);
    return rc;
}

static int read_body(const uint8_t *buf, size_t len, size_t at,
                     struct elem *el, int nel, int ascii,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err)
{
    struct mesh_grow g = {.m = out, .lim = lim};
    struct rd r = {.p = buf + at, .end = buf + len, .ascii = ascii};
    for (int ei = 0; ei < nel; ei++) {
        struct elem *e = &el[ei];
        int is_vertex = strcmp(e->name, "vertex") == 0;
        int is_face = strcmp(e->name, "face") == 0;
        if (is_vertex) {
            int roles = 0;
            for (int k = 0; k < e->nprops; k++)
                roles |= 1 << e->props[k].role;
            if ((roles & 14) != 14)
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: vertex element "
                               "without x, y, z");
            if (out->nverts)
                return gv_fail(err, GV_ECORRUPT, "mesh: ply: two vertex "
                               "elements");
        }
        /* Cheap bound before reserving: every record takes a byte. */
        if (e->count > (uint64_t)(r.end - r.p) + 1 && (is_vertex || is_face))
            return gv_fail(err, GV_ECORRUPT, "mesh: ply: %s count %llu over "
                           "the file's size", e->name,
                           (unsigned long long)e->count);
        if (is_vertex && mesh_grow_reserve(&g, e->count, 0, err) < 0)
            return -1;
        if (is_face && e->count > lim->max_tris)
            return gv_fail(err, GV_ELIMIT, "mesh: more than %u triangles "
                           "(limit)", lim->max_tris);
        for (uint64_t i = 0; i < e->count; i++) {
            double xyz[3] = {0, 0, 0};
            for (int k = 0; k < e->nprops; k++) {
                struct prop *p = &e->props[k];
                double v;
                if (p->count_t == T_NONE) {
                    if (read_scalar(&r, p->t, &v) < 0)
                        goto bad;
                    if (p->role >= 1 && p->role <= 3)
                        xyz[p->role - 1] = v;
                    continue;
                }
                double cnt;
                if (read_scalar(&r, p->count_t, &cnt) < 0 || cnt < 0 ||
                    cnt > 1e9)
                    goto bad;
                uint32_t nc = (uint32_t)cnt;
                if (p->role == 4 && (nc < 3 || nc > MAX_CORNERS))
                    return gv_fail(err, GV_ECORRUPT, "mesh: ply: face %llu "
                                   "with %u corners", (unsigned long long)i,
                                   nc);
                uint32_t c[MAX_CORNERS];
                for (uint32_t j = 0; j < nc; j++) {
                    if (read_scalar(&r, p->t, &v) < 0)
                        goto bad;
                    if (p->role == 4) {
                        if (v < 0 || v >= out->nverts)
                            return gv_fail(err, GV_ECORRUPT, "mesh: ply: face "
                                           "%llu names vertex %.0f of %u",
                                           (unsigned long long)i, v,
                                           out->nverts);
                        c[j] = (uint32_t)v;
                    }
                }
                if (p->role == 4)
                    for (uint32_t j = 1; j + 1 < nc; j++)
                        if (mesh_grow_tri(&g, c[0], c[j], c[j + 1], err) < 0)
                            return -1;
            }
            if (is_vertex) {
                for (int k = 0; k < 3; k++)
                    if (!isfinite(xyz[k]) || fabs(xyz[k]) > 3.4e38)
                        goto bad;
                if (mesh_grow_vert(&g, (float)xyz[0], (float)xyz[1],
                                   (float)xyz[2], err) < 0)
                    return -1;
            }
        }
    }
    return 0;
bad:
    return gv_fail(err, GV_ECORRUPT, "mesh: ply: truncated or bad %s data",
                   ascii ? "ascii" : "binary");
}
