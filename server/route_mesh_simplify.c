/*
 * route_mesh_simplify.c - POST /v1/meshes/simplify?faces=N|ratio=R
 *                         &format=glb|ply|obj&interp=exact|paper
 *
 * The body is a triangle mesh (PLY ascii or binary, OBJ, GLB; sniffed);
 * the answer is the same mesh simplified by vertex clustering with
 * face-count control (Kanaya et al.; lib/mesh/cluster.h), exactly what
 * `gigaview simplify` writes.  The selection runs on the server's GPU
 * context when it has one (the same mesh as the CPU's, byte for byte).
 * X-Faces-Asked, X-Faces and X-Vertices tell the counts.
 *
 * Limits, each a configuration key: the body (simplify_max_bytes, 413,
 * refused before reading when announced), the input's triangles and the
 * faces asked (simplify_max_faces, 413; vertices up to three times that),
 * and the octree's building time (simplify_time_limit, 504).  A malformed
 * file is 400 with the reader's message, an unsupported variant (big-endian
 * PLY, external glTF buffers) 501.
 *
 * The work runs on the HTTP thread that received the body, inside
 * gigaviewd: not in the sandboxed filter worker processes (see
 * docs/API.md, "Mesh simplification", for this gap).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "mesh/cluster_run.h"
#include "routes.h"
#ifdef GV_HAVE_GPU
#include "gpu/gpu_cluster.h"
#endif

static int parse(struct req *r, struct gv_simplify_opts *o,
                 struct gv_error *err)
{
    const struct settings *cfg = r->srv->cfg;
    memset(o, 0, sizeof *o);
    o->ratio = -1;
    const char *f = http_query(r, "faces"), *ra = http_query(r, "ratio");
    if (!f == !ra)
        return gv_fail(err, GV_EINVAL, "simplify: give faces=N or ratio=R "
                       "(one of them)");
    if (f) {
        uint32_t n;
        if (http_parse_u32(f, UINT32_MAX, &n) < 0 || n == 0)
            return gv_fail(err, GV_EINVAL, "simplify: faces must be a "
                           "positive integer");
        o->faces = n;
    } else {
        char *end;
        o->ratio = strtod(ra, &end);
        if (end == ra || *end || !(o->ratio >= 0 && o->ratio <= 1))
            return gv_fail(err, GV_EINVAL, "simplify: ratio must be a number "
                           "in [0, 1]");
    }
    const char *fmt = http_query(r, "format");
    if (!fmt)
        fmt = "glb";
    if (gv_mesh_format_parse(fmt, &o->format) < 0 ||
        o->format == GV_MESH_QMESH)
        return gv_fail(err, GV_EINVAL, "simplify: format must be glb, ply or "
                       "obj");
    const char *in = http_query(r, "interp");
    if (in && strcmp(in, "paper") == 0)
        o->mode = GV_CLUSTER_PAPER;
    else if (in && strcmp(in, "exact") != 0)
        return gv_fail(err, GV_EINVAL, "simplify: interp must be exact or "
                       "paper");
    if (!r->body_len)
        return gv_fail(err, GV_EINVAL, "simplify: the body must be a mesh "
                       "file (PLY, OBJ or GLB)");
    uint64_t mf = cfg->simplify_max_faces;
    o->max_faces = (uint32_t)mf;
    o->lim.max_bytes = cfg->simplify_max_bytes;
    o->lim.max_tris = (uint32_t)mf;
    o->lim.max_verts = 3 * mf > UINT32_MAX ? UINT32_MAX : (uint32_t)(3 * mf);
    o->time_limit = cfg->simplify_time_limit;
#ifdef GV_HAVE_GPU
    if (r->srv->gpu) {
        o->select = gv_gpu_cluster_run;
        o->select_ctx = r->srv->gpu;
    }
#endif
    return 0;
}

enum MHD_Result route_mesh_simplify(struct req *r)
{
    struct gv_error err;
    struct gv_simplify_opts o;
    if (parse(r, &o, &err) < 0)
        return http_send_error(r, &err);
    uint8_t *out = NULL;
    size_t len = 0;
    struct gv_simplify_stats st;
    if (gv_simplify((const uint8_t *)r->body, r->body_len, &o, &out, &len,
                    &st, &err) < 0) {
        if (err.code == GV_ELIMIT && strstr(err.text, "limit"))
            strncat(err.text, " (simplify_max_faces or simplify_max_bytes)",
                    sizeof err.text - strlen(err.text) - 1);
        if (err.code == GV_ECORRUPT)   /* the client's file, not our data */
            err.code = GV_EINVAL;
        return http_send_error(r, &err);
    }
    struct MHD_Response *resp =
        http_response_owned(out, len, gv_mesh_format_mime(o.format));
    if (!resp)
        return http_send_errorf(r, GV_ENOMEM, "simplify: out of memory");
    http_header_int(resp, "X-Faces-Asked", (long long)st.asked);
    http_header_int(resp, "X-Faces", st.out_tris);
    http_header_int(resp, "X-Vertices", st.out_verts);
    MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                            "X-Faces-Asked, X-Faces, X-Vertices");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    return http_send(r, 200, resp, len);
}
