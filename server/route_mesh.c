/*
 * route_mesh.c - GET /v1/images/{id}/mesh?level=&region=x,y,w,h
 *                &max_error=E|max_triangles=N&format=glb|qmesh|ply|obj
 *
 * The TIN of a region of a height store by greedy insertion (lib/mesh,
 * Garland & Heckbert section 4.4), exactly as `gigaview mesh` makes it:
 * the grid spans samples x .. x+w and y .. y+h of the level (clamped), so
 * meshes of regions that tile a level share their border samples, and with
 * max_error the border vertices come from those samples alone: neighbours
 * join without cracks (docs/MESHES.md).  The measured error against the
 * decoded heights is in the body's metadata and in the X-Mesh-Max-Error
 * header, cached answers included (read back from the body).
 *
 * Limits, each a configuration key: the grid's samples (max_mesh_samples)
 * and the triangles (max_mesh_triangles) give 413, whether asked for or
 * needed to reach max_error; meshing longer than mesh_time_limit seconds
 * gives 504.  The work runs on a render thread and the answer is kept in
 * the output cache, like /region (render_call.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mesh/io/mesh_write.h"
#include "mesh/tin.h"
#include "output_cache.h"
#include "mesh/zfield.h"
#include "render/height_region.h"
#include "render_call.h"
#include "routes.h"
#include "store/geometry.h"

struct mesh_query {
    uint32_t level, x, y, w, h;
    double max_error;        /* < 0: not given */
    uint32_t max_triangles;  /* 0: not given */
    enum gv_mesh_format format;
    const char *format_name;
    int zfield;              /* method=zfield (lib/mesh/zfield.h) */
    /* from the configuration, copied on the HTTP thread */
    uint64_t max_samples, limit_triangles;
    double time_limit;
};

static int parse_query(struct req *r, struct mesh_query *q,
                       struct gv_error *err)
{
    const struct settings *cfg = r->srv->cfg;
    memset(q, 0, sizeof *q);
    q->max_error = -1;
    const char *s = http_query(r, "level");
    if (s && http_parse_u32(s, 64, &q->level) < 0)
        return gv_fail(err, GV_EINVAL, "mesh: level must be 0..64");
    s = http_query(r, "region");
    if (!s)
        return gv_fail(err, GV_EINVAL, "mesh: missing region=x,y,w,h");
    uint32_t *v[4] = {&q->x, &q->y, &q->w, &q->h};
    const char *p = s;
    for (int i = 0; i < 4; i++) {
        char num[16];
        size_t n = strcspn(p, ",");
        if (n == 0 || n >= sizeof num || (i < 3) != (p[n] == ','))
            return gv_fail(err, GV_EINVAL, "mesh: region must be four "
                           "non-negative integers x,y,w,h");
        memcpy(num, p, n);
        num[n] = 0;
        if (http_parse_u32(num, GV_MAX_DIM, v[i]) < 0)
            return gv_fail(err, GV_EINVAL, "mesh: region must be four "
                           "non-negative integers x,y,w,h");
        p += n + (i < 3);
    }
    if (q->w == 0 || q->h == 0)
        return gv_fail(err, GV_EINVAL, "mesh: region w and h must be at "
                       "least 1");
    s = http_query(r, "max_error");
    if (s) {
        char *end;
        q->max_error = strtod(s, &end);
        if (end == s || *end || !isfinite(q->max_error) || q->max_error < 0)
            return gv_fail(err, GV_EINVAL, "mesh: max_error must be a "
                           "finite number >= 0");
    }
    s = http_query(r, "max_triangles");
    if (s && (http_parse_u32(s, UINT32_MAX - 1, &q->max_triangles) < 0 ||
              q->max_triangles < 2))
        return gv_fail(err, GV_EINVAL, "mesh: max_triangles must be an "
                       "integer >= 2");
    if (q->max_error < 0 && !q->max_triangles)
        return gv_fail(err, GV_EINVAL, "mesh: give max_error or "
                       "max_triangles");
    if (q->max_triangles > cfg->max_mesh_triangles)
        return gv_fail(err, GV_ELIMIT, "mesh: %u triangles asked, at most "
                       "%llu (max_mesh_triangles)", q->max_triangles,
                       (unsigned long long)cfg->max_mesh_triangles);
    s = http_query(r, "method");
    if (s && strcmp(s, "greedy") && strcmp(s, "zfield"))
        return gv_fail(err, GV_EINVAL, "mesh: method must be greedy or zfield");
    q->zfield = s && !strcmp(s, "zfield");
    if (q->zfield && (q->max_error < 0 || q->max_triangles))
        return gv_fail(err, GV_EINVAL, "mesh: method=zfield takes max_error "
                       "(each removed vertex's vertical threshold), not "
                       "max_triangles");
    if (q->zfield && (q->w != q->h || !gv_zfield_side_ok(q->w + 1)))
        return gv_fail(err, GV_EINVAL, "mesh: method=zfield needs a square "
                       "region of 2^k x 2^k cells, not %ux%u", q->w, q->h);
    s = http_query(r, "format");
    q->format_name = s ? s : "glb";
    if (gv_mesh_format_parse(q->format_name, &q->format) < 0)
        return gv_fail(err, GV_EINVAL, "mesh: format must be glb, qmesh, "
                       "ply or obj");
    uint64_t samples = ((uint64_t)q->w + 1) * ((uint64_t)q->h + 1);
    if (samples > cfg->max_mesh_samples)
        return gv_fail(err, GV_ELIMIT, "mesh: a grid of %llu samples, at "
                       "most %llu (max_mesh_samples)",
                       (unsigned long long)samples,
                       (unsigned long long)cfg->max_mesh_samples);
    q->max_samples = cfg->max_mesh_samples;
    q->limit_triangles = cfg->max_mesh_triangles;
    q->time_limit = cfg->mesh_time_limit;
    return 0;
}

/* The grid of q in img's level: *gw x *gh samples.  0, or -1 with *err. */
static int place(const struct image *img, const struct mesh_query *q,
                 uint32_t *gw, uint32_t *gh, struct gv_error *err)
{
    const struct gv_geometry *g = &img->info->geometry;
    uint32_t lw, lh;
    if (gv_level_size(g, (int)q->level, &lw, &lh) < 0)
        return gv_fail(err, GV_EINVAL, "mesh: no level %u (0..%d)", q->level,
                       g->root + g->root_mips - 1);
    if ((uint64_t)q->x + q->w > lw || (uint64_t)q->y + q->h > lh)
        return gv_fail(err, GV_EINVAL, "mesh: region %u,%u,%u,%u outside "
                       "level %u (%ux%u)", q->x, q->y, q->w, q->h, q->level,
                       lw, lh);
    *gw = q->x + q->w < lw ? q->w + 1 : lw - q->x;
    *gh = q->y + q->h < lh ? q->h + 1 : lh - q->y;
    if (*gw < 2 || *gh < 2)
        return gv_fail(err, GV_EINVAL, "mesh: region %u,%u,%u,%u leaves a "
                       "grid of %ux%u samples; a mesh needs 2x2", q->x, q->y,
                       q->w, q->h, *gw, *gh);
    return 0;
}

/* On a render thread: decode, mesh, encode. */
static int render(void *arg, struct image *img, uint8_t **out, size_t *len,
                  struct gv_error *err)
{
    const struct mesh_query *q = arg;
    struct gv_decoder *d = image_decoder_get(img);
    struct gv_height_meta hm;
    uint16_t *codes = NULL;
    float *h = NULL;
    struct gv_mesh t = {0};
    uint32_t gw, gh;
    int rc = -1;
    if (!d) {
        gv_fail(err, GV_ENOMEM, "mesh: out of memory");
        goto out;
    }
    if (!gv_height_meta_get(d, &hm)) {
        gv_fail(err, GV_EINVAL, "mesh: %s is not a height store", img->id);
        goto out;
    }
    if (place(img, q, &gw, &gh, err) < 0)
        goto out;
    codes = malloc((size_t)gw * gh * sizeof *codes);
    h = malloc((size_t)gw * gh * sizeof *h);
    if (!codes || !h) {
        gv_fail(err, GV_ENOMEM, "mesh: out of memory");
        goto out;
    }
    if (gv_height_region(d, (int)q->level, q->x, q->y, gw, gh, codes, err) < 0)
        goto out;
    for (size_t i = 0; i < (size_t)gw * gh; i++)
        h[i] = (float)(codes[i] * hm.scale + hm.offset);
    uint32_t limit = (uint32_t)q->limit_triangles;
    if (q->zfield) {
        uint8_t *en = malloc((size_t)gw * gh);
        const struct gv_zfield_params zp = {.threshold = (float)q->max_error};
        if (!en)
            gv_fail(err, GV_ENOMEM, "mesh: out of memory");
        const int zrc = en && gv_zfield_enable(h, gw, &zp, en, err) == 0 &&
                                gv_zfield_mesh(h, gw, en, 1, &t, err) == 0 ? 0 : -1;
        free(en);
        if (zrc < 0)
            goto out;
        if (t.ntris > limit) {
            gv_fail(err, GV_ELIMIT, "mesh: threshold %g gives %u triangles, more "
                    "than %u (max_mesh_triangles)", q->max_error, t.ntris, limit);
            goto out;
        }
        goto encode;
    }
    struct gv_tin_params p = {
        .max_error = q->max_error,
        .max_triangles = q->max_triangles ? q->max_triangles : limit,
        .border_first = q->max_error >= 0,
        .time_limit = q->time_limit};
    if (gv_tin_build(h, gw, gh, gw, &p, &t, err) < 0) {
        if (err->code == GV_ELIMIT) {   /* said in the request's terms */
            gv_error_clear(err);
            gv_fail(err, GV_ELIMIT, "mesh: max_error %g needs more than %u "
                    "triangles (max_mesh_triangles)", q->max_error, limit);
        }
        goto out;
    }
    if (q->max_error >= 0 && !q->max_triangles &&
        t.max_error > q->max_error + 1e-9 * (1 + q->max_error)) {
        gv_fail(err, GV_ELIMIT, "mesh: max_error %g needs more than %u "
                "triangles (max_mesh_triangles)", q->max_error, limit);
        goto out;
    }
encode:;
    struct gv_mesh_place pl = {.x0 = q->x, .y0 = q->y, .level = q->level};
    rc = gv_mesh_encode(q->format, &t, &pl, NULL, out, len, err);
out:
    gv_mesh_free(&t);
    free(codes);
    free(h);
    image_decoder_put(img, d);
    return rc;
}

/* X-Mesh-Max-Error from the body's metadata, which every format carries
 * (mesh_write.h), so that answers from the output cache have it too. */
static void body_headers(const uint8_t *body, size_t len,
                         struct MHD_Response *resp)
{
    static const char *const keys[] = {"\"maxError\":", "max_error "};
    for (int k = 0; k < 2; k++) {
        size_t kl = strlen(keys[k]);
        const uint8_t *p = memmem(body, len, keys[k], kl);
        if (!p)
            continue;
        char num[40];
        size_t i = 0, off = (size_t)(p - body) + kl;
        while (off + i < len && i + 1 < sizeof num &&
               strchr("0123456789.eE+-", body[off + i])) {
            num[i] = (char)body[off + i];
            i++;
        }
        num[i] = 0;
        if (i) {
            MHD_add_response_header(resp, "X-Mesh-Max-Error", num);
            MHD_add_response_header(resp, "Access-Control-Expose-Headers",
                                    "X-Mesh-Max-Error");
        }
        return;
    }
}

enum MHD_Result route_mesh(struct req *r)
{
    if (render_call_resumed(r))
        return render_call_finish(r);
    enum MHD_Result ret;
    struct gv_error err = {0};
    struct mesh_query q;
    uint32_t gw, gh;
    if (parse_query(r, &q, &err) < 0)
        return http_send_error(r, &err);
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    struct mesh_query *arg = malloc(sizeof *arg);
    if (!arg || place(img, &q, &gw, &gh, &err) < 0) {
        free(arg);
        image_put(img);
        if (!arg)
            return http_send_errorf(r, GV_ENOMEM, "mesh: out of memory");
        return http_send_error(r, &err);
    }
    *arg = q;
    char canon[400], key[420], etag[OUTPUT_ETAG_SIZE];
    snprintf(canon, sizeof canon, "mesh/%s/%u/%u,%u,%u,%u e%.17g n%u l%llu%s.%s",
             img->id, q.level, q.x, q.y, q.w, q.h, q.max_error,
             q.max_triangles, (unsigned long long)q.limit_triangles,
             q.zfield ? " zfield" : "",
             gv_mesh_format_ext(q.format));
    snprintf(key, sizeof key, "%llu %s", (unsigned long long)img->serial, canon);
    output_cache_etag(img->identity, canon, etag, sizeof etag);
    struct render_spec spec = {
        .module = "mesh", .key = key, .etag = etag,
        .mime = gv_mesh_format_mime(q.format), .render = render,
        .headers = render_call_cache_day, .body_headers = body_headers, .arg = arg};
    return render_call_serve(r, img, &spec);
}
