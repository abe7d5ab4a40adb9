/*
 * route_region.c - GET /v1/images/{id}/region?level=&x=&y=&w=&h=&format=
 *
 * Decoded pixels for clients with no GPU decoder: the rectangle
 * [x, x+w) x [y, y+h) of pyramid level `level` (0 = full resolution; the
 * levels above the root are the root's mips), decoded by the CPU reference
 * decoder exactly as `gigaview export --level --region` does, and encoded
 * as png (default), jpeg, webp or tiff.  A height store (docs/FORMAT.md
 * section 12) gives its gray mapping in those, and also png16 (its 16-bit
 * codes) and tiff32 (float values in its unit).  A sample store (section
 * 13) gives its display pixels (gray, or its channels' colours added)
 * through the window in those, and png16 (up to 4 channels), tiff16 (its
 * codes, every channel) and tiff32 (values).  w*h is capped by
 * max_region_pixels (413 beyond).  `window` (render/window.h) maps the
 * decoded samples (a sample store's 16-bit codes, any other store's
 * 8-bit samples) through a display window before they are encoded,
 * and is part of the cache key and the ETag; without it the store's
 * default window applies (catalog.h), and `window=none` asks for none.  The query is checked here; the render
 * runs on a render thread, and the answer is kept in the output cache
 * with a strong ETag (render_call.h).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "imageio/imageio.h"
#include "imageio/output_format.h"
#include "render/height_region.h"
#include "render/samples_region.h"
#include "render/window.h"
#include "output_cache.h"
#include "render_call.h"
#include "render_stages.h"
#include "routes.h"
#include "store/geometry.h"

/* A region request's query: level, x, y, w, h, format and quality. */
struct region_query {
    uint32_t level, x, y, w, h, quality;
    const struct gv_output_format *format;
    int codes;             /* CODES_PNG16, _TIFF16 or _TIFF32, else 0 */
    struct gv_window window;   /* count 0: none */
    int window_given;          /* 1: the query named one (or none) */
    struct gv_colours colours; /* a sample store's; count 0: not given */
};

/* The formats of the codes of height and sample stores only. */
enum { CODES_PNG16 = 1, CODES_TIFF32 = 2, CODES_TIFF16 = 3 };

/* Parse and check the query against the limits (not yet the image).  0,
 * or -1 with *err. */
static int parse_query(struct req *r, struct region_query *q,
                       struct gv_error *err)
{
    static const char *const names[5] = {"level", "x", "y", "w", "h"};
    uint32_t *v[5] = {&q->level, &q->x, &q->y, &q->w, &q->h};
    for (int i = 0; i < 5; i++) {
        const char *s = http_query(r, names[i]);
        if (!s)
            return gv_fail(err, GV_EINVAL, "region: missing %s", names[i]);
        if (http_parse_u32(s, GV_MAX_DIM, v[i]) < 0)
            return gv_fail(err, GV_EINVAL, "region: %s must be a non-negative "
                           "decimal integer below 2^31", names[i]);
    }
    if (q->w == 0 || q->h == 0)
        return gv_fail(err, GV_EINVAL, "region: w and h must be at least 1");
    const char *fs = http_query(r, "format");
    q->codes = fs && !strcmp(fs, "png16") ? CODES_PNG16
              : fs && !strcmp(fs, "tiff16") ? CODES_TIFF16
              : fs && !strcmp(fs, "tiff32") ? CODES_TIFF32 : 0;
    q->format = gv_output_format_find(q->codes == CODES_PNG16 ? "png"
                                      : q->codes ? "tif" : fs ? fs : "png");
    if (!q->format || !q->format->oiio)
        return gv_fail(err, GV_EINVAL, "region: format must be png, jpeg, webp "
                       "or tiff (png16 or tiff32 for a height store, png16, "
                       "tiff16 or tiff32 for a sample store)");
    q->quality = (uint32_t)r->srv->cfg->jpeg_quality;
    const char *qs = http_query(r, "quality");
    if (qs && (http_parse_u32(qs, 100, &q->quality) < 0 || q->quality == 0))
        return gv_fail(err, GV_EINVAL, "region: quality must be 1..100");
    const char *ws = http_query(r, "window");
    q->window.count = 0;
    q->window_given = ws != NULL;
    if (ws && strcmp(ws, "none") != 0 &&
        gv_window_parse(ws, 65535, &q->window, err) < 0)
        return -1;
    if (ws && q->codes)
        return gv_fail(err, GV_EINVAL, "window: not with png16, tiff16 or "
                       "tiff32");
    const char *cs = http_query(r, "colours");
    q->colours.count = 0;
    if (cs && (gv_colours_parse(cs, &q->colours, err) < 0))
        return -1;
    if (cs && q->codes)
        return gv_fail(err, GV_EINVAL, "colours: not with png16, tiff16 or "
                       "tiff32");
    uint64_t pixels = (uint64_t)q->w * q->h;
    if (pixels > r->srv->cfg->max_region_pixels)
        return gv_fail(err, GV_ELIMIT, "region: %llu pixels, at most %llu "
                       "(max_region_pixels)", (unsigned long long)pixels,
                       (unsigned long long)r->srv->cfg->max_region_pixels);
    return 0;
}

/* Check q against img's level sizes.  0, or -1 with *err. */
static int place(const struct image *img, const struct region_query *q,
                 struct gv_error *err)
{
    const struct gv_geometry *g = &img->info->geometry;
    uint32_t lw, lh;
    if (gv_level_size(g, (int)q->level, &lw, &lh) < 0)
        return gv_fail(err, GV_EINVAL, "region: no level %u (0..%d)", q->level,
                       g->root + g->root_mips - 1);
    if ((uint64_t)q->x + q->w > lw || (uint64_t)q->y + q->h > lh)
        return gv_fail(err, GV_EINVAL, "region: %u,%u,%u,%u outside level %u "
                       "(%ux%u)", q->x, q->y, q->w, q->h, q->level, lw, lh);
    const struct gv_header *hd = &img->info->header;
    if (q->codes && !gv_header_codes(hd))
        return gv_fail(err, GV_EINVAL, "region: png16, tiff16 and tiff32 are "
                       "for height and sample stores; this image is neither");
    if (q->codes == CODES_TIFF16 && hd->kind != GV_KIND_SAMPLES)
        return gv_fail(err, GV_EINVAL, "region: tiff16 is for sample stores "
                       "(png16 gives a height store's codes)");
    if (q->codes == CODES_PNG16 && g->channels > 4)
        return gv_fail(err, GV_EINVAL, "region: png16 holds up to 4 channels, "
                       "this image has %d (ask for tiff16)", g->channels);
    return gv_display_check(hd, &q->window, &q->colours, err);
}

/* Render a format of codes: the codes (png16, tiff16) or the values as
 * floats (tiff32), every channel.  0, or -1 with *err. */
static int render_codes(const struct region_query *q, struct gv_decoder *d,
                         uint8_t **out, size_t *len, struct gv_error *err)
{
    const struct gv_header *hd = &gv_store_info(gv_decoder_store(d))->header;
    const int c = hd->channels;
    const size_t n = (size_t)q->w * q->h * (size_t)c;
    uint16_t *codes = malloc(sizeof *codes * n);
    float *values = q->codes == CODES_TIFF32 ? malloc(sizeof *values * n) : NULL;
    int rc = -1;
    if (!codes || (q->codes == CODES_TIFF32 && !values))
        gv_fail(err, GV_ENOMEM, "region: out of memory");
    else if (gv_decoder_copy_region(d, "region", (int)q->level, q->x, q->y,
                                    q->w, q->h, codes, err) == 0) {
        if (values)
            for (size_t i = 0; i < n; i++)
                values[i] = (float)(codes[i] * hd->height_scale + hd->height_offset);
        rc = values ? gv_image_encode_typed("tif", q->w, q->h, c, GV_SAMPLE_F32,
                                            values, out, len, err)
                    : gv_image_encode_typed(q->codes == CODES_TIFF16 ? "tif" : "png",
                                            q->w, q->h, c, GV_SAMPLE_U16,
                                            codes, out, len, err);
    }
    free(codes);
    free(values);
    return rc;
}

/* On a render thread: decode q's rectangle of img and encode it: *out
 * (malloc'ed) of *len bytes.  0, or -1 with *err. */
static int render(void *arg, struct image *img, uint8_t **out, size_t *len,
                  struct gv_error *err)
{
    const struct region_query *q = arg;
    struct gv_decoder *d = image_decoder_get(img);
    if (q->codes && d) {
        int hrc = render_codes(q, d, out, len, err);
        image_decoder_put(img, d);
        return hrc;
    }
    const int dc = gv_display_channels(&img->info->header);
    uint8_t *pix = malloc((size_t)q->w * q->h * (size_t)dc);
    int rc = -1;
    if (!pix || !d)
        gv_fail(err, GV_ENOMEM, "region: out of memory");
    else {
        gv_decoder_times(d, &(struct gv_decode_times){0}, 1);
        double t0 = render_stages_now();
        int ok = gv_decode_region_window(d, (int)q->level, q->x, q->y, q->w,
                                         q->h, &q->window,
                                         q->colours.count ? &q->colours : &img->colours,
                                         pix, err) == 0;
        double t1 = render_stages_now();
        render_stages_decoder(d, t1 - t0);
        if (ok && gv_image_encode(q->format->name, q->w, q->h, dc,
                                  pix, (int)q->quality, out, len, err) == 0)
            rc = 0;
        if (ok)
            render_stages_add(STAGE_ENCODE, render_stages_now() - t1);
    }
    image_decoder_put(img, d);
    free(pix);
    return rc;
}

enum MHD_Result route_region(struct req *r)
{
    if (render_call_resumed(r))
        return render_call_finish(r);
    enum MHD_Result ret;
    struct gv_error err = {0};
    struct region_query q;
    if (parse_query(r, &q, &err) < 0)
        return http_send_error(r, &err);
    struct image *img = http_image(r, &ret);
    if (!img)
        return ret;
    struct region_query *arg = malloc(sizeof *arg);
    if (!arg || place(img, &q, &err) < 0) {
        free(arg);
        image_put(img);
        if (!arg)
            return http_send_errorf(r, GV_ENOMEM, "region: out of memory");
        return http_send_error(r, &err);
    }
    if (!q.window_given && !q.codes)
        q.window = img->window;   /* the store's default, if any */
    *arg = q;
    char canon[400 + GV_DISPLAY_KEY_MAX], key[sizeof canon + 24];
    char win[GV_DISPLAY_KEY_MAX];
    gv_display_key(&q.window, &q.colours, win);
    char etag[OUTPUT_ETAG_SIZE];
    snprintf(canon, sizeof canon, "region/%s/%u/%u,%u,%u,%u.%s q%u%s", img->id,
             q.level, q.x, q.y, q.w, q.h,
             q.codes == CODES_PNG16 ? "png16"
             : q.codes == CODES_TIFF16 ? "tiff16"
             : q.codes == CODES_TIFF32 ? "tiff32" : q.format->name, q.quality,
             win);
    snprintf(key, sizeof key, "%llu %s", (unsigned long long)img->serial, canon);
    output_cache_etag(img->identity, canon, etag, sizeof etag);
    struct render_spec spec = {
        .module = "region", .key = key, .etag = etag, .mime = q.format->mime,
        .render = render, .headers = render_call_cache_day, .arg = arg};
    return render_call_serve(r, img, &spec);
}
