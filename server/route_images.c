/*
 * route_images.c - GET /v1/images (the list), GET /v1/images/{id} (one
 * image's metadata: geometry, tile grid per level, sizes, links) and
 * GET /v1/images/{id}/root (the lossless root level or one of its mips,
 * as PNG or raw samples for GPU clients; the root level also as the
 * lossless WebP the store keeps, the fewest bytes).  http.c checks the
 * access policy before the last two run; the list leaves out the images
 * hidden from the caller.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "imageio/imageio.h"
#include "imageio/output_format.h"
#include "routes.h"
#include "store/geometry.h"

static double bpp(uint64_t bytes, uint64_t pixels)
{
    return pixels ? (double)bytes * 8.0 / (double)pixels : 0.0;
}

enum MHD_Result route_images_list(struct req *r)
{
    struct image **imgs;
    int n = catalog_list(r->srv->catalog, &imgs);
    if (n < 0)
        return http_send_errorf(r, GV_ENOMEM, "images: out of memory");
    json_t *arr = json_array();
    for (int i = 0; i < n; i++) {
        const struct gv_geometry *g = &imgs[i]->info->geometry;
        /* Hidden images are left out; a protected one says whether this
         * caller may see it (access.h). */
        enum access_verdict v = http_access(r, imgs[i]->id);
        json_t *e = v == ACCESS_HIDDEN ? NULL : json_pack(
            "{s:s,s:I,s:I,s:i,s:i,s:I}", "id", imgs[i]->id,
            "width", (json_int_t)g->width, "height", (json_int_t)g->height,
            "levels", g->root + 1, "channels", g->channels,
            "bytes", (json_int_t)imgs[i]->bytes);
        if (e && v != ACCESS_PUBLIC)
            json_object_set_new(e, "access", json_string(
                v == ACCESS_GRANTED ? "granted" : "restricted"));
        if (e)
            json_array_append_new(arr, e);
        image_put(imgs[i]);
    }
    /* The list depends on who asks once some image is protected. */
    if (http_policy(r))
        r->private_answer = 1;
    free(imgs);
    return http_send_json(r, 200, json_pack("{s:o}", "images", arr));
}

enum MHD_Result route_image_info(struct req *r)
{
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    const struct gv_geometry *g = &img->info->geometry;
    const struct gv_header *h = &img->info->header;
    json_t *levels = json_array();
    for (int k = 0; k < g->root; k++) {
        const struct gv_level *l = &g->level[k];
        uint64_t b = gv_store_level_bytes(img->store, k);
        json_array_append_new(levels, json_pack(
            "{s:i,s:I,s:I,s:I,s:I,s:I,s:I,s:I,s:f}", "level", k,
            "width", (json_int_t)l->width, "height", (json_int_t)l->height,
            "tiles_x", (json_int_t)l->tiles_x, "tiles_y", (json_int_t)l->tiles_y,
            "pages_x", (json_int_t)l->pages_x, "pages_y", (json_int_t)l->pages_y,
            "bytes", (json_int_t)b,
            "bpp", bpp(b, (uint64_t)l->width * l->height)));
    }
    json_t *mips = json_array();
    for (int m = 0; m < g->root_mips; m++) {
        uint32_t w, hh;
        if (gv_store_root(img->store, m, &w, &hh))
            json_array_append_new(mips, json_pack("{s:i,s:I,s:I}", "level",
                                                  g->root + m, "width",
                                                  (json_int_t)w, "height",
                                                  (json_int_t)hh));
    }
    char base[300], self[600], tiles[700], root[700], iiif[700], region[700],
        batch[700];
    http_base_url(r, base, sizeof base);
    snprintf(self, sizeof self, "%s/v1/images/%s", base, img->id);
    snprintf(tiles, sizeof tiles, "%s/tiles/{level}/{tx}/{ty}", self);
    snprintf(batch, sizeof batch, "%s/batch", self);
    snprintf(root, sizeof root, "%s/root", self);
    snprintf(region, sizeof region, "%s/region{?level,x,y,w,h,format}", self);
    snprintf(iiif, sizeof iiif, "%s/iiif/3/%s/info.json", base, img->id);
    json_t *j = json_pack(
        "{s:s,s:I,s:I,s:i,s:i,s:I,s:f,s:i,s:i,s:i,s:i,s:i,s:i,s:f,s:f,"
        "s:{s:i,s:I,s:I,s:I,s:i,s:I,s:o},s:o,s:{s:s,s:s,s:s,s:s,s:s,s:s}}",
        "id", img->id, "width", (json_int_t)g->width,
        "height", (json_int_t)g->height, "channels", g->channels,
        "format_version", (int)h->version, "bytes", (json_int_t)img->bytes,
        "bpp", bpp(img->bytes, (uint64_t)g->width * g->height),
        "tile_size", GV_TILE, "tile_overlap", GV_TILE - GV_STEP,
        "tile_step", GV_STEP, "page_tiles", GV_PAGE_TILES,
        "levels_tiled", g->root, "max_rate", (int)h->max_rate,
        "psnr_db", h->psnr0_mdb / 1000.0, "target_psnr_db",
        h->target_mpsnr / 1000.0,
        "root", "level", g->root, "width", (json_int_t)g->level[g->root].width,
        "height", (json_int_t)g->level[g->root].height,
        "bytes", (json_int_t)h->root_size, "mip_count", g->root_mips,
        "side", (json_int_t)g->root_side,
        "mips", mips,
        "levels", levels,
        "links", "self", self, "tiles", tiles, "batch", batch, "root", root,
        "region", region, "iiif", iiif);
    if (j && h->kind == GV_KIND_HEIGHT)   /* docs/FORMAT.md section 12 */
        json_object_set_new(j, "elevation", json_pack(
            "{s:s,s:f,s:f,s:f,s:f,s:f,s:i,s:b}", "unit", h->height_unit,
            "scale", h->height_scale, "offset", h->height_offset,
            "min", (double)h->height_min, "max", (double)h->height_max,
            "max_error", h->height_max_error, "error_codes", (int)h->height_e,
            "float_source", (int)h->height_float));
    if (j && h->kind == GV_KIND_SAMPLES)   /* docs/FORMAT.md section 13 */
        json_object_set_new(j, "samples", json_pack(
            "{s:i,s:f,s:f,s:f,s:f,s:f,s:i,s:b,s:i,s:i}", "bits", 16,
            "scale", h->height_scale, "offset", h->height_offset,
            "min", (double)h->height_min, "max", (double)h->height_max,
            "max_error", h->height_max_error, "error_codes", (int)h->height_e,
            "float_source", (int)h->height_float,
            "code_min", (int)h->samples_lo, "code_max", (int)h->samples_hi));
    /* What the input said of its pixels (docs/FORMAT.md section 6,
     * metadata section): a slide's microns per pixel, a raster's
     * georeference. */
    const char *meta = gv_store_meta(img->store);
    if (j && meta)
        json_object_set_new(j, "metadata", json_loads(meta, 0, NULL));
    /* The default display window the server applies (docs/API.md). */
    if (j && img->window.count) {
        char win[GV_WINDOW_MAX_CHANNELS * 32];
        gv_window_format(&img->window, win, sizeof win);
        json_object_set_new(j, "window", json_string(win));
    }
    image_put(img);
    if (!j)
        return http_send_errorf(r, GV_ENOMEM, "images: cannot build JSON");
    return http_send_json(r, 200, j);
}

/* The forms of GET .../root (docs/API.md). */
enum root_form { ROOT_PNG, ROOT_RAW, ROOT_WEBP };

/* A response with the root mip px (w x h) of img as raw samples or as
 * PNG, or the root level as the store keeps it (the lossless WebP of
 * docs/FORMAT.md section 6, read from the file: nothing is encoded): 0
 * with *resp (NULL on allocation failure) and *len, or -1 with *err when
 * the PNG encoder or the store read fails. */
static int root_response(const struct image *img, const uint8_t *px,
                         uint32_t w, uint32_t h, enum root_form form,
                         struct MHD_Response **resp, size_t *len,
                         struct gv_error *err)
{
    int c = img->info->geometry.channels;
    if (form == ROOT_WEBP) {
        uint8_t *webp;
        if (gv_store_read_root_webp(img->store, &webp, len, err) < 0)
            return -1;
        *resp = http_response_owned(webp, *len, "image/webp");
        return 0;
    }
    /* A height or sample store's root holds 16-bit codes (host order,
     * which is little-endian on every supported host): raw gives them,
     * png a 16-bit PNG (a sample store of more than 4 channels has raw
     * only). */
    int codes = gv_header_codes(&img->info->header);
    if (codes && c > 4 && form == ROOT_PNG)
        return gv_fail(err, GV_EINVAL, "root: a PNG holds up to 4 channels, "
                       "this image has %d (ask for format=raw)", c);
    int raw = form == ROOT_RAW;
    const struct gv_output_format *f = gv_output_format_find(raw ? "raw" : "png");
    *len = (size_t)w * h * (size_t)c * (codes ? 2 : 1);
    if (raw) { /* The pixels live as long as the store; copy, since the
                * store may be closed (rescan) before the response is sent. */
        *resp = http_response_copy(px, *len, f->mime);
        return 0;
    }
    uint8_t *png;
    if ((codes ? gv_image_encode_typed(f->name, w, h, c, GV_SAMPLE_U16, px,
                                        &png, len, err)
                : gv_image_encode(f->name, w, h, c, px, 0, &png, len, err)) < 0)
        return -1;
    *resp = http_response_owned(png, *len, f->mime);
    return 0;
}

enum MHD_Result route_image_root(struct req *r)
{
    static const char *const form_name[] = {"png", "raw", "webp"};
    enum MHD_Result ret;
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    const struct gv_geometry *g = &img->info->geometry;
    uint32_t mip = 0, w, h;
    const char *ms = http_query(r, "mip");
    const char *fmt = http_query(r, "format");
    enum root_form form = ROOT_PNG;
    if (ms && http_parse_u32(ms, 64, &mip) < 0) {
        ret = http_send_errorf(r, GV_EINVAL, "root: mip must be 0..%d",
                               g->root_mips - 1);
        goto out;
    }
    if (fmt && !strcmp(fmt, "raw"))
        form = ROOT_RAW;
    else if (fmt && !strcmp(fmt, "webp"))
        form = ROOT_WEBP;
    else if (fmt && strcmp(fmt, "png")) {
        ret = http_send_errorf(r, GV_EINVAL, "root: format must be png, raw "
                               "or webp");
        goto out;
    }
    if (form == ROOT_WEBP && mip != 0) {
        ret = http_send_errorf(r, GV_EINVAL, "root: format=webp is the root "
                               "level only (mip 0); its mips are the 2x2 box "
                               "filter of it (or format=raw&mip=%u)", mip);
        goto out;
    }
    if (form == ROOT_WEBP && gv_header_codes(&img->info->header)) {
        ret = http_send_errorf(r, GV_EINVAL, "root: a height or sample "
                               "store's root holds 16-bit codes and has no "
                               "WebP form: use format=png (16-bit) or raw");
        goto out;
    }
    const uint8_t *px = gv_store_root(img->store, (int)mip, &w, &h);
    if (!px) {
        ret = http_send_errorf(r, GV_ENOTFOUND, "root: no mip %u (0..%d)", mip,
                               g->root_mips - 1);
        goto out;
    }
    char etag[64]; /* quotes, 16 hex digits, "-root-", a mip, a format */
    snprintf(etag, sizeof etag, "\"%016llx-root-%u-%s\"",
             (unsigned long long)img->identity, mip, form_name[form]);
    if (http_etag_listed(http_header(r, "If-None-Match"), etag)) {
        ret = http_send_empty(r, 304, "ETag", etag);
        goto out;
    }
    struct MHD_Response *resp = NULL;
    size_t len;
    struct gv_error err = {0};
    if (root_response(img, px, w, h, form, &resp, &len, &err) < 0) {
        ret = http_send_error(r, &err);
        goto out;
    }
    if (resp) {
        http_header_int(resp, "X-Width", w);
        http_header_int(resp, "X-Height", h);
        http_header_int(resp, "X-Channels", g->channels);
        http_header_int(resp, "X-Level", g->root + (int)mip);
    }
    http_header_etag_hour(resp, etag);
    ret = http_send(r, 200, resp, len);
out:
    image_put(img);
    return ret;
}
