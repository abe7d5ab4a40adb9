/*
 * mesh_read_obj.c - Wavefront OBJ: "v x y z [w]" and "f i[/t[/n]] ..."
 * records (1-based indices, negative ones relative to the vertices so
 * far); every other record (vt, vn, o, g, s, usemtl, mtllib, l, p) is
 * skipped.  Faces with more than three corners are fanned.  Numbers are
 * parsed within the line only (the buffer need not be terminated).
 */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_read_int.h"

#define MAX_LINE 4096   /* longer v/f records are refused */
#define MAX_CORNERS 256 /* corners of one polygon */

static int is_space(int c) { return c == ' ' || c == '\t' || c == '\r'; }

int gv_mesh_read_obj(const uint8_t *buf, size_t len,
                     const struct gv_mesh_limits *lim, struct gv_mesh *out,
                     struct gv_error *err)
{
    struct mesh_grow g = {.m = out, .lim = lim};
    char line[MAX_LINE + 1];
    size_t pos = 0, lineno = 0;
    while (pos < len) {
        size_t end = pos;
        while (end < len && buf[end] != '\n')
            end++;
        size_t n = end - pos;
        const uint8_t *s = buf + pos;
        pos = end + 1;
        lineno++;
        while (n && is_space(*s))
            s++, n--;
        if (n < 2 || !(s[0] == 'v' || s[0] == 'f') || !is_space(s[1]))
            continue;   /* not a v or f record */
        if (n > MAX_LINE)
            return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu longer than "
                           "%d bytes", lineno, MAX_LINE);
        memcpy(line, s, n);
        line[n] = 0;
        if (memchr(line, 0, n))
            return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu has a NUL",
                           lineno);
        char *p = line + 2, *e;
        if (line[0] == 'v') {
            float v[3];
            for (int k = 0; k < 3; k++) {
                errno = 0;
                double d = strtod(p, &e);
                if (e == p || !isfinite(d) || fabs(d) > 3.4e38)
                    return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu: bad "
                                   "vertex coordinate", lineno);
                v[k] = (float)d;
                p = e;
            }
            if (mesh_grow_vert(&g, v[0], v[1], v[2], err) < 0)
                return -1;
            continue;
        }
        uint32_t c[MAX_CORNERS];
        int nc = 0;
        for (;;) {
            while (is_space(*p))
                p++;
            if (!*p)
                break;
            if (nc == MAX_CORNERS)
                return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu: more "
                               "than %d corners", lineno, MAX_CORNERS);
            errno = 0;
            long long i = strtoll(p, &e, 10);
            if (e == p || errno || i == 0)
                return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu: bad "
                               "face index", lineno);
            long long nv = out->nverts;
            long long idx = i > 0 ? i - 1 : nv + i;
            if (idx < 0 || idx >= nv)
                return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu: index "
                               "%lld outside the %lld vertices", lineno, i, nv);
            c[nc++] = (uint32_t)idx;
            p = e;
            while (*p && !is_space(*p))   /* skip /t/n */
                p++;
        }
        if (nc < 3)
            return gv_fail(err, GV_ECORRUPT, "mesh: obj line %zu: a face of "
                           "%d corners", lineno, nc);
        for (int k = 1; k + 1 < nc; k++)
            if (mesh_grow_tri(&g, c[0], c[k], c[k + 1], err) < 0)
                return -1;
    }
    return 0;
}
