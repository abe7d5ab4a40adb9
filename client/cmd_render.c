/*
 * cmd_render.c - `gigaview render URL --image ID ...`: the native thin
 * client.  It fetches only the compressed tiles a picture needs, plus
 * their ancestors, from gigaviewd (in parallel, through the on-disk cache
 * with ETag revalidation), decodes them on the GPU through EGL
 * (lib/gpu/gpu_cache.c pulls missing parents recursively), composes the
 * picture on the CPU from the read-back tiles and writes it atomically.
 *
 * Two forms:
 *   --level L --region X,Y,W,H   pixels of one pyramid level: bit for bit
 *                                what `gigaview export` writes.
 *   --center X,Y --zoom Z --rotate DEG --size WxH
 *                                a view: output pixels are 2^Z level-0
 *                                pixels wide (Z real, negative magnifies),
 *                                the image turned clockwise by DEG about
 *                                the centre (level-0 coordinates); levels floor(Z)
 *                                and floor(Z)+1 are sampled bilinearly
 *                                and blended by the fraction of Z, as
 *                                section 7.5 blends adjacent levels.
 *                                Outside the image is black.
 *
 * GIGAVIEW_GPU_PLATFORM (auto, device, surfaceless or default) forces an
 * EGL platform, as gigaviewd's gpu_platform does.  A build configured
 * --without-gpu has only a cmd_render that says it needs the GPU.
 */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h" /* autoconf: GV_HAVE_GPU */

#include "commands.h"
#include "options.h"
#include "store/geometry.h"
#include "gpu/gpu.h"
#include "gpu/gpu_cache.h"
#include "gpu/gpu_decode.h"
#include "http_fetch.h"
#include "imageio/imageio.h"
#include "tile_cache_disk.h"

#define DEFAULT_MAX_PIXELS (256ull << 20)
#define ME "gigaview render"

#ifdef GV_HAVE_GPU

static void usage(FILE *out)
{
    fprintf(out,
        "usage: gigaview render URL --image ID [--level L] [--region X,Y,W,H] -o OUT\n"
        "       gigaview render URL --image ID --center X,Y --zoom Z [--rotate DEG]\n"
        "                       --size WxH -o OUT\n"
        "\n"
        "Fetch compressed tiles from the gigaviewd at URL (http:// or https://),\n"
        "decode them on the GPU and write OUT (.png, .tif or .jpg).\n"
        "\n"
        "  -i, --image ID         the image (see 'gigaview info URL')\n"
        "  -l, --level L          pyramid level, 0 = full resolution (default 0)\n"
        "  -R, --region X,Y,W,H   pixels of that level (default: all of it)\n"
        "  -c, --center X,Y       view centre in level-0 pixels (default: image centre)\n"
        "  -z, --zoom Z           level of detail: one output pixel is 2^Z level-0\n"
        "                         pixels; fractions blend two levels\n"
        "  -r, --rotate DEG       clockwise rotation of the view (default 0)\n"
        "  -s, --size WxH         output size of the view\n"
        "  -o, --output OUT       the image to write\n"
        "  -t, --timeout SEC      limit for each HTTP request (default 30)\n"
        "      --cache-dir DIR    tile cache (default $XDG_CACHE_HOME/gigaview\n"
        "                         or ~/.cache/gigaview)\n"
        "      --no-cache         do not use the tile cache\n"
        "      --gpu-cache MIB    GPU memory for decoded tiles (default 256)\n"
        "      --max-pixels N     refuse larger outputs (default %llu)\n"
        "  -v, --verbose          log requests and statistics to stderr\n"
        "\n"
        "GIGAVIEW_GPU_PLATFORM=auto|device|surfaceless|default in the environment\n"
        "chooses the EGL platform (default auto: the first that works).\n",
        DEFAULT_MAX_PIXELS);
}

struct need {
    struct gv_tile_want *t;
    size_t n, cap;
};

static int cmp_want(const void *a, const void *b)
{
    const struct gv_tile_want *x = a, *y = b;
    if (x->level != y->level)
        return x->level > y->level ? -1 : 1;   /* coarse first */
    if (x->ty != y->ty)
        return x->ty < y->ty ? -1 : 1;
    if (x->tx != y->tx)
        return x->tx < y->tx ? -1 : 1;
    return 0;
}

static int need_add(struct need *nd, int level, uint32_t tx, uint32_t ty)
{
    if (nd->n == nd->cap) {
        size_t cap = nd->cap ? 2 * nd->cap : 64;
        struct gv_tile_want *t = realloc(nd->t, cap * sizeof *t);
        if (!t)
            return -1;
        nd->t = t;
        nd->cap = cap;
    }
    nd->t[nd->n++] = (struct gv_tile_want){.level = level, .tx = tx, .ty = ty};
    return 0;
}

/* Add tiles [t0x..t1x] x [t0y..t1y] of `level` and all their ancestors
 * below the root. */
static int need_range(struct need *nd, const struct gv_geometry *g, int level,
                      uint32_t t0x, uint32_t t0y, uint32_t t1x, uint32_t t1y)
{
    for (int k = level; k < g->root; k++) {
        for (uint32_t ty = t0y; ty <= t1y; ty++)
            for (uint32_t tx = t0x; tx <= t1x; tx++)
                if (need_add(nd, k, tx, ty) < 0)
                    return -1;
        t0x /= 2, t0y /= 2, t1x /= 2, t1y /= 2;
    }
    return 0;
}

static void need_unique(struct need *nd)
{
    if (!nd->n)
        return;
    qsort(nd->t, nd->n, sizeof *nd->t, cmp_want);
    size_t m = 1;
    for (size_t i = 1; i < nd->n; i++)
        if (cmp_want(&nd->t[i], &nd->t[m - 1]))
            nd->t[m++] = nd->t[i];
    nd->n = m;
}

struct fetch_ctx {
    struct need *nd;
    struct gv_http *http;
    const struct gv_remote_image *img;
    struct gv_disk_cache *dc;
};

/* The gpu_cache callback: tiles come from the prefetched set (a copy, as
 * the cache frees what it gets); any other is fetched on its own. */
static int fetch_tile(void *arg, int level, uint32_t tx, uint32_t ty,
                      uint8_t **buf, size_t *len, struct gv_error *err)
{
    struct fetch_ctx *f = arg;
    struct gv_tile_want key = {.level = level, .tx = tx, .ty = ty};
    struct gv_tile_want *w = bsearch(&key, f->nd->t, f->nd->n, sizeof key, cmp_want);
    if (w && w->buf) {
        if (!(*buf = malloc(w->len ? w->len : 1)))
            return gv_fail(err, GV_ENOMEM, "out of memory");
        memcpy(*buf, w->buf, w->len);
        *len = w->len;
        return 0;
    }
    if (gv_http_tiles(f->http, f->img, &key, 1, f->dc, err) < 0) {
        free(key.buf);
        return -1;
    }
    *buf = key.buf;
    *len = key.len;
    return 0;
}

/* One pyramid level as the compositor sees it: read-back tiles (tiled
 * levels) or a root mip image. */
struct lvl {
    int k;
    uint32_t w, h, tiles_x, tiles_y;
    uint8_t **tile;        /* tiles_x * tiles_y, NULL where not loaded */
    uint8_t *mip;          /* levels >= root */
};

static const uint8_t *lvl_px(const struct lvl *l, uint32_t x, uint32_t y, int c)
{
    if (l->mip)
        return l->mip + ((size_t)y * l->w + x) * c;
    uint32_t tx = x / GV_STEP, ty = y / GV_STEP;
    if (tx >= l->tiles_x)
        tx = l->tiles_x - 1;
    if (ty >= l->tiles_y)
        ty = l->tiles_y - 1;
    const uint8_t *t = l->tile[(size_t)ty * l->tiles_x + tx];
    return t + ((size_t)(y - ty * GV_STEP) * GV_TILE + (x - tx * GV_STEP)) * c;
}

static void lvl_free(struct lvl *l)
{
    if (l->tile)
        for (size_t i = 0; i < (size_t)l->tiles_x * l->tiles_y; i++)
            free(l->tile[i]);
    free(l->tile);
    free(l->mip);
    memset(l, 0, sizeof *l);
}

struct session {
    struct gv_http *http;
    struct gv_remote_image img;
    struct gv_geometry geo;
    struct gv_disk_cache *dc;
    struct need nd;
    struct gv_gpu *gpu;
    struct gv_gpu_decoder *dec;
    struct gv_gpu_cache *cache;
    struct fetch_ctx fetch;
    size_t gpu_budget;
    enum gv_gpu_platform platform;
    int verbose;
};

/* The EGL platform GIGAVIEW_GPU_PLATFORM names (unset or empty: auto).
 * 0, or -1 after saying what it accepts. */
static int platform_from_env(enum gv_gpu_platform *platform)
{
    const char *name = getenv("GIGAVIEW_GPU_PLATFORM");
    int p = name && *name ? gv_gpu_platform_parse(name) : GV_GPU_PLATFORM_AUTO;
    if (p < 0) {
        fprintf(stderr, ME ": GIGAVIEW_GPU_PLATFORM wants auto, device, "
                "surfaceless or default, not '%s'\n", name);
        return -1;
    }
    *platform = (enum gv_gpu_platform)p;
    return 0;
}

/* Fetch every tile in s->nd, then start the GPU and its cache. */
static int start_decoding(struct session *s, struct gv_error *err)
{
    need_unique(&s->nd);
    if (gv_http_tiles(s->http, &s->img, s->nd.t, s->nd.n, s->dc, err) < 0)
        return -1;
    if (s->cache)
        return 0;
    if (!(s->gpu = gv_gpu_open(s->platform, err)))
        return -1;
    if (!(s->dec = gv_gpu_decoder_new(s->gpu, s->img.channels, err)))
        return -1;
    uint8_t *root;
    uint32_t rw, rh;
    if (gv_http_root(s->http, &s->img, 0, s->dc, &root, &rw, &rh, err) < 0)
        return -1;
    s->fetch = (struct fetch_ctx){&s->nd, s->http, &s->img, s->dc};
    s->cache = gv_gpu_cache_new(s->dec, &s->geo, root, rw, rh, s->gpu_budget,
                                fetch_tile, &s->fetch, err);
    free(root);
    return s->cache ? 0 : -1;
}

/* Load level k's tiles [t0x..t1x] x [t0y..t1y] (or its root mip). */
static int lvl_load(struct session *s, struct lvl *l, int k, uint32_t t0x,
                    uint32_t t0y, uint32_t t1x, uint32_t t1y, struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    memset(l, 0, sizeof *l);
    l->k = k;
    if (k >= g->root)
        return gv_http_root(s->http, &s->img, k - g->root, s->dc, &l->mip, &l->w,
                            &l->h, err);
    const struct gv_level *gl = &g->level[k];
    l->w = gl->width;
    l->h = gl->height;
    l->tiles_x = gl->tiles_x;
    l->tiles_y = gl->tiles_y;
    if (!(l->tile = calloc((size_t)l->tiles_x * l->tiles_y, sizeof *l->tile)))
        return gv_fail(err, GV_ENOMEM, "out of memory");
    for (uint32_t ty = t0y; ty <= t1y; ty++)
        for (uint32_t tx = t0x; tx <= t1x; tx++) {
            uint8_t **p = &l->tile[(size_t)ty * l->tiles_x + tx];
            if (!(*p = malloc(gv_tile_bytes(g->channels))))
                return gv_fail(err, GV_ENOMEM, "out of memory");
            if (gv_gpu_cache_read(s->cache, k, tx, ty, *p, err) < 0)
                return -1;
        }
    return 0;
}

static void tile_span(const struct gv_level *l, uint32_t x0, uint32_t x1,
                      uint32_t y0, uint32_t y1, uint32_t *t)
{
    /* Pixels x0..x1, y0..y1 inclusive -> tile ranges, as store_decoder.c does. */
    t[0] = x0 / GV_STEP;
    t[2] = x1 / GV_STEP;
    t[1] = y0 / GV_STEP;
    t[3] = y1 / GV_STEP;
    if (t[2] >= l->tiles_x) t[2] = l->tiles_x - 1;
    if (t[3] >= l->tiles_y) t[3] = l->tiles_y - 1;
    if (t[0] > t[2]) t[0] = t[2];
    if (t[1] > t[3]) t[1] = t[3];
}

/* Bounding box in level k pixels (inclusive, clamped) of level-0 box
 * [ax,bx] x [ay,by], widened by one pixel for bilinear taps. */
static void level_box(const struct lvl *l, double s, double ax, double ay,
                      double bx, double by, uint32_t *box)
{
    double v[4] = {floor(ax / s - 0.5) - 1, floor(ay / s - 0.5) - 1,
                   ceil(bx / s - 0.5) + 1, ceil(by / s - 0.5) + 1};
    double lim[4] = {l->w - 1.0, l->h - 1.0, l->w - 1.0, l->h - 1.0};
    for (int i = 0; i < 4; i++)
        box[i] = (uint32_t)(v[i] < 0 ? 0 : v[i] > lim[i] ? lim[i] : v[i]);
}

static void level_size(const struct gv_geometry *g, const struct gv_remote_image *img,
                       int k, uint32_t *w, uint32_t *h)
{
    if (k < g->root) {
        *w = g->level[k].width;
        *h = g->level[k].height;
        return;
    }
    *w = img->root_w;
    *h = img->root_h;
    for (int m = g->root; m < k; m++) {
        *w = (*w + 1) / 2;
        *h = (*h + 1) / 2;
    }
}

/* Bilinear sample of level l at level-0 point (px,py), into acc. */
static void sample(const struct lvl *l, double s, double px, double py, int c,
                   double *acc, double wgt)
{
    double u = px / s - 0.5, v = py / s - 0.5;
    double fu = floor(u), fv = floor(v);
    double au = u - fu, av = v - fv;
    long x0 = (long)fu, y0 = (long)fv;
    long xs[2] = {x0, x0 + 1}, ys[2] = {y0, y0 + 1};
    for (int i = 0; i < 2; i++) {
        xs[i] = xs[i] < 0 ? 0 : xs[i] >= (long)l->w ? (long)l->w - 1 : xs[i];
        ys[i] = ys[i] < 0 ? 0 : ys[i] >= (long)l->h ? (long)l->h - 1 : ys[i];
    }
    const uint8_t *p00 = lvl_px(l, (uint32_t)xs[0], (uint32_t)ys[0], c);
    const uint8_t *p10 = lvl_px(l, (uint32_t)xs[1], (uint32_t)ys[0], c);
    const uint8_t *p01 = lvl_px(l, (uint32_t)xs[0], (uint32_t)ys[1], c);
    const uint8_t *p11 = lvl_px(l, (uint32_t)xs[1], (uint32_t)ys[1], c);
    for (int k = 0; k < c; k++)
        acc[k] += wgt * ((1 - av) * ((1 - au) * p00[k] + au * p10[k]) +
                         av * ((1 - au) * p01[k] + au * p11[k]));
}

struct view {
    double cx, cy, zoom, rot;
    uint32_t w, h;
};

static int render_view(struct session *s, const struct view *v, uint8_t *out,
                       struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    const int c = g->channels;
    const int top = g->root + s->img.root_mips - 1;
    int f = (int)floor(v->zoom);
    double t = v->zoom - f;
    if (f < 0) {
        f = 0;
        t = 0;
    }
    if (f >= top) {
        f = top;
        t = 0;
    }
    const int nl = t > 0 ? 2 : 1;
    const double scale = exp2(v->zoom), th = v->rot * M_PI / 180.0;
    /* Output to image: rotate by -DEG, so the image appears turned
     * clockwise by DEG (y points down). */
    const double cs = cos(th), sn = -sin(th);
    /* Level-0 bounding box of the view, clipped to the image. */
    double ax = 1e300, ay = 1e300, bx = -1e300, by = -1e300;
    for (int i = 0; i < 4; i++) {
        double dx = ((i & 1) ? 0.5 : -0.5) * v->w, dy = ((i & 2) ? 0.5 : -0.5) * v->h;
        double px = v->cx + scale * (dx * cs - dy * sn);
        double py = v->cy + scale * (dx * sn + dy * cs);
        ax = fmin(ax, px), bx = fmax(bx, px), ay = fmin(ay, py), by = fmax(by, py);
    }
    memset(out, 0, (size_t)v->w * v->h * c);
    if (bx <= 0 || by <= 0 || ax >= g->width || ay >= g->height)
        return 0;                                   /* nothing of the image */
    ax = fmax(ax, 0), ay = fmax(ay, 0);
    bx = fmin(bx, g->width), by = fmin(by, g->height);
    struct lvl L[2];
    uint32_t box[2][4], span[2][4];
    memset(L, 0, sizeof L);
    int rc = -1;
    for (int i = 0; i < nl; i++) {
        int k = f + i;
        struct lvl tmp = {.k = k};
        level_size(g, &s->img, k, &tmp.w, &tmp.h);
        level_box(&tmp, exp2(k), ax, ay, bx, by, box[i]);
        if (k < g->root) {
            tile_span(&g->level[k], box[i][0], box[i][2], box[i][1], box[i][3], span[i]);
            if (need_range(&s->nd, g, k, span[i][0], span[i][1], span[i][2],
                           span[i][3]) < 0) {
                gv_fail(err, GV_ENOMEM, "out of memory");
                goto out;
            }
        }
    }
    if (s->nd.n && start_decoding(s, err) < 0)
        goto out;
    for (int i = 0; i < nl; i++)
        if (lvl_load(s, &L[i], f + i, span[i][0], span[i][1], span[i][2],
                     span[i][3], err) < 0)
            goto out;
    for (uint32_t j = 0; j < v->h; j++)
        for (uint32_t i = 0; i < v->w; i++) {
            double dx = (i + 0.5 - v->w / 2.0) * scale, dy = (j + 0.5 - v->h / 2.0) * scale;
            double px = v->cx + dx * cs - dy * sn, py = v->cy + dx * sn + dy * cs;
            if (px < 0 || py < 0 || px >= g->width || py >= g->height)
                continue;
            double acc[3] = {0, 0, 0};
            sample(&L[0], exp2(f), px, py, c, acc, 1 - t);
            if (nl == 2)
                sample(&L[1], exp2(f + 1), px, py, c, acc, t);
            uint8_t *o = out + ((size_t)j * v->w + i) * c;
            for (int k = 0; k < c; k++) {
                double q = floor(acc[k] + 0.5);
                o[k] = (uint8_t)(q < 0 ? 0 : q > 255 ? 255 : q);
            }
        }
    rc = 0;
out:
    lvl_free(&L[0]);
    lvl_free(&L[1]);
    return rc;
}

static int render_region(struct session *s, int level, uint32_t x, uint32_t y,
                         uint32_t w, uint32_t h, uint8_t *out, struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    const int c = g->channels;
    const size_t orow = (size_t)w * c;
    if (level >= g->root) {
        uint8_t *mip;
        uint32_t mw, mh;
        if (gv_http_root(s->http, &s->img, level - g->root, s->dc, &mip, &mw, &mh,
                         err) < 0)
            return -1;
        for (uint32_t r = 0; r < h; r++)
            memcpy(out + r * orow, mip + ((size_t)(y + r) * mw + x) * c, orow);
        free(mip);
        return 0;
    }
    const struct gv_level *l = &g->level[level];
    uint32_t sp[4];
    tile_span(l, x, x + w - 1, y, y + h - 1, sp);
    if (need_range(&s->nd, g, level, sp[0], sp[1], sp[2], sp[3]) < 0)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    if (start_decoding(s, err) < 0)
        return -1;
    uint8_t *px = malloc(gv_tile_bytes(c));
    if (!px)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    for (uint32_t ty = sp[1]; ty <= sp[3]; ty++)
        for (uint32_t tx = sp[0]; tx <= sp[2]; tx++) {
            if (gv_gpu_cache_read(s->cache, level, tx, ty, px, err) < 0) {
                free(px);
                return -1;
            }
            /* The pixels this tile is the source of (store_decoder.c's rule). */
            uint32_t sx0 = tx * GV_STEP, sy0 = ty * GV_STEP;
            uint32_t sx1 = tx + 1 == l->tiles_x ? l->width : sx0 + GV_STEP;
            uint32_t sy1 = ty + 1 == l->tiles_y ? l->height : sy0 + GV_STEP;
            uint32_t ax = x > sx0 ? x : sx0, bx = x + w < sx1 ? x + w : sx1;
            uint32_t ay = y > sy0 ? y : sy0, by = y + h < sy1 ? y + h : sy1;
            for (uint32_t yy = ay; ax < bx && yy < by; yy++)
                memcpy(out + (size_t)(yy - y) * orow + (size_t)(ax - x) * c,
                       px + ((size_t)(yy - sy0) * GV_TILE + (ax - sx0)) * c,
                       (size_t)(bx - ax) * c);
        }
    free(px);
    return 0;
}

static int parse_pair(const char *s, char sep, double *a, double *b)
{
    char *end;
    *a = strtod(s, &end);
    if (end == s || *end != sep)
        return -1;
    const char *p = end + 1;
    *b = strtod(p, &end);
    return end == p || *end || !isfinite(*a) || !isfinite(*b) ? -1 : 0;
}

int cmd_render(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"image", required_argument, NULL, 'i'},
        {"level", required_argument, NULL, 'l'},
        {"region", required_argument, NULL, 'R'},
        {"center", required_argument, NULL, 'c'},
        {"centre", required_argument, NULL, 'c'},
        {"zoom", required_argument, NULL, 'z'},
        {"rotate", required_argument, NULL, 'r'},
        {"size", required_argument, NULL, 's'},
        {"output", required_argument, NULL, 'o'},
        {"timeout", required_argument, NULL, 't'},
        {"cache-dir", required_argument, NULL, 'C'},
        {"no-cache", no_argument, NULL, 'N'},
        {"gpu-cache", required_argument, NULL, 'G'},
        {"max-pixels", required_argument, NULL, 'M'},
        {"verbose", no_argument, NULL, 'v'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *image = NULL, *region = NULL, *output = NULL, *center = NULL,
               *size = NULL, *cache_dir = NULL;
    long level = 0;
    double zoom = NAN, rot = 0, timeout = 30, gpu_mib = 256;
    int no_cache = 0, verbose = 0, have_level = 0, c;
    unsigned long long max_pixels = DEFAULT_MAX_PIXELS;
    optind = 1;
    while ((c = getopt_long(argc, argv, "i:l:R:c:z:r:s:o:t:vh", longopts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'i': image = optarg; break;
        case 'R': region = optarg; break;
        case 'c': center = optarg; break;
        case 's': size = optarg; break;
        case 'o': output = optarg; break;
        case 'C': cache_dir = optarg; break;
        case 'N': no_cache = 1; break;
        case 'v': verbose = 1; break;
        case 'l':
            level = strtol(optarg, &end, 10);
            have_level = 1;
            if (end == optarg || *end || level < 0 || level > 64) {
                fprintf(stderr, ME ": bad --level '%s'\n", optarg);
                return 2;
            }
            break;
        case 'z':
        case 'r':
        case 't':
        case 'G': {
            double d = strtod(optarg, &end);
            if (end == optarg || *end || !isfinite(d) ||
                (c == 't' && (d <= 0 || d > 86400)) || (c == 'G' && d < 0) ||
                (c == 'z' && fabs(d) > 64)) {
                fprintf(stderr, ME ": bad --%s '%s'\n",
                        c == 'z' ? "zoom" : c == 'r' ? "rotate" : c == 't' ? "timeout"
                                                                   : "gpu-cache",
                        optarg);
                return 2;
            }
            if (c == 'z') zoom = d;
            else if (c == 'r') rot = d;
            else if (c == 't') timeout = d;
            else gpu_mib = d;
            break;
        }
        case 'M':
            if (parse_count(optarg, &max_pixels) < 0) {
                fprintf(stderr, ME ": bad --max-pixels '%s'\n", optarg);
                return 2;
            }
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            usage(stderr);
            return 2;
        }
    }
    const int view_form = center || size || !isnan(zoom) || rot != 0;
    if (!output || !image || optind != argc - 1) {
        usage(stderr);
        return 2;
    }
    if (view_form && (region || have_level || !size || isnan(zoom))) {
        fprintf(stderr, ME ": the view form takes --zoom and --size (and optionally "
                "--center, --rotate), not --level or --region\n");
        return 2;
    }
    struct view v = {.zoom = zoom, .rot = rot};
    if (size) {
        double a, b;
        if (parse_pair(size, 'x', &a, &b) < 0 || a < 1 || b < 1 || a > 1e6 ||
            b > 1e6 || a != floor(a) || b != floor(b)) {
            fprintf(stderr, ME ": --size wants WxH, not '%s'\n", size);
            return 2;
        }
        v.w = (uint32_t)a;
        v.h = (uint32_t)b;
    }
    if (center && parse_pair(center, ',', &v.cx, &v.cy) < 0) {
        fprintf(stderr, ME ": --center wants X,Y, not '%s'\n", center);
        return 2;
    }

    struct gv_error err;
    struct session s;
    memset(&s, 0, sizeof s);
    s.verbose = verbose;
    s.gpu_budget = (size_t)(gpu_mib * 1048576.0);
    if (platform_from_env(&s.platform) < 0)
        return 2;
    int rc = 1;
    uint8_t *pixels = NULL;
    uint32_t ow = 0, oh = 0;
    if (!(s.http = gv_http_new(argv[optind], (long)(timeout * 1000), verbose, &err)) ||
        gv_http_image(s.http, image, &s.img, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        goto out;
    }
    if (gv_geometry_init(&s.geo, s.img.width, s.img.height, s.img.channels) < 0 ||
        s.geo.root != s.img.levels_tiled ||
        s.geo.level[s.geo.root].width != s.img.root_w ||
        s.geo.level[s.geo.root].height != s.img.root_h) {
        fprintf(stderr, ME ": the server's metadata for '%s' is inconsistent\n", image);
        goto out;
    }
    if (!no_cache) {
        s.dc = gv_disk_cache_open(cache_dir, gv_http_base(s.http), image);
        if (!s.dc && cache_dir)
            fprintf(stderr, ME ": warning: cannot use the cache directory %s\n",
                    cache_dir);
        if (verbose && s.dc)
            fprintf(stderr, "render: tile cache %s\n", gv_disk_cache_dir(s.dc));
    }
    const int c3 = s.img.channels;
    if (view_form) {
        if (!center) {
            v.cx = s.img.width / 2.0;
            v.cy = s.img.height / 2.0;
        }
        if ((unsigned long long)v.w * v.h > max_pixels) {
            fprintf(stderr, ME ": output of %llu pixels exceeds the limit of %llu "
                    "(--max-pixels)\n", (unsigned long long)v.w * v.h, max_pixels);
            goto out;
        }
        /* Decoding at level floor(zoom) must stay within reason too. */
        double span = exp2(v.zoom < 0 ? 0 : -floor(v.zoom));
        if ((double)v.w * v.h * span * span * 2 > (double)max_pixels * 4) {
            fprintf(stderr, ME ": the view needs too many decoded pixels\n");
            goto out;
        }
        ow = v.w;
        oh = v.h;
        if (!(pixels = malloc((size_t)ow * oh * c3))) {
            fprintf(stderr, ME ": out of memory\n");
            goto out;
        }
        if (render_view(&s, &v, pixels, &err) < 0) {
            fprintf(stderr, ME ": %s\n", err.text);
            goto out;
        }
    } else {
        const int top = s.geo.root + s.img.root_mips - 1;
        if (level > top) {
            fprintf(stderr, ME ": no level %ld (image '%s' has 0..%d)\n", level,
                    image, top);
            goto out;
        }
        uint32_t lw, lh;
        level_size(&s.geo, &s.img, (int)level, &lw, &lh);
        unsigned long long x = 0, y = 0, w = lw, h = lh;
        if (region) {
            char tail;
            if (sscanf(region, "%llu,%llu,%llu,%llu%c", &x, &y, &w, &h, &tail) != 4) {
                fprintf(stderr, ME ": --region wants X,Y,W,H, not '%s'\n", region);
                rc = 2;
                goto out;
            }
        }
        if (w == 0 || h == 0 || x >= lw || y >= lh || w > lw - x || h > lh - y) {
            fprintf(stderr, ME ": region %llu,%llu,%llu,%llu is outside level %ld "
                    "(%u x %u)\n", x, y, w, h, level, lw, lh);
            goto out;
        }
        if (w * h > max_pixels) {
            fprintf(stderr, ME ": region of %llu pixels exceeds the limit of %llu "
                    "(--max-pixels)\n", w * h, max_pixels);
            goto out;
        }
        ow = (uint32_t)w;
        oh = (uint32_t)h;
        if (!(pixels = malloc((size_t)(w * h * c3)))) {
            fprintf(stderr, ME ": out of memory\n");
            goto out;
        }
        if (render_region(&s, (int)level, (uint32_t)x, (uint32_t)y, ow, oh, pixels,
                          &err) < 0) {
            fprintf(stderr, ME ": %s\n", err.text);
            goto out;
        }
    }
    if (gv_image_write(output, ow, oh, c3, pixels, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        goto out;
    }
    rc = 0;
    if (verbose) {
        struct gv_http_stats hs;
        gv_http_stats(s.http, &hs);
        fprintf(stderr, "render: %zu tiles needed (ancestors included); http: %llu "
                "requests, %llu tiles downloaded, %llu revalidated (304), %llu bytes\n",
                s.nd.n, (unsigned long long)hs.requests,
                (unsigned long long)hs.downloaded, (unsigned long long)hs.revalidated,
                (unsigned long long)hs.bytes);
        if (s.cache) {
            struct gv_gpu_cache_stats gs;
            gv_gpu_cache_stats(s.cache, &gs);
            const struct gv_gpu_info *gi = gv_gpu_info(s.gpu);
            fprintf(stderr, "render: gpu %s (%s): %llu tiles decoded, %llu cache hits, "
                    "%llu evictions, peak %zu bytes\n", gi->renderer, gi->platform,
                    (unsigned long long)gs.decodes, (unsigned long long)gs.hits,
                    (unsigned long long)gs.evictions, gs.peak_bytes);
        }
    }
out:
    free(pixels);
    gv_gpu_cache_free(s.cache);
    gv_gpu_decoder_free(s.dec);
    gv_gpu_close(s.gpu);
    for (size_t i = 0; i < s.nd.n; i++)
        free(s.nd.t[i].buf);
    free(s.nd.t);
    gv_disk_cache_free(s.dc);
    gv_http_free(s.http);
    return rc;
}

#else /* !GV_HAVE_GPU */

/* Decoding on the GPU is all render does; this build has no EGL. */
int cmd_render(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    fprintf(stderr, ME ": needs a build with GPU support (this gigaview was "
            "configured --without-gpu); 'gigaview export' decodes on the CPU\n");
    return 1;
}

#endif
