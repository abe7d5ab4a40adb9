/*
 * region.c - a region of a store, scaled, rotated and colour-converted
 * (see region.h).
 *
 * Design.  The region [x, x+w) x [y, y+h) (level-0 pixels) is decoded at
 * the coarsest level k whose exact footprint w/2^k x h/2^k is still at
 * least out_w x out_h, so every output pixel covers between one and two
 * decoded pixels per axis (levels run up to the root's last mip, which
 * gv_decode_region reads from the root).  At level k the decoded rectangle
 * is the region rounded outwards, x_k = x >> k to ceil((x+w)/2^k), and the
 * resampling works on the exact, fractional footprint inside it.
 *
 * Resampling is separable, with per-axis weight tables in 14-bit fixed
 * point (each output pixel's weights sum to exactly 1 << 14):
 *  - an axis whose output is no larger than the level-k footprint uses the
 *    box (area) filter: the weight of a source pixel is its overlap with
 *    the output pixel's interval, computed exactly in integers (units of
 *    1/(out << k) source pixels, so there is no rounding before the
 *    conversion to fixed point);
 *  - an axis that is upscaled (only possible at level 0) uses bilinear
 *    interpolation between the two nearest pixel centres, clamped at the
 *    region's edge (the region is all that is decoded).
 * The vertical pass sums the rows an output row needs into one row of
 * 32-bit values (at most 255 << 14 each), the horizontal pass sums those
 * into 64 bits (at most 255 << 28) and rounds once: (acc + 2^27) >> 28.
 * A pixel that maps onto exactly one source pixel therefore comes out
 * unchanged (and where every pixel does, the rows are simply copied),
 * which makes a full-size render byte-identical to
 * gv_decode_region at level 0, and a render at exactly level k's size of
 * a level-aligned region identical to gv_decode_region at level k.
 *
 * When both axes map each output pixel onto one decoded pixel (a tile at
 * its level's own size), the decoded rectangle is the scaled image as it
 * is, and resampling is skipped.
 *
 * A display window (render/window.h), when the request has one, maps the
 * decoded samples through its tables before any resampling.
 *
 * Then quality (gray = (299 R + 587 G + 114 B + 500) / 1000, bitonal =
 * gray >= 128 ? 255 : 0, colour of a gray store replicates), the mirror
 * and the clockwise rotation, all in one pass over the scaled image.
 * Memory: the decoded rectangle, the scaled image and the final image, the
 * decoded one freed before the final one is allocated, plus weight tables
 * of a few entries per output column and row.  When the decoded rectangle
 * is the answer (a tile at its level's size, no rotation or recolouring),
 * gv_render_to decodes it into the caller's buffer and allocates nothing
 * else: a server's render thread keeps one such buffer, and pays for
 * neither a fresh mapping nor its page faults on every tile.
 */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "render/region.h"
#include "render/samples_region.h"
#include "store/store_read.h"

#define WBITS 14                  /* fixed-point weight precision */
#define WONE (1u << WBITS)

/* Weights of one axis: output pixel i reads source pixels
 * first[i] .. first[i] + count[i] - 1 with weights w[i * taps + t]. */
struct axis {
    uint32_t n, taps;
    uint32_t *first;
    uint32_t *count;
    uint32_t *w;
};

static void axis_free(struct axis *a)
{
    free(a->first);
    free(a->count);
    free(a->w);
}

/* Make the weights of output pixel i sum to exactly WONE by adjusting the
 * largest one (rounding each weight may leave the sum off by a few). */
static void normalise(uint32_t *w, uint32_t count)
{
    uint32_t sum = 0, big = 0;
    for (uint32_t t = 0; t < count; t++) {
        sum += w[t];
        if (w[t] > w[big])
            big = t;
    }
    w[big] = w[big] + WONE - sum;
}

/*
 * Box weights for an axis: region [x, x+len) of level 0 scaled to n
 * pixels, read at level k from decoded pixels starting at x >> k (src of
 * them).  Requires n << k <= len.
 */
static int axis_box(struct axis *a, uint64_t x, uint64_t len, uint32_t n,
                    int k, uint32_t src)
{
    const uint64_t q = (uint64_t)n << k;   /* units per source pixel */
    const uint64_t base = (x >> k) * q;    /* origin of the decoded pixels */
    /* An interval of len units touches at most len / q + 2 pixels. */
    uint64_t taps = len / q + 2;
    if (taps > src)
        taps = src;
    a->n = n;
    a->taps = (uint32_t)taps;
    a->first = malloc(sizeof *a->first * n);
    a->count = malloc(sizeof *a->count * n);
    a->w = malloc(sizeof *a->w * n * taps);
    if (!a->first || !a->count || !a->w)
        return -1;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t lo = x * n + (uint64_t)i * len - base;
        uint64_t hi = lo + len;
        uint64_t j0 = lo / q, j1 = (hi - 1) / q;
        if (j1 >= src)
            j1 = src - 1;   /* cannot happen: hi <= src * q */
        uint32_t *w = a->w + (size_t)i * taps;
        uint32_t c = 0;
        for (uint64_t j = j0; j <= j1 && c < taps; j++, c++) {
            uint64_t s = j * q > lo ? j * q : lo;
            uint64_t e = (j + 1) * q < hi ? (j + 1) * q : hi;
            /* overlap <= len < 2^31: the product fits in 64 bits. */
            w[c] = (uint32_t)(((e - s) * WONE + len / 2) / len);
        }
        a->first[i] = (uint32_t)j0;
        a->count[i] = c;
        normalise(w, c);
    }
    return 0;
}

/* Bilinear weights for an upscaled axis at level 0: region of len pixels
 * (all decoded) to n > len pixels.  Output centre i + 1/2 maps to source
 * coordinate (i + 1/2) * len / n - 1/2, clamped to the region. */
static int axis_bilinear(struct axis *a, uint64_t len, uint32_t n)
{
    a->n = n;
    a->taps = 2;
    a->first = malloc(sizeof *a->first * n);
    a->count = malloc(sizeof *a->count * n);
    a->w = malloc(sizeof *a->w * n * 2);
    if (!a->first || !a->count || !a->w)
        return -1;
    for (uint32_t i = 0; i < n; i++) {
        double s = ((double)i + 0.5) * (double)len / (double)n - 0.5;
        if (s < 0)
            s = 0;
        if (s > (double)(len - 1))
            s = (double)(len - 1);
        uint32_t j = (uint32_t)s;
        uint32_t f = (uint32_t)lround((s - j) * WONE);
        uint32_t *w = a->w + (size_t)i * 2;
        a->first[i] = j;
        if (f == 0 || j + 1 >= len) {
            a->count[i] = 1;
            w[0] = WONE;
        } else if (f >= WONE) {
            a->first[i] = j + 1;
            a->count[i] = 1;
            w[0] = WONE;
        } else {
            a->count[i] = 2;
            w[0] = WONE - f;
            w[1] = f;
        }
    }
    return 0;
}

/* Whether each output pixel of the axis is one source pixel, the next one
 * each time: resampling along it is a plain copy from first[0] on.  When
 * a->n is the source's length, such a copy can only start at 0: it is the
 * whole source, unchanged. */
static int axis_is_copy(const struct axis *a)
{
    for (uint32_t i = 0; i < a->n; i++)
        if (a->count[i] != 1 || a->w[(size_t)i * a->taps] != WONE ||
            a->first[i] != a->first[0] + i)
            return 0;
    return 1;
}

/* Scale the decoded sw x sh x c image to ax.n x ay.n into out. */
static int resample(const uint8_t *src, uint32_t sw, int c,
                    const struct axis *ax, const struct axis *ay,
                    uint8_t *out)
{
    const size_t rowv = (size_t)sw * c;
    /* A render at a level's own scale (most tile requests): both axes
     * copy, and the sums below would give the same bytes, r * 2^28
     * rounded back to r. */
    if (axis_is_copy(ax) && axis_is_copy(ay)) {
        for (uint32_t oy = 0; oy < ay->n; oy++)
            memcpy(out + (size_t)oy * ax->n * c,
                   src + (size_t)(ay->first[0] + oy) * rowv + (size_t)ax->first[0] * c,
                   (size_t)ax->n * c);
        return 0;
    }
    uint32_t *v = malloc(sizeof *v * rowv);
    if (!v)
        return -1;
    for (uint32_t oy = 0; oy < ay->n; oy++) {
        const uint32_t *wy = ay->w + (size_t)oy * ay->taps;
        memset(v, 0, sizeof *v * rowv);
        for (uint32_t t = 0; t < ay->count[oy]; t++) {
            const uint8_t *r = src + (size_t)(ay->first[oy] + t) * rowv;
            uint32_t wt = wy[t];
            for (size_t i = 0; i < rowv; i++)
                v[i] += wt * r[i];
        }
        uint8_t *o = out + (size_t)oy * ax->n * c;
        for (uint32_t ox = 0; ox < ax->n; ox++) {
            const uint32_t *wx = ax->w + (size_t)ox * ax->taps;
            const uint32_t *p = v + (size_t)ax->first[ox] * c;
            for (int ch = 0; ch < c; ch++) {
                uint64_t acc = 0;
                for (uint32_t t = 0; t < ax->count[ox]; t++)
                    acc += (uint64_t)wx[t] * p[(size_t)t * c + ch];
                acc = (acc + (1ull << (2 * WBITS - 1))) >> (2 * WBITS);
                o[(size_t)ox * c + ch] = (uint8_t)(acc > 255 ? 255 : acc);
            }
        }
    }
    free(v);
    return 0;
}

static inline uint8_t luma(const uint8_t *p)
{
    return (uint8_t)((299u * p[0] + 587u * p[1] + 114u * p[2] + 500u) / 1000u);
}

/* Write one output pixel of `oc` channels from scaled pixel p (sc
 * channels) under quality q. */
static inline void convert(const uint8_t *p, int sc, uint8_t *o, int oc,
                           enum gv_quality q)
{
    uint8_t g;
    switch (q) {
    case GV_QUALITY_GRAY:
    case GV_QUALITY_BITONAL:
        g = sc == 3 ? luma(p) : p[0];
        o[0] = q == GV_QUALITY_GRAY ? g : (g >= 128 ? 255 : 0);
        return;
    default:
        if (sc == oc)
            memcpy(o, p, (size_t)oc);
        else
            o[0] = o[1] = o[2] = p[0];   /* colour from a gray store */
        return;
    }
}

/* Refuse a request that does not fit geometry g; returns 0 or -1. */
static int check_request(const struct gv_geometry *g,
                         const struct gv_render_req *req, struct gv_error *err)
{
    if (req->w == 0 || req->h == 0 || req->x >= g->width
        || req->y >= g->height || req->w > g->width - req->x
        || req->h > g->height - req->y)
        return gv_fail(err, GV_EINVAL, "render: region %u,%u %ux%u is not "
                       "inside the image (%ux%u)", req->x, req->y, req->w,
                       req->h, g->width, g->height);
    if (req->out_w == 0 || req->out_h == 0 || req->out_w > GV_MAX_DIM
        || req->out_h > GV_MAX_DIM)
        return gv_fail(err, GV_EINVAL, "render: bad output size %ux%u",
                       req->out_w, req->out_h);
    if (req->rotation != 0 && req->rotation != 90 && req->rotation != 180
        && req->rotation != 270)
        return gv_fail(err, GV_EINVAL, "render: rotation %d is not a "
                       "multiple of 90 in 0..270", req->rotation);
    if (req->quality < GV_QUALITY_DEFAULT || req->quality > GV_QUALITY_BITONAL)
        return gv_fail(err, GV_EINVAL, "render: bad quality %d",
                       (int)req->quality);
    if ((uint64_t)req->out_w * req->out_h > SIZE_MAX / 4)
        return gv_fail(err, GV_ELIMIT, "render: output of %ux%u pixels is "
                       "too large", req->out_w, req->out_h);
    return 0;
}

/* The decoded rectangle: level k, and the region rounded outwards to
 * that level's pixels. */
struct footprint {
    int k;
    uint32_t x, y, w, h;
};

/* The coarsest level whose exact footprint still covers the output
 * (out << k <= size on both axes), and the rectangle decoded there;
 * refused past the request's decode limit. */
static int choose_footprint(const struct gv_geometry *g,
                            const struct gv_render_req *req,
                            struct footprint *f, struct gv_error *err)
{
    const int lmax = g->root + g->root_mips - 1;
    int k = 0;
    while (k < lmax && ((uint64_t)req->out_w << (k + 1)) <= req->w
           && ((uint64_t)req->out_h << (k + 1)) <= req->h)
        k++;
    const uint64_t x = req->x, y = req->y, one = 1ull << k;
    f->k = k;
    f->x = (uint32_t)(x >> k);
    f->y = (uint32_t)(y >> k);
    f->w = (uint32_t)(((x + req->w + one - 1) >> k) - f->x);
    f->h = (uint32_t)(((y + req->h + one - 1) >> k) - f->y);
    const uint64_t dec_px = (uint64_t)f->w * f->h;
    if (req->max_decode_pixels && dec_px > req->max_decode_pixels)
        return gv_fail(err, GV_ELIMIT, "render: decoding %ux%u pixels at "
                       "level %d exceeds the limit of %llu pixels", f->w, f->h,
                       k, (unsigned long long)req->max_decode_pixels);
    if (dec_px > SIZE_MAX / 4)
        return gv_fail(err, GV_ELIMIT, "render: region too large");
    return 0;
}

/* The weights of both axes: box where the footprint is at least the
 * output, bilinear where it is upscaled (only possible at level 0, by the
 * choice of the level). */
static int make_axes(const struct gv_render_req *req, const struct footprint *f,
                     struct axis *ax, struct axis *ay)
{
    const int k = f->k;
    int up_x = ((uint64_t)req->out_w << k) > req->w;
    int up_y = ((uint64_t)req->out_h << k) > req->h;
    if ((up_x ? axis_bilinear(ax, req->w, req->out_w)
              : axis_box(ax, req->x, req->w, req->out_w, k, f->w)) != 0
        || (up_y ? axis_bilinear(ay, req->h, req->out_h)
                 : axis_box(ay, req->y, req->h, req->out_h, k, f->h)) != 0)
        return -1;
    return 0;
}

/* Output channels for the request's quality from a store of sc. */
static int out_channels(const struct gv_render_req *req, int sc)
{
    if (req->quality == GV_QUALITY_GRAY || req->quality == GV_QUALITY_BITONAL)
        return 1;
    return req->quality == GV_QUALITY_COLOR ? 3 : sc;
}

/* Whether the scaled image already is the answer: no rotation, no mirror
 * and no change of channels. */
static int scaled_is_final(const struct gv_render_req *req, int sc, int oc)
{
    return req->rotation == 0 && !req->mirror && oc == sc
        && (req->quality == GV_QUALITY_DEFAULT
            || req->quality == GV_QUALITY_COLOR
            || (sc == 1 && req->quality == GV_QUALITY_GRAY));
}

/* Mirror, rotate and convert the out_w x out_h scaled image (sc channels)
 * into final (fw x fh, oc channels). */
static void orient(const uint8_t *scaled, int sc, const struct gv_render_req *req,
                   uint32_t fw, uint32_t fh, int oc, uint8_t *final)
{
    const uint32_t ow = req->out_w, oh = req->out_h;
    /* Final pixel (X, Y) comes from mirrored pixel (mx, my), which is
     * scaled pixel (mirror ? ow-1-mx : mx, my). */
    for (uint32_t Y = 0; Y < fh; Y++) {
        uint8_t *o = final + (size_t)Y * fw * oc;
        for (uint32_t X = 0; X < fw; X++) {
            uint32_t mx, my;
            switch (req->rotation) {
            case 90: mx = Y; my = oh - 1 - X; break;
            case 180: mx = ow - 1 - X; my = oh - 1 - Y; break;
            case 270: mx = ow - 1 - Y; my = X; break;
            default: mx = X; my = Y; break;
            }
            if (req->mirror)
                mx = ow - 1 - mx;
            convert(scaled + ((size_t)my * ow + mx) * sc, sc,
                    o + (size_t)X * oc, oc, req->quality);
        }
    }
}

int gv_render(struct gv_decoder *d, const struct gv_render_req *req,
              uint8_t **pixels, uint32_t *w, uint32_t *h, int *channels,
              struct gv_error *err)
{
    uint8_t *buf = NULL;
    size_t cap = 0;
    if (gv_render_to(d, req, &buf, &cap, w, h, channels, err) < 0) {
        free(buf);
        return -1;
    }
    *pixels = buf;
    return 0;
}

/* *buf of at least `need` bytes (its contents dropped): 0 or -1. */
static int reserve(uint8_t **buf, size_t *cap, size_t need)
{
    if (*buf && *cap >= need)
        return 0;
    free(*buf);
    *buf = malloc(need ? need : 1);
    *cap = *buf ? need : 0;
    return *buf ? 0 : -1;
}


int gv_render_to(struct gv_decoder *d, const struct gv_render_req *req,
                 uint8_t **buf, size_t *cap, uint32_t *w, uint32_t *h,
                 int *channels, struct gv_error *err)
{
    const struct gv_geometry *g = &gv_store_info(gv_decoder_store(d))->geometry;
    /* 8-bit pixels: a sample store's codes through req's window */
    const int sc = gv_display_channels(&gv_store_info(gv_decoder_store(d))->header);
    uint8_t *dec = NULL, *scaled = NULL, *final = NULL;
    struct axis ax = {0}, ay = {0};
    struct footprint f;
    int rc = -1;

    if (check_request(g, req, err) < 0 || choose_footprint(g, req, &f, err) < 0)
        return -1;
    const int oc = out_channels(req, sc);
    const uint64_t out_px = (uint64_t)req->out_w * req->out_h;
    if (make_axes(req, &f, &ax, &ay) < 0) {
        gv_fail(err, GV_ENOMEM, "render: out of memory for weights");
        goto out;
    }

    const int copy = ax.n == f.w && ay.n == f.h && axis_is_copy(&ax) &&
                     axis_is_copy(&ay);
    if (copy && scaled_is_final(req, sc, oc)) {
        /* The decoded rectangle is the answer: decode it into *buf. */
        if (reserve(buf, cap, (size_t)f.w * f.h * sc) < 0) {
            gv_fail(err, GV_ENOMEM, "render: out of memory decoding %ux%u "
                    "pixels", f.w, f.h);
            goto out;
        }
        if (gv_decode_region_window(d, f.k, f.x, f.y, f.w, f.h, req->window,
                                    req->colours, *buf, err) != 0)
            goto out;
        *w = req->out_w;
        *h = req->out_h;
        *channels = oc;
        rc = 0;
        goto out;
    }
    dec = malloc((size_t)f.w * f.h * sc);
    if (!dec) {
        gv_fail(err, GV_ENOMEM, "render: out of memory decoding %ux%u pixels",
                f.w, f.h);
        goto out;
    }
    if (gv_decode_region_window(d, f.k, f.x, f.y, f.w, f.h, req->window,
                                req->colours, dec, err) != 0)
        goto out;

    if (copy) {
        /* Level-aligned at the level's own size (an IIIF tile): each output
         * pixel is one decoded pixel, which resample would copy unchanged. */
        scaled = dec;
        dec = NULL;
    } else if (!(scaled = malloc((size_t)out_px * sc)) ||
               resample(dec, f.w, sc, &ax, &ay, scaled) != 0) {
        gv_fail(err, GV_ENOMEM, "render: out of memory scaling to %ux%u",
                req->out_w, req->out_h);
        goto out;
    }
    free(dec);
    dec = NULL;

    const int turned = req->rotation == 90 || req->rotation == 270;
    const uint32_t fw = turned ? req->out_h : req->out_w;
    const uint32_t fh = turned ? req->out_w : req->out_h;
    if (scaled_is_final(req, sc, oc)) {
        final = scaled;
        scaled = NULL;
    } else {
        final = malloc((size_t)out_px * oc);
        if (!final) {
            gv_fail(err, GV_ENOMEM, "render: out of memory");
            goto out;
        }
        orient(scaled, sc, req, fw, fh, oc, final);
    }
    free(*buf);
    *buf = final;
    *cap = (size_t)out_px * (scaled_is_final(req, sc, oc) ? sc : oc);
    final = NULL;
    *w = fw;
    *h = fh;
    *channels = oc;
    rc = 0;
out:
    free(dec);
    free(scaled);
    free(final);
    axis_free(&ax);
    axis_free(&ay);
    return rc;
}
