/*
 * route_region.c - GET /v1/images/{id}/region?level=&x=&y=&w=&h=&format=
 *
 * Decoded pixels for clients with no GPU decoder: the rectangle
 * [x, x+w) x [y, y+h) of pyramid level `level` (0 = full resolution; the
 * levels above the root are the root's mips), decoded by the CPU reference
 * decoder exactly as `gigaview export --level --region` does, and encoded
 * as png (default), jpeg, webp or tiff.  w*h is capped by
 * max_region_pixels (413 beyond).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "store/geometry.h"
#include "imageio/imageio.h"
#include "log.h"
#include "metrics.h"
#include "routes.h"

struct out_format {
    const char *name, *alias, *encoder, *type;
};

static const struct out_format formats[] = {
    {"png", NULL, "png", "image/png"},
    {"jpeg", "jpg", "jpg", "image/jpeg"},
    {"webp", NULL, "webp", "image/webp"},
    {"tiff", "tif", "tif", "image/tiff"},
};

/* Size of level k (tiled, root, or a root mip).  0 or -1. */
static int level_size(const struct image *img, uint32_t k, uint32_t *w,
                      uint32_t *h)
{
    const struct gv_geometry *g = &img->info->geometry;
    if (k <= (uint32_t)g->root) {
        *w = g->level[k].width;
        *h = g->level[k].height;
        return 0;
    }
    if (k - (uint32_t)g->root >= (uint32_t)g->root_mips)
        return -1;
    return gv_store_root(img->store, (int)(k - (uint32_t)g->root), w, h) ? 0 : -1;
}

enum MHD_Result route_region(struct req *r)
{
    enum MHD_Result ret;
    struct gv_error err;
    const char *names[5] = {"level", "x", "y", "w", "h"};
    uint32_t v[5];
    for (int i = 0; i < 5; i++) {
        const char *s = http_query(r, names[i]);
        if (!s)
            return http_send_errorf(r, GV_EINVAL, "region: missing %s", names[i]);
        if (http_parse_u32(s, GV_MAX_DIM, &v[i]) < 0)
            return http_send_errorf(r, GV_EINVAL,
                                    "region: %s must be a non-negative decimal "
                                    "integer below 2^31", names[i]);
    }
    uint32_t level = v[0], x = v[1], y = v[2], w = v[3], h = v[4];
    if (w == 0 || h == 0)
        return http_send_errorf(r, GV_EINVAL, "region: w and h must be at least 1");
    const char *fs = http_query(r, "format");
    const struct out_format *f = &formats[0];
    if (fs) {
        f = NULL;
        for (size_t i = 0; i < sizeof formats / sizeof formats[0]; i++)
            if (!strcmp(fs, formats[i].name) ||
                (formats[i].alias && !strcmp(fs, formats[i].alias)))
                f = &formats[i];
        if (!f)
            return http_send_errorf(r, GV_EINVAL,
                                    "region: format must be png, jpeg, webp or tiff");
    }
    uint32_t quality = (uint32_t)r->srv->cfg->jpeg_quality;
    const char *qs = http_query(r, "quality");
    if (qs && (http_parse_u32(qs, 100, &quality) < 0 || quality == 0))
        return http_send_errorf(r, GV_EINVAL, "region: quality must be 1..100");
    uint64_t pixels = (uint64_t)w * h;
    if (pixels > r->srv->cfg->max_region_pixels)
        return http_send_errorf(r, GV_ELIMIT,
                                "region: %llu pixels, at most %llu (max_region_pixels)",
                                (unsigned long long)pixels,
                                (unsigned long long)r->srv->cfg->max_region_pixels);
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    uint32_t lw, lh;
    int c = img->info->geometry.channels;
    uint8_t *pix = NULL, *out = NULL;
    struct gv_decoder *d = NULL;
    size_t len;
    if (level_size(img, level, &lw, &lh) < 0) {
        ret = http_send_errorf(r, GV_EINVAL, "region: no level %u (0..%d)", level,
                               img->info->geometry.root +
                                   img->info->geometry.root_mips - 1);
        goto out;
    }
    if ((uint64_t)x + w > lw || (uint64_t)y + h > lh) {
        ret = http_send_errorf(r, GV_EINVAL,
                               "region: %u,%u,%u,%u outside level %u (%ux%u)", x,
                               y, w, h, level, lw, lh);
        goto out;
    }
    pix = malloc((size_t)pixels * (size_t)c);
    d = image_decoder_get(img);
    if (!pix || !d) {
        ret = http_send_errorf(r, GV_ENOMEM, "region: out of memory");
        goto out;
    }
    if (gv_decode_region(d, (int)level, x, y, w, h, pix, &err) < 0 ||
        gv_image_encode(f->encoder, w, h, c, pix, (int)quality, &out, &len,
                        &err) < 0) {
        if (err.code == GV_ECORRUPT || err.code == GV_EIO) { /* the store */
            atomic_fetch_add(&metrics.page_errors, 1);
            log_msg(LOG_ERROR, "region", "%s: %s", img->id, err.text);
        }
        ret = http_send_error(r, &err);
        goto out;
    }
    struct MHD_Response *resp =
        MHD_create_response_from_buffer_with_free_callback(len, out, free);
    if (resp) {
        out = NULL;
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, f->type);
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
