/*
 * route_iiif.c - IIIF Image API 3.0, compliance level 2, at /iiif/3/.
 *
 *   GET /iiif/3/{id}                303 to .../info.json (baseUriRedirect)
 *   GET /iiif/3/{id}/info.json      the image information document
 *   GET /iiif/3/{id}/{region}/{size}/{rotation}/{quality}.{format}
 *
 * Parsing and validation are iiif_parse's (server/iiif.c, a pure
 * function); this file builds info.json and describes each image request
 * (its canonical path, ETag and render function) to render_call.c, which
 * answers from If-None-Match or the output cache, or renders with
 * gv_render on a render thread (the connection suspended meanwhile).
 * Every response carries
 * Access-Control-Allow-Origin: * (the IIIF routes ignore cors_origin), and
 * errors use the statuses the specification lists (400, 404, 501; limits
 * are 400, since the specification knows no 413).  Image responses carry
 * the canonical URI and the compliance profile in Link headers.  An
 * extra query parameter `window` (render/window.h) maps the decoded
 * samples through a display window before resampling; it is part of the
 * cache key and the ETag (the canonical URI stays the IIIF one).  Without
 * it the store's default window applies (catalog.h), so the output stays
 * 8-bit through it; `window=none` asks for none.
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "iiif.h"
#include "output_cache.h"
#include "render_call.h"
#include "render_stages.h"
#include "imageio/imageio.h"
#include "imageio/output_format.h"
#include "render/region.h"
#include "render/samples_region.h"
#include "render/window.h"
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

/* "{base}/iiif/3/{id}" into buf. */
static void service_id(struct req *r, const struct image *img, char *buf,
                       size_t size)
{
    char base[300];
    http_base_url(r, base, sizeof base);
    snprintf(buf, size, "%s/iiif/3/%s", base, img->id);
}

enum MHD_Result route_iiif_base(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    char id[600], loc[620];
    service_id(r, img, id, sizeof id);
    snprintf(loc, sizeof loc, "%s/info.json", id);
    image_put(img);
    return http_send_empty(r, 303, MHD_HTTP_HEADER_LOCATION, loc);
}

static json_t *size_json(uint32_t w, uint32_t h)
{
    return json_pack("{s:I,s:I}", "width", (json_int_t)w, "height", (json_int_t)h);
}

/* info.json's sizes: every pyramid level (root mips, root, tiled levels)
 * whose whole image is within the output limits, smallest first: each is
 * decoded without resampling. */
static json_t *sizes_json(const struct image *img, const struct iiif_limits *lim)
{
    const struct gv_geometry *g = &img->info->geometry;
    json_t *sizes = json_array();
    for (int m = g->root_mips - 1; m >= 1; m--) {
        uint32_t w, h;
        if (gv_store_root(img->store, m, &w, &h))
            json_array_append_new(sizes, size_json(w, h));
    }
    for (int k = g->root; k >= 0; k--) {
        uint32_t w = g->level[k].width, h = g->level[k].height;
        if ((lim->max_width && w > lim->max_width) ||
            (lim->max_height && h > lim->max_height) ||
            (lim->max_area && (uint64_t)w * h > lim->max_area))
            break;
        json_array_append_new(sizes, size_json(w, h));
    }
    return sizes;
}

/* The image information document (spec 5), or NULL. */
/* The IIIF Physical Dimensions service (IIIF Services Annex) of a store
 * whose metadata gives microns per pixel (a whole slide's slide.mpp_x),
 * in millimetres per pixel; NULL for any other. */
static json_t *physdim_json(const struct image *img)
{
    const char *meta = gv_store_meta(img->store);
    json_t *m = meta ? json_loads(meta, 0, NULL) : NULL;
    json_t *mpp = json_object_get(m, "slide.mpp_x");
    json_t *s = NULL;
    if (json_is_number(mpp) && json_number_value(mpp) > 0)
        s = json_pack("{s:s,s:s,s:f,s:s}",
                      "@context", "http://iiif.io/api/annex/services/physdim/1/context.json",
                      "profile", "http://iiif.io/api/annex/services/physdim",
                      "physicalScale", json_number_value(mpp) / 1000.0,
                      "physicalUnits", "mm");
    json_decref(m);
    return s;
}

static json_t *info_json(struct req *r, const struct image *img)
{
    const struct gv_geometry *g = &img->info->geometry;
    struct iiif_limits lim;
    limits_of(r->srv->cfg, &lim);
    char id[600];
    service_id(r, img, id, sizeof id);
    json_t *factors = json_array();
    for (int k = 0; k <= g->root; k++)
        json_array_append_new(factors, json_integer((json_int_t)1 << k));
    /* Image API 3.0 section 5.3: maxWidth, maxHeight and maxArea are
     * optional, an absent one meaning no such limit; a limit of 0 is
     * "none" (iiif.h), so it is left out rather than sent as 0. */
    json_t *info = json_pack(
        "{s:s,s:s,s:s,s:s,s:s,s:I,s:I,s:o,"
        "s:[{s:i,s:i,s:o}],s:[s,s],s:[s,s,s],s:[s,s,s,s,s]}",
        "@context", IIIF_CONTEXT, "id", id, "type", "ImageService3",
        "protocol", "http://iiif.io/api/image", "profile", "level2",
        "width", (json_int_t)g->width, "height", (json_int_t)g->height,
        "sizes", sizes_json(img, &lim),
        "tiles", "width", 512, "height", 512, "scaleFactors", factors,
        "extraFormats", "webp", "tif",
        "extraQualities", "color", "gray", "bitonal",
        "extraFeatures", "mirroring", "rotationBy90s", "sizeUpscaling",
        "canonicalLinkHeader", "profileLinkHeader");
    const struct { const char *key; uint64_t v; } max[3] = {
        {"maxWidth", lim.max_width}, {"maxHeight", lim.max_height},
        {"maxArea", lim.max_area}};
    for (int i = 0; info && i < 3; i++)
        if (max[i].v)
            json_object_set_new(info, max[i].key, json_integer((json_int_t)max[i].v));
    json_t *physdim = physdim_json(img);
    if (info && physdim)
        json_object_set_new(info, "service", json_pack("[o]", physdim));
    else
        json_decref(physdim);
    return info;
}

enum MHD_Result route_iiif_info(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    json_t *j = info_json(r, img);
    /* A protected image (shown to its group: http.c let it through)
     * names its IIIF Authorization Flow 2.0 services, and their context
     * comes first (Image API 3.0 section 5.1: extensions before the
     * image context). */
    if (j && http_access(r, img->id) == ACCESS_GRANTED) {
        json_object_set_new(j, "@context", json_pack(
            "[s,s]", "http://iiif.io/api/auth/2/context.json", IIIF_CONTEXT));
        json_t *services = auth_services_json(r, img->id);
        json_array_extend(services, json_object_get(j, "service"));
        json_object_set_new(j, "service", services);
    }
    image_put(img);
    /* JSON-LD only when asked for (spec 5.1); otherwise plain JSON with
     * the context in a Link header. */
    const char *accept = http_header(r, "Accept");
    int ld = accept && strstr(accept, "application/ld+json");
    size_t len;
    struct MHD_Response *resp = http_response_json(
        j, JSON_INDENT(2) | JSON_REAL_PRECISION(10),
        ld ? "application/ld+json;profile=\"" IIIF_CONTEXT "\"" : "application/json",
        &len);
    if (!resp)
        return http_send_errorf(r, GV_ENOMEM, "iiif: cannot build info.json");
    if (!ld)
        MHD_add_response_header(resp, "Link",
                                "<" IIIF_CONTEXT ">; rel=\"http://www.w3.org/ns/"
                                "json-ld#context\"; type=\"application/ld+json\"");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=86400");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_VARY, "Accept");
    return http_send(r, 200, resp, len);
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

/* The canonical path of a parsed request after the identifier (spec 4.7):
 * "{region}/{size}/{rotation}/{quality}.{format}", into buf. */
static void canonical_path(const struct image *img, const struct iiif_request *q,
                           char *buf, size_t size)
{
    const struct gv_render_req *p = &q->render;
    const struct gv_geometry *g = &img->info->geometry;
    char region[64], sz[48];
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
    snprintf(buf, size, "%s/%s/%s%d/%s.%s", region, sz, p->mirror ? "!" : "",
             p->rotation, quality_name(p->quality), q->format);
}

/* A request being rendered (render_call.h's arg). */
struct iiif_call {
    struct iiif_request q;
    struct gv_window window;   /* count 0: none */
    struct gv_colours colours; /* a sample store's; count 0: not given */
    int jpeg_quality;
    char link[1024];   /* canonical URI and profile, as a Link header */
};

/* Each render thread's pixel buffer, kept between renders (gv_render_to)
 * up to KEEP_BYTES: a 512-pixel tile's fresh 768 KiB mapping and its page
 * faults on every render cost a fifth of the CPU of a cold pass
 * (bench/README.md, 2026-12-02).  Larger answers are let go at once. */
#define KEEP_BYTES (4u << 20)
struct pix_buf {
    uint8_t *p;
    size_t cap;
};
static pthread_key_t pix_key;
static pthread_once_t pix_once = PTHREAD_ONCE_INIT;

static void pix_free(void *b)
{
    free(((struct pix_buf *)b)->p);
    free(b);
}

static void pix_key_make(void)
{
    (void)pthread_key_create(&pix_key, pix_free);
}

/* This thread's buffer (freed when the thread ends), or NULL. */
static struct pix_buf *pix_get(void)
{
    pthread_once(&pix_once, pix_key_make);
    struct pix_buf *b = pthread_getspecific(pix_key);
    if (!b && (b = calloc(1, sizeof *b)) != NULL &&
        pthread_setspecific(pix_key, b) != 0) {
        free(b);
        b = NULL;
    }
    return b;
}

/* On a render thread: render and encode c's request of img. */
static int render(void *arg, struct image *img, uint8_t **out, size_t *len,
                  struct gv_error *err)
{
    struct iiif_call *c = arg;
    struct gv_decoder *d = image_decoder_get(img);
    if (!d)
        return gv_fail(err, GV_ENOMEM, "iiif: out of memory");
    struct pix_buf own = {0}, *b = pix_get();
    if (!b)
        b = &own;   /* no thread buffer: this render's own */
    uint32_t w, h;
    int ch;
    gv_decoder_times(d, &(struct gv_decode_times){0}, 1);
    double t0 = render_stages_now();
    int rc = gv_render_to(d, &c->q.render, &b->p, &b->cap, &w, &h, &ch, err);
    const uint8_t *pix = b->p;
    double t1 = render_stages_now();
    render_stages_decoder(d, t1 - t0);
    if (rc == 0) {
        rc = gv_image_encode(c->q.format, w, h, ch, pix, c->jpeg_quality, out,
                             len, err) < 0 ? -1 : 0;
        render_stages_add(STAGE_ENCODE, render_stages_now() - t1);
    }
    image_decoder_put(img, d);
    if (b == &own || b->cap > KEEP_BYTES) {
        free(b->p);
        b->p = NULL;
        b->cap = 0;
    }
    return rc;
}

static void add_headers(void *arg, struct req *r, struct image *img,
                        struct MHD_Response *resp)
{
    (void)r;
    (void)img;
    struct iiif_call *c = arg;
    MHD_add_response_header(resp, "Link", c->link);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL,
                            "public, max-age=86400");
}

/* Parse r's request for img into c.  0, or -1 with *err. */
static int parse(struct req *r, const struct image *img, struct iiif_call *c,
                 struct gv_error *err)
{
    const struct gv_geometry *g = &img->info->geometry;
    struct iiif_limits lim;
    limits_of(r->srv->cfg, &lim);
    if (iiif_parse(r->param[1], r->param[2], r->param[3], r->param[4],
                   g->width, g->height, &lim, &c->q, err) < 0)
        return -1;
    /* gv_render decodes at most 2x oversampled, so a request within
     * maxArea decodes at most about 4 x maxArea pixels (plus a pixel of
     * rounding per edge): that is the bound of an IIIF decode, which
     * max_output_pixels sets (conf/gigaviewd.conf says so).  /region's
     * max_region_pixels does not apply, or info.json would advertise
     * sizes the server refuses. */
    c->q.render.max_decode_pixels = 4 * (r->srv->cfg->max_output_pixels +
                                         2 * r->srv->cfg->max_output_side + 1);
    c->jpeg_quality = (int)r->srv->cfg->jpeg_quality;
    /* No window: the store's default (count 0: none, or a sample store's
     * codes' range); "none": none.  No colours: the store's. */
    const char *ws = http_query(r, "window"), *cs = http_query(r, "colours");
    c->window = ws ? (struct gv_window){0} : img->window;
    if ((ws && strcmp(ws, "none") != 0 &&
         gv_window_parse(ws, 65535, &c->window, err) < 0) ||
        (cs && gv_colours_parse(cs, &c->colours, err) < 0) ||
        gv_display_check(&img->info->header, &c->window, &c->colours, err) < 0)
        return -1;
    c->q.render.window = &c->window;
    c->q.render.colours = cs ? &c->colours : &img->colours;
    return 0;
}

enum MHD_Result route_iiif_image(struct req *r)
{
    if (render_call_resumed(r))
        return render_call_finish(r);
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    struct gv_error err = {0};
    struct iiif_call *c = calloc(1, sizeof *c);
    if (!c) {
        image_put(img);
        return http_send_errorf(r, GV_ENOMEM, "iiif: out of memory");
    }
    if (parse(r, img, c, &err) < 0) {
        free(c);
        image_put(img);
        return http_send_error(r, &err);
    }
    char id[600], path[200], canon[900 + GV_DISPLAY_KEY_MAX];
    char key[sizeof canon + 24], etag[OUTPUT_ETAG_SIZE];
    char win[GV_DISPLAY_KEY_MAX];
    gv_display_key(&c->window, &c->colours, win);
    service_id(r, img, id, sizeof id);
    canonical_path(img, &c->q, path, sizeof path);
    snprintf(c->link, sizeof c->link, "<%s/%s>;rel=\"canonical\", "
             IIIF_PROFILE_LINK, id, path);
    /* The ETag and the cache key name the image, not the host it was
     * asked through: the bytes do not depend on it. */
    snprintf(canon, sizeof canon, "iiif/%s/%s q%d%s", img->id, path,
             c->jpeg_quality, win);
    snprintf(key, sizeof key, "%llu %s", (unsigned long long)img->serial, canon);
    output_cache_etag(img->identity, canon, etag, sizeof etag);
    struct render_spec spec = {
        .module = "iiif", .key = key, .etag = etag,
        .mime = gv_output_format_image(c->q.format)->mime,
        .render = render, .headers = add_headers, .arg = c};
    return render_call_serve(r, img, &spec);
}
