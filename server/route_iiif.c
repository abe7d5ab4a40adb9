/*
 * route_iiif.c - IIIF Image API 3.0, compliance level 2, at /iiif/3/.
 *
 *   GET /iiif/3/{id}                303 to .../info.json (baseUriRedirect)
 *   GET /iiif/3/{id}/info.json      the image information document
 *   GET /iiif/3/{id}/{region}/{size}/{rotation}/{quality}.{format}
 *
 * Parsing and validation are iiif_parse's (server/iiif.c, a pure
 * function); this file builds info.json, renders with gv_render on a
 * pooled CPU decoder and encodes.  Every response carries
 * Access-Control-Allow-Origin: * (the IIIF routes ignore cors_origin), and
 * errors use the statuses the specification lists (400, 404, 501; limits
 * are 400, since the specification knows no 413).  Image responses carry
 * the canonical URI and the compliance profile in Link headers.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "iiif.h"
#include "imageio/imageio.h"
#include "log.h"
#include "metrics.h"
#include "render/region.h"
#include "routes.h"

#define IIIF_CONTEXT "http://iiif.io/api/image/3/context.json"
#define IIIF_PROFILE_LINK "<http://iiif.io/api/image/3/level2.json>;rel=\"profile\""

static void limits_of(const struct settings *cfg, struct iiif_limits *l)
{
    l->max_width = (uint32_t)cfg->max_output_side;
    l->max_height = (uint32_t)cfg->max_output_side;
    l->max_area = cfg->max_output_pixels;
    l->max_upscale = cfg->max_upscale;
}

enum MHD_Result route_iiif_base(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    char base[300], loc[600];
    http_base_url(r, base, sizeof base);
    snprintf(loc, sizeof loc, "%s/iiif/3/%s/info.json", base, img->id);
    image_put(img);
    return http_send_empty(r, 303, MHD_HTTP_HEADER_LOCATION, loc);
}

enum MHD_Result route_iiif_info(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    const struct gv_geometry *g = &img->info->geometry;
    struct iiif_limits lim;
    limits_of(r->srv->cfg, &lim);
    char base[300], id[600];
    http_base_url(r, base, sizeof base);
    snprintf(id, sizeof id, "%s/iiif/3/%s", base, img->id);

    /* sizes: every pyramid level (root mips, root, tiled levels) whose
     * whole image is within the output limits, smallest first: each is
     * decoded without resampling. */
    json_t *sizes = json_array();
    for (int m = g->root_mips - 1; m >= 1; m--) {
        uint32_t w, h;
        if (gv_store_root(img->store, m, &w, &h))
            json_array_append_new(sizes, json_pack("{s:I,s:I}", "width",
                                                   (json_int_t)w, "height",
                                                   (json_int_t)h));
    }
    for (int k = g->root; k >= 0; k--) {
        uint32_t w = g->level[k].width, h = g->level[k].height;
        if (w > lim.max_width || h > lim.max_height ||
            (uint64_t)w * h > lim.max_area)
            break;
        json_array_append_new(sizes, json_pack("{s:I,s:I}", "width",
                                               (json_int_t)w, "height",
                                               (json_int_t)h));
    }
    json_t *factors = json_array();
    for (int k = 0; k <= g->root; k++)
        json_array_append_new(factors, json_integer((json_int_t)1 << k));
    json_t *j = json_pack(
        "{s:s,s:s,s:s,s:s,s:s,s:I,s:I,s:I,s:I,s:I,s:o,"
        "s:[{s:i,s:i,s:o}],s:[s,s],s:[s,s,s],s:[s,s,s,s,s]}",
        "@context", IIIF_CONTEXT, "id", id, "type", "ImageService3",
        "protocol", "http://iiif.io/api/image", "profile", "level2",
        "width", (json_int_t)g->width, "height", (json_int_t)g->height,
        "maxWidth", (json_int_t)lim.max_width,
        "maxHeight", (json_int_t)lim.max_height,
        "maxArea", (json_int_t)lim.max_area,
        "sizes", sizes,
        "tiles", "width", 512, "height", 512, "scaleFactors", factors,
        "extraFormats", "webp", "tif",
        "extraQualities", "color", "gray", "bitonal",
        "extraFeatures", "mirroring", "rotationBy90s", "sizeUpscaling",
        "canonicalLinkHeader", "profileLinkHeader");
    image_put(img);
    if (!j)
        return http_send_errorf(r, GV_ENOMEM, "iiif: cannot build info.json");
    char *s = json_dumps(j, JSON_INDENT(2));
    json_decref(j);
    if (!s)
        return http_send_errorf(r, GV_ENOMEM, "iiif: cannot build info.json");
    size_t n = strlen(s);
    s[n] = '\n';
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback(n + 1, s, free);
    if (!resp) {
        free(s);
        return http_send(r, 500, NULL, 0);
    }
    /* JSON-LD only when asked for (spec 5.1); otherwise plain JSON with
     * the context in a Link header. */
    const char *accept = http_header(r, "Accept");
    if (accept && strstr(accept, "application/ld+json")) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
                                "application/ld+json;profile=\"" IIIF_CONTEXT "\"");
    } else {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
                                "application/json");
        MHD_add_response_header(resp, "Link",
                                "<" IIIF_CONTEXT ">; rel=\"http://www.w3.org/ns/"
                                "json-ld#context\"; type=\"application/ld+json\"");
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=86400");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY, "Accept");
    return http_send(r, 200, resp, n + 1);
}

static const char *quality_name(enum gv_quality q)
{
    switch (q) {
    case GV_QUALITY_COLOR: return "color";
    case GV_QUALITY_GRAY: return "gray";
    case GV_QUALITY_BITONAL: return "bitonal";
    default: return "default";
    }
}

static const char *content_type(const char *format)
{
    if (!strcmp(format, "jpg"))
        return "image/jpeg";
    if (!strcmp(format, "png"))
        return "image/png";
    if (!strcmp(format, "webp"))
        return "image/webp";
    if (!strcmp(format, "tif"))
        return "image/tiff";
    return "application/octet-stream";
}

/* The canonical URI of a parsed request (spec 4.7) into buf. */
static void canonical(struct req *r, const struct image *img,
                      const struct iiif_request *q, char *buf, size_t size)
{
    const struct gv_render_req *p = &q->render;
    const struct gv_geometry *g = &img->info->geometry;
    char base[300], region[64], sz[48];
    http_base_url(r, base, sizeof base);
    if (p->x == 0 && p->y == 0 && p->w == g->width && p->h == g->height)
        snprintf(region, sizeof region, "full");
    else
        snprintf(region, sizeof region, "%u,%u,%u,%u", p->x, p->y, p->w, p->h);
    if (p->out_w == p->w && p->out_h == p->h)
        snprintf(sz, sizeof sz, "max");
    else
        snprintf(sz, sizeof sz, "%s%u,%u",
                 p->out_w > p->w || p->out_h > p->h ? "^" : "", p->out_w,
                 p->out_h);
    snprintf(buf, size, "<%s/iiif/3/%s/%s/%s/%s%d/%s.%s>;rel=\"canonical\"",
             base, img->id, region, sz, p->mirror ? "!" : "", p->rotation,
             quality_name(p->quality), q->format);
}

enum MHD_Result route_iiif_image(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    const struct gv_geometry *g = &img->info->geometry;
    struct iiif_limits lim;
    limits_of(r->srv->cfg, &lim);
    struct iiif_request q;
    struct gv_error err;
    uint8_t *pix = NULL, *out = NULL;
    struct gv_decoder *d = NULL;
    size_t len;
    uint32_t w, h;
    int c;
    if (iiif_parse(r->param[1], r->param[2], r->param[3], r->param[4],
                   g->width, g->height, &lim, &q, &err) < 0) {
        ret = http_send_error(r, &err);
        goto out;
    }
    /* gv_render decodes at most 2x oversampled, so a request within
     * maxArea decodes at most about 4 x maxArea pixels (plus a pixel of
     * rounding per edge); /region's max_region_pixels does not apply, or
     * info.json would advertise sizes the server refuses. */
    q.render.max_decode_pixels = 4 * (r->srv->cfg->max_output_pixels +
                                      2 * r->srv->cfg->max_output_side + 1);
    d = image_decoder_get(img);
    if (!d) {
        ret = http_send_errorf(r, GV_ENOMEM, "iiif: out of memory");
        goto out;
    }
    if (gv_render(d, &q.render, &pix, &w, &h, &c, &err) < 0 ||
        gv_image_encode(q.format, w, h, c, pix,
                        (int)r->srv->cfg->jpeg_quality, &out, &len, &err) < 0) {
        if (err.code == GV_ECORRUPT || err.code == GV_EIO) { /* the store */
            atomic_fetch_add(&metrics.page_errors, 1);
            log_msg(LOG_ERROR, "iiif", "%s: %s", img->id, err.text);
        }
        ret = http_send_error(r, &err);
        goto out;
    }
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback(len, out, free);
    if (resp) {
        out = NULL;
        char link[1024];
        canonical(r, img, &q, link, sizeof link);
        strncat(link, ", " IIIF_PROFILE_LINK, sizeof link - strlen(link) - 1);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
                                content_type(q.format));
        MHD_add_response_header(resp, "Link", link);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                                "public, max-age=86400");
    }
    ret = http_send(r, 200, resp, len);
out:
    image_decoder_put(img, d);
    free(pix);
    free(out);
    image_put(img);
    return ret;
}
