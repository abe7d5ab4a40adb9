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
 * The steps, one function each: check the arguments (check_args), connect
 * and read the image's metadata (session_open), plan the tiles a picture
 * needs (need_range, plan_view_tiles), fetch them and start the GPU
 * (start_decoding), decode and read back (lvl_load, render_region),
 * compose (compose_view), write (cmd_render) and report (print_stats).
 *
 * Stores of 16-bit codes (height and sample stores) decode on the GPU as
 * 513x513xC R16UI textures (lib/gpu/gpu_height.c behind the same cache)
 * and become 8-bit pictures as gigaviewd draws them (to_display): a
 * height store's gray, a sample store's window on its codes (--window,
 * else the store's, else the codes' range) and its channels' colours
 * (--colours, else the store's, else the palette).  The region form then
 * equals `gigaview export` of the same store bit for bit.
 *
 * GIGAVIEW_GPU_PLATFORM (auto, device, surfaceless or default) forces an
 * EGL platform, as gigaviewd's gpu_platform does.  A build configured
 * --without-gpu has only a cmd_render that says it needs the GPU.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h" /* autoconf: GV_HAVE_GPU */

#include "base/byteorder.h"
#include "commands.h"
#include "gpu/gpu.h"
#include "gpu/gpu_cache.h"
#include "gpu/gpu_decode.h"
#include "imageio/imageio.h"
#include "options.h"
#include "region_arg.h"
#include "remote/http_fetch.h"
#include "remote/tile_cache_disk.h"
#include "render/height_region.h"
#include "render/samples_region.h"
#include "render/window.h"
#include "remote_opts.h"
#include "store/geometry.h"

#define ME "gigaview render"

#ifdef GV_HAVE_GPU

struct render_args {
    struct remote_opts remote; /* --timeout, --cache-dir, --no-cache, --gpu-cache */
    const char *image, *region, *center, *size, *output, *window, *colours;
    int level;             /* -1: not given (the region form then uses 0) */
    int no_batch, verbose;
    double zoom;           /* NAN: not given */
    double rotate;
    uint64_t max_pixels;
};

#define F(field) offsetof(struct render_args, field)
static const struct opt_spec render_opts[] = {
    {.name = "image", .short_name = 'i', .kind = OPT_STRING, .arg = "ID",
     .field = F(image), .help = "the image (see 'gigaview info URL')"},
    {.name = "level", .short_name = 'l', .kind = OPT_INT, .arg = "L",
     .field = F(level), .min = 0, .max = 64,
     .help = "pyramid level, 0 = full resolution (default 0)"},
    {.name = "region", .short_name = 'R', .kind = OPT_STRING, .arg = "X,Y,W,H",
     .field = F(region), .help = "pixels of that level (default: all of it)"},
    {.name = "center", .alias = "centre", .short_name = 'c', .kind = OPT_STRING,
     .arg = "X,Y", .field = F(center),
     .help = "view centre in level-0 pixels (default: image centre)"},
    {.name = "zoom", .short_name = 'z', .kind = OPT_DOUBLE, .arg = "Z",
     .field = F(zoom), .min = -64, .max = 64, .flags = OPT_FINITE,
     .help = "level of detail: one output pixel is 2^Z level-0\n"
             "pixels; fractions blend two levels"},
    {.name = "rotate", .short_name = 'r', .kind = OPT_DOUBLE, .arg = "DEG",
     .field = F(rotate), .min = -HUGE_VAL, .max = HUGE_VAL, .flags = OPT_FINITE,
     .help = "clockwise rotation of the view (default 0)"},
    {.name = "size", .short_name = 's', .kind = OPT_STRING, .arg = "WxH",
     .field = F(size), .help = "output size of the view"},
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "OUT",
     .field = F(output), .help = "the image to write"},
    {.name = "window", .kind = OPT_STRING, .arg = "B,W,G[;...]|none",
     .field = F(window),
     .help = "display window: black, white, gamma (one, or one\n"
             "a channel; default the store's, none for none;\n"
             "a sample store's on its 16-bit codes)"},
    {.name = "colours", .alias = "colors", .kind = OPT_STRING, .arg = "RRGGBB;...",
     .field = F(colours),
     .help = "a sample store's channel colours, one a channel\n"
             "(default the store's, else a palette)"},
    REMOTE_OPT_TIMEOUT(F(remote)),
    REMOTE_OPT_CACHE(F(remote)),
    {.name = "no-batch", .kind = OPT_FLAG, .field = F(no_batch),
     .help = "fetch each tile with a request of its own\n"
             "(default: batches of up to 64, one request each)"},
    REMOTE_OPT_GPU_CACHE(F(remote)),
    {.name = "max-pixels", .kind = OPT_COUNT, .arg = "N", .field = F(max_pixels),
     .help = "refuse larger outputs (default " OPT_STR(REGION_DEFAULT_MAX_PIXELS) ")"},
    {.name = "verbose", .short_name = 'v', .kind = OPT_FLAG, .field = F(verbose),
     .help = "log requests and statistics to stderr"},
};
#undef F

static const struct opt_command render_command = {
    .me = ME,
    .synopsis =
        "usage: gigaview render URL --image ID [--level L] [--region X,Y,W,H] -o OUT\n"
        "       gigaview render URL --image ID --center X,Y --zoom Z [--rotate DEG]\n"
        "                       --size WxH -o OUT\n"
        "\n"
        "Fetch compressed tiles from the gigaviewd at URL (http:// or https://),\n"
        "decode them on the GPU and write OUT (.png, .tif or .jpg).\n"
        "GIGAVIEW_GPU_PLATFORM=auto|device|surfaceless|default in the environment\n"
        "chooses the EGL platform (default auto: the first that works).\n"
        "GIGAVIEW_TOKEN, if set, is sent as the access token of restricted images.\n",
    .opts = render_opts,
    .nopts = sizeof render_opts / sizeof render_opts[0],
};

/* The tiles a picture needs, fetched as one batch. */
struct need {
    struct gv_tile_want *t;
    size_t n, cap;
};

/* Order of the tile list: coarse levels first, then row-major. */
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

/* Sort the list (cmp_want) and drop repeated tiles. */
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

/* The pixel (x, y) of level l: from the tile it belongs to (the last
 * tile of a row or column holds the level's edge). */
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

/* One run of the client: the server connection, the image's metadata and
 * geometry, the disk cache, the tiles fetched, and the GPU side. */
struct session {
    struct gv_http *http;
    struct gv_remote_image img;
    struct gv_geometry geo;
    struct gv_disk_cache *dc;
    struct need nd;
    struct gv_gpu *gpu;
    struct gv_gpu_decoder *dec;      /* image stores */
    struct gv_gpu_height *hdec;      /* stores of codes */
    struct gv_gpu_cache *cache;
    struct fetch_ctx fetch;
    size_t gpu_budget;
    enum gv_gpu_platform platform;
    /* What the display rules of render/samples_region.h need of the
     * image: its kind, channels and a sample store's codes' range. */
    struct gv_header hdr;
    int pc;                          /* channels of the picture */
    /* Stores of codes: the read-back tile, and how codes become the
     * picture (to_display). */
    uint16_t *codes;
    struct gv_height_meta hm;
    struct gv_window win;            /* a sample store's, on codes */
    struct gv_colours col;
    uint8_t *tables;                 /* C x 65536 */
};

/* n pixels of codes (s->img.channels a pixel) to the picture's pixels
 * (s->pc a pixel), as gigaviewd draws them: a height store's gray
 * (gv_height_gray; its window comes after, as for images), a sample
 * store's window and colours (gv_samples_display). */
static int to_display(struct session *s, const uint16_t *codes, size_t n,
                      uint8_t *out, struct gv_error *err)
{
    if (s->hdr.kind == GV_KIND_SAMPLES)
        return gv_samples_display(codes, n, s->img.channels, &s->win, &s->col,
                                  s->tables, out, err);
    for (size_t i = 0; i < n; i++)
        out[i] = gv_height_gray(&s->hm, codes[i]);
    return 0;
}

/* Little-endian codes (the server's raw form) in place as host order. */
static void codes_from_le(uint8_t *b, size_t n)
{
    uint16_t *c = (uint16_t *)(void *)b;
    for (size_t i = 0; i < n; i++)
        c[i] = gv_get16(b + 2 * i);
}

/* Root mip `mip` as the picture's pixels (*px malloc'ed, *w x *h). */
static int root_mip(struct session *s, int mip, uint8_t **px, uint32_t *w,
                    uint32_t *h, struct gv_error *err)
{
    uint8_t *raw;
    if (gv_http_root(s->http, &s->img, mip, s->dc, &raw, w, h, err) < 0)
        return -1;
    if (!gv_header_codes(&s->hdr)) {
        *px = raw;
        return 0;
    }
    const size_t n = (size_t)*w * *h;
    codes_from_le(raw, n * s->img.channels);
    *px = malloc(n * s->pc);
    int rc = *px ? to_display(s, (const uint16_t *)(void *)raw, n, *px, err)
                 : gv_fail(err, GV_ENOMEM, "out of memory");
    free(raw);
    return rc;
}

/* Tile (tx, ty) of `level` from the GPU cache as the picture's pixels
 * (513 x 513 x s->pc) into px. */
static int read_tile(struct session *s, int level, uint32_t tx, uint32_t ty,
                     uint8_t *px, struct gv_error *err)
{
    if (!gv_header_codes(&s->hdr))
        return gv_gpu_cache_read(s->cache, level, tx, ty, px, err);
    if (gv_gpu_cache_read(s->cache, level, tx, ty, s->codes, err) < 0)
        return -1;
    return to_display(s, s->codes, (size_t)GV_TILE * GV_TILE, px, err);
}

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

/* Fetch every tile in s->nd (deduplicated first) in one parallel batch;
 * on the first call also start the GPU, its decoder and the decoded-tile
 * cache, seeded with the root. */
static int start_decoding(struct session *s, struct gv_error *err)
{
    need_unique(&s->nd);
    if (gv_http_tiles(s->http, &s->img, s->nd.t, s->nd.n, s->dc, err) < 0)
        return -1;
    if (s->cache)
        return 0;
    if (!(s->gpu = gv_gpu_open(s->platform, err)))
        return -1;
    const int c = s->img.channels;
    struct gv_gpu_tiles tiles;
    if (gv_header_codes(&s->hdr)) {
        if (!(s->hdec = gv_gpu_height_new(s->gpu, &(struct gv_gpu_height_opts){
                                              .channels = c}, err)))
            return -1;
        if (!(s->codes = malloc(sizeof *s->codes * GV_TILE * GV_TILE * (size_t)c)))
            return gv_fail(err, GV_ENOMEM, "out of memory");
        tiles = gv_gpu_tiles_codes(s->hdec, c);
    } else {
        if (!(s->dec = gv_gpu_decoder_new(s->gpu, &(struct gv_gpu_decoder_opts){
                                              .channels = c}, err)))
            return -1;
        tiles = gv_gpu_tiles_image(s->dec, c);
    }
    uint8_t *root;
    uint32_t rw, rh;
    if (gv_http_root(s->http, &s->img, 0, s->dc, &root, &rw, &rh, err) < 0)
        return -1;
    if (gv_header_codes(&s->hdr))
        codes_from_le(root, (size_t)rw * rh * c);
    s->fetch = (struct fetch_ctx){&s->nd, s->http, &s->img, s->dc};
    s->cache = gv_gpu_cache_new(&tiles, &s->geo, root, rw, rh, s->gpu_budget,
                                fetch_tile, &s->fetch, err);
    free(root);
    return s->cache ? 0 : -1;
}

/* Load into *l level k's tiles [t0x..t1x] x [t0y..t1y], decoded and read
 * back from the GPU cache (or, for k >= root, its root mip).  On failure
 * *l holds what was loaded; lvl_free frees it either way. */
static int lvl_load(struct session *s, struct lvl *l, int k, uint32_t t0x,
                    uint32_t t0y, uint32_t t1x, uint32_t t1y, struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    memset(l, 0, sizeof *l);
    l->k = k;
    if (k >= g->root)
        return root_mip(s, k - g->root, &l->mip, &l->w, &l->h, err);
    const struct gv_level *gl = &g->level[k];
    l->w = gl->width;
    l->h = gl->height;
    l->tiles_x = gl->tiles_x;
    l->tiles_y = gl->tiles_y;
    if (!(l->tile = calloc((size_t)l->tiles_x * l->tiles_y, sizeof *l->tile)))
        return gv_fail(err, GV_ENOMEM, "out of memory");
    /* Missing tiles and ancestors in one batch, where the budget allows. */
    if (gv_gpu_cache_prepare(s->cache, k, t0x, t0y, t1x, t1y, err) < 0)
        return -1;
    for (uint32_t ty = t0y; ty <= t1y; ty++)
        for (uint32_t tx = t0x; tx <= t1x; tx++) {
            uint8_t **p = &l->tile[(size_t)ty * l->tiles_x + tx];
            if (!(*p = malloc((size_t)GV_TILE * GV_TILE * s->pc)))
                return gv_fail(err, GV_ENOMEM, "out of memory");
            if (read_tile(s, k, tx, ty, *p, err) < 0)
                return -1;
        }
    return 0;
}

/* The tiles of level l that pixels x0..x1, y0..y1 (inclusive) need, as
 * store_decoder.c finds them: t = {first x, first y, last x, last y}. */
static void tile_span(const struct gv_level *l, uint32_t x0, uint32_t x1,
                      uint32_t y0, uint32_t y1, uint32_t *t)
{
    t[0] = x0 / GV_STEP;
    t[2] = x1 / GV_STEP;
    t[1] = y0 / GV_STEP;
    t[3] = y1 / GV_STEP;
    if (t[2] >= l->tiles_x) t[2] = l->tiles_x - 1;
    if (t[3] >= l->tiles_y) t[3] = l->tiles_y - 1;
    if (t[0] > t[2]) t[0] = t[2];
    if (t[1] > t[3]) t[1] = t[3];
}

/* Bounding box in level pixels (inclusive, clamped to the level's w x h)
 * of the level-0 box [ax,bx] x [ay,by], at s level-0 pixels per level
 * pixel, widened by one pixel for bilinear taps.  box: x0, y0, x1, y1. */
static void level_box(uint32_t w, uint32_t h, double s, double ax, double ay,
                      double bx, double by, uint32_t *box)
{
    double v[4] = {floor(ax / s - 0.5) - 1, floor(ay / s - 0.5) - 1,
                   ceil(bx / s - 0.5) + 1, ceil(by / s - 0.5) + 1};
    double lim[4] = {w - 1.0, h - 1.0, w - 1.0, h - 1.0};
    for (int i = 0; i < 4; i++)
        box[i] = (uint32_t)(v[i] < 0 ? 0 : v[i] > lim[i] ? lim[i] : v[i]);
}

/* Bilinear sample of level l at level-0 point (px,py), s level-0 pixels
 * per level pixel, added with weight wgt to acc[0..c). */
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

/* A view: centre (level-0 pixels), zoom, clockwise rotation in degrees
 * and output size. */
struct view {
    double cx, cy, zoom, rot;
    uint32_t w, h;
};

/* How a view maps output to level-0 pixels, and the levels it samples:
 * level f with weight 1 - t, and level f + 1 with weight t when nl is 2. */
struct view_plan {
    int f, nl;
    double t;
    double scale;       /* level-0 pixels per output pixel, 2^zoom */
    double cs, sn;      /* the rotation from output to image */
};

/* Plan view v over levels 0..top (top: the last root mip): zooms below
 * 0 sample level 0 magnified, zooms at or past top sample top alone. */
static void plan_view(const struct view *v, int top, struct view_plan *p)
{
    p->f = (int)floor(v->zoom);
    p->t = v->zoom - p->f;
    if (p->f < 0) {
        p->f = 0;
        p->t = 0;
    }
    if (p->f >= top) {
        p->f = top;
        p->t = 0;
    }
    p->nl = p->t > 0 ? 2 : 1;
    p->scale = exp2(v->zoom);
    const double th = v->rot * M_PI / 180.0;
    /* Output to image: rotate by -DEG, so the image appears turned
     * clockwise by DEG (y points down). */
    p->cs = cos(th);
    p->sn = -sin(th);
}

/* The level-0 bounding box of the view's corners, b = {ax, ay, bx, by},
 * clipped to the image.  Returns 0 when the view shows none of it. */
static int view_bounds(const struct view *v, const struct view_plan *p,
                       const struct gv_geometry *g, double *b)
{
    double ax = 1e300, ay = 1e300, bx = -1e300, by = -1e300;
    for (int i = 0; i < 4; i++) {
        double dx = ((i & 1) ? 0.5 : -0.5) * v->w, dy = ((i & 2) ? 0.5 : -0.5) * v->h;
        double px = v->cx + p->scale * (dx * p->cs - dy * p->sn);
        double py = v->cy + p->scale * (dx * p->sn + dy * p->cs);
        ax = fmin(ax, px), bx = fmax(bx, px), ay = fmin(ay, py), by = fmax(by, py);
    }
    if (bx <= 0 || by <= 0 || ax >= g->width || ay >= g->height)
        return 0;
    b[0] = fmax(ax, 0), b[1] = fmax(ay, 0);
    b[2] = fmin(bx, g->width), b[3] = fmin(by, g->height);
    return 1;
}

/* Add to s->nd the tiles of the sampled tiled levels that cover the
 * level-0 box b (and their ancestors); span[i]: the tile range of level
 * f + i (set for tiled levels only). */
static int plan_view_tiles(struct session *s, const struct view_plan *p,
                           const double *b, uint32_t span[2][4], struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    for (int i = 0; i < p->nl; i++) {
        int k = p->f + i;
        uint32_t w, h, box[4];
        gv_level_size(g, k, &w, &h); /* the server's root matched g */
        level_box(w, h, exp2(k), b[0], b[1], b[2], b[3], box);
        if (k >= g->root)
            continue;
        tile_span(&g->level[k], box[0], box[2], box[1], box[3], span[i]);
        if (need_range(&s->nd, g, k, span[i][0], span[i][1], span[i][2],
                       span[i][3]) < 0)
            return gv_fail(err, GV_ENOMEM, "out of memory");
    }
    return 0;
}

/* Every output pixel of the view inside the image: the blend of its
 * bilinear samples of the loaded levels L[0..p->nl). */
static void compose_view(const struct view *v, const struct view_plan *p,
                         const struct gv_geometry *g, const struct lvl *L, int c,
                         uint8_t *out)
{
    for (uint32_t j = 0; j < v->h; j++)
        for (uint32_t i = 0; i < v->w; i++) {
            double dx = (i + 0.5 - v->w / 2.0) * p->scale;
            double dy = (j + 0.5 - v->h / 2.0) * p->scale;
            double px = v->cx + dx * p->cs - dy * p->sn;
            double py = v->cy + dx * p->sn + dy * p->cs;
            if (px < 0 || py < 0 || px >= g->width || py >= g->height)
                continue;
            double acc[3] = {0, 0, 0};
            sample(&L[0], exp2(p->f), px, py, c, acc, 1 - p->t);
            if (p->nl == 2)
                sample(&L[1], exp2(p->f + 1), px, py, c, acc, p->t);
            uint8_t *o = out + ((size_t)j * v->w + i) * c;
            for (int k = 0; k < c; k++) {
                double q = floor(acc[k] + 0.5);
                o[k] = (uint8_t)(q < 0 ? 0 : q > 255 ? 255 : q);
            }
        }
}

/* Render view v into out (v->w x v->h pixels; black outside the image). */
static int render_view(struct session *s, const struct view *v, uint8_t *out,
                       struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    struct view_plan p;
    double b[4];
    plan_view(v, g->root + s->img.root_mips - 1, &p);
    memset(out, 0, (size_t)v->w * v->h * s->pc);
    if (!view_bounds(v, &p, g, b))
        return 0;                                   /* nothing of the image */
    struct lvl L[2];
    uint32_t span[2][4];
    memset(L, 0, sizeof L);
    int rc = -1;
    if (plan_view_tiles(s, &p, b, span, err) < 0)
        goto out;
    if (s->nd.n && start_decoding(s, err) < 0)
        goto out;
    for (int i = 0; i < p.nl; i++)
        if (lvl_load(s, &L[i], p.f + i, span[i][0], span[i][1], span[i][2],
                     span[i][3], err) < 0)
            goto out;
    compose_view(v, &p, g, L, s->pc, out);
    rc = 0;
out:
    lvl_free(&L[0]);
    lvl_free(&L[1]);
    return rc;
}

/* Copy region r of root mip `mip` into out. */
static int copy_root_region(struct session *s, int mip, const struct region *r,
                            uint8_t *out, struct gv_error *err)
{
    const int c = s->pc;
    const size_t orow = (size_t)r->w * c;
    uint8_t *px;
    uint32_t mw, mh;
    if (root_mip(s, mip, &px, &mw, &mh, err) < 0)
        return -1;
    for (uint32_t row = 0; row < r->h; row++)
        memcpy(out + row * orow, px + ((size_t)(r->y + row) * mw + r->x) * c, orow);
    free(px);
    return 0;
}

/* Copy the part of region r that tile (tx, ty) of level l is the source
 * of (store_decoder.c's rule) from its pixels px into out. */
static void copy_tile_part(const struct gv_level *l, uint32_t tx, uint32_t ty,
                           const uint8_t *px, const struct region *r, int c,
                           uint8_t *out)
{
    const size_t orow = (size_t)r->w * c;
    uint32_t sx0 = tx * GV_STEP, sy0 = ty * GV_STEP;
    uint32_t sx1 = tx + 1 == l->tiles_x ? l->width : sx0 + GV_STEP;
    uint32_t sy1 = ty + 1 == l->tiles_y ? l->height : sy0 + GV_STEP;
    uint32_t ax = r->x > sx0 ? r->x : sx0, bx = r->x + r->w < sx1 ? r->x + r->w : sx1;
    uint32_t ay = r->y > sy0 ? r->y : sy0, by = r->y + r->h < sy1 ? r->y + r->h : sy1;
    for (uint32_t yy = ay; ax < bx && yy < by; yy++)
        memcpy(out + (size_t)(yy - r->y) * orow + (size_t)(ax - r->x) * c,
               px + ((size_t)(yy - sy0) * GV_TILE + (ax - sx0)) * c,
               (size_t)(bx - ax) * c);
}

/* Render region r of `level` into out (r->w x r->h pixels): the pixels
 * `gigaview export` writes for it. */
static int render_region(struct session *s, int level, const struct region *r,
                         uint8_t *out, struct gv_error *err)
{
    const struct gv_geometry *g = &s->geo;
    const int c = s->pc;
    if (level >= g->root)
        return copy_root_region(s, level - g->root, r, out, err);
    const struct gv_level *l = &g->level[level];
    uint32_t sp[4];
    tile_span(l, r->x, r->x + r->w - 1, r->y, r->y + r->h - 1, sp);
    if (need_range(&s->nd, g, level, sp[0], sp[1], sp[2], sp[3]) < 0)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    if (start_decoding(s, err) < 0)
        return -1;
    if (gv_gpu_cache_prepare(s->cache, level, sp[0], sp[1], sp[2], sp[3], err) < 0)
        return -1;
    uint8_t *px = malloc((size_t)GV_TILE * GV_TILE * c);
    if (!px)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    for (uint32_t ty = sp[1]; ty <= sp[3]; ty++)
        for (uint32_t tx = sp[0]; tx <= sp[2]; tx++) {
            if (read_tile(s, level, tx, ty, px, err) < 0) {
                free(px);
                return -1;
            }
            copy_tile_part(l, tx, ty, px, r, c, out);
        }
    free(px);
    return 0;
}

/* "AxB" (sep 'x') or "A,B" (sep ','): two finite numbers. */
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

/* The view form: any of --center, --size, --zoom, or a rotation. */
static int is_view_form(const struct render_args *a)
{
    return a->center || a->size || !isnan(a->zoom) || a->rotate != 0;
}

/* Check the arguments beyond each option's own value: the operands (one
 * URL), the options each form needs and refuses, and parse --size and
 * --center into *v.  Returns OPT_GO_ON, or 2 after a message. */
static int check_args(const struct render_args *a, int noperands, struct view *v)
{
    if (!a->output || !a->image || noperands != 1) {
        opt_usage(&render_command, stderr);
        return 2;
    }
    if (is_view_form(a) && (a->region || a->level >= 0 || !a->size || isnan(a->zoom))) {
        fprintf(stderr, ME ": the view form takes --zoom and --size (and optionally "
                "--center, --rotate), not --level or --region\n");
        return 2;
    }
    *v = (struct view){.zoom = a->zoom, .rot = a->rotate};
    if (a->size) {
        double w, h;
        if (parse_pair(a->size, 'x', &w, &h) < 0 || w < 1 || h < 1 || w > 1e6 ||
            h > 1e6 || w != floor(w) || h != floor(h)) {
            fprintf(stderr, ME ": --size wants WxH, not '%s'\n", a->size);
            return 2;
        }
        v->w = (uint32_t)w;
        v->h = (uint32_t)h;
    }
    if (a->center && parse_pair(a->center, ',', &v->cx, &v->cy) < 0) {
        fprintf(stderr, ME ": --center wants X,Y, not '%s'\n", a->center);
        return 2;
    }
    return OPT_GO_ON;
}

/* Open the disk cache of the image (a failure is only a warning). */
static void open_disk_cache(struct session *s, const struct render_args *a)
{
    s->dc = gv_disk_cache_open(a->remote.cache_dir, gv_http_base(s->http), a->image);
    if (!s->dc && a->remote.cache_dir)
        fprintf(stderr, ME ": warning: cannot use the cache directory %s\n",
                a->remote.cache_dir);
    if (a->verbose && s->dc)
        fprintf(stderr, "render: tile cache %s\n", gv_disk_cache_dir(s->dc));
}

/* Connect to the server at url, read the image's metadata and check it
 * against the geometry it implies, and open the disk cache.  Returns 0,
 * or -1 after a message; session_close frees *s either way. */
static int session_open(struct session *s, const char *url, const struct render_args *a,
                        enum gv_gpu_platform platform)
{
    struct gv_error err = {0};
    memset(s, 0, sizeof *s);
    s->platform = platform;
    s->gpu_budget = remote_gpu_bytes(&a->remote);
    if (!(s->http = gv_http_new(url, remote_timeout_ms(&a->remote), a->verbose, &err)) ||
        gv_http_image(s->http, a->image, &s->img, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return -1;
    }
    gv_http_use_batches(s->http, !a->no_batch);
    if (gv_geometry_init(&s->geo, s->img.width, s->img.height, s->img.channels,
                         s->img.root_side) < 0 ||
        s->geo.root != s->img.levels_tiled ||
        s->geo.level[s->geo.root].width != s->img.root_w ||
        s->geo.level[s->geo.root].height != s->img.root_h) {
        fprintf(stderr, ME ": the server's metadata for '%s' is inconsistent\n",
                a->image);
        return -1;
    }
    s->hdr = gv_remote_header(&s->img);
    s->pc = gv_display_channels(&s->hdr);
    if (s->hdr.kind == GV_KIND_HEIGHT)
        s->hm = gv_remote_height_meta(&s->img);
    if (!a->remote.no_cache)
        open_disk_cache(s, a);
    return 0;
}

/* A sample store's picture: the window on its codes (--window, else the
 * store's, else the codes' range) and the channels' colours (--colours,
 * else the store's, else the palette), as gigaviewd resolves them for a
 * region.  --colours for another store is refused.  Returns the exit
 * status (2 for a bad option). */
static int samples_display_setup(struct session *s, const struct render_args *a)
{
    struct gv_error err = {0};
    const struct gv_window none = {0};
    /* gv_display_check: colours for a sample store only, one a channel. */
    if (a->colours && (gv_colours_parse(a->colours, &s->col, &err) < 0 ||
                       gv_display_check(&s->hdr, &none, &s->col, &err) < 0)) {
        fprintf(stderr, ME ": --colours: %s ('%s')\n", err.text, a->image);
        return 2;
    }
    if (s->hdr.kind != GV_KIND_SAMPLES)
        return 0;
    const int c = s->img.channels;
    const char *text = a->window ? a->window : s->img.window;
    if (*text && strcmp(text, "none") &&
        (gv_window_parse(text, 65535, &s->win, &err) < 0 ||
         gv_display_check(&s->hdr, &s->win, &s->col, &err) < 0)) {
        fprintf(stderr, ME ": %s\n", err.text);
        return a->window ? 2 : 1;
    }
    if (s->win.count == 0)
        gv_samples_default_window(&s->hdr, &s->win);
    if (!a->colours && *s->img.colours) {
        /* The store's, when they fit it (else the palette, as the server). */
        if (gv_colours_parse(s->img.colours, &s->col, &err) < 0 ||
            gv_colours_check(&s->col, c, &err) < 0)
            memset(&s->col, 0, sizeof s->col);
    }
    if (!(s->tables = malloc((size_t)c * 65536))) {
        fprintf(stderr, ME ": out of memory\n");
        return 1;
    }
    return 0;
}

static void session_close(struct session *s)
{
    gv_gpu_cache_free(s->cache);
    gv_gpu_decoder_free(s->dec);
    gv_gpu_height_free(s->hdec);
    gv_gpu_close(s->gpu);
    free(s->codes);
    free(s->tables);
    for (size_t i = 0; i < s->nd.n; i++)
        free(s->nd.t[i].buf);
    free(s->nd.t);
    gv_disk_cache_free(s->dc);
    gv_http_free(s->http);
}

/* The picture to write: w x h pixels of the image's channels. */
struct picture {
    uint8_t *px;
    uint32_t w, h;
};

static int picture_alloc(struct picture *pic, uint32_t w, uint32_t h, int c)
{
    pic->w = w;
    pic->h = h;
    if (!(pic->px = malloc((size_t)w * h * c))) {
        fprintf(stderr, ME ": out of memory\n");
        return -1;
    }
    return 0;
}

/* The view form: check the output against --max-pixels, then render.
 * Returns the exit status. */
static int draw_view(struct session *s, const struct render_args *a, struct view *v,
                     struct picture *pic)
{
    struct gv_error err = {0};
    if (!a->center) {
        v->cx = s->img.width / 2.0;
        v->cy = s->img.height / 2.0;
    }
    if ((unsigned long long)v->w * v->h > a->max_pixels) {
        fprintf(stderr, ME ": output of %llu pixels exceeds the limit of %llu "
                "(--max-pixels)\n", (unsigned long long)v->w * v->h,
                (unsigned long long)a->max_pixels);
        return 1;
    }
    /* Decoding at level floor(zoom) must stay within reason too. */
    double span = exp2(v->zoom < 0 ? 0 : -floor(v->zoom));
    if ((double)v->w * v->h * span * span * 2 > (double)a->max_pixels * 4) {
        fprintf(stderr, ME ": the view needs too many decoded pixels\n");
        return 1;
    }
    if (picture_alloc(pic, v->w, v->h, s->pc) < 0)
        return 1;
    if (render_view(s, v, pic->px, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    return 0;
}

/* The region form: check --level and --region against the image, then
 * render.  Returns the exit status. */
static int draw_region(struct session *s, const struct render_args *a,
                       struct picture *pic)
{
    struct gv_error err = {0};
    const int top = s->geo.root + s->img.root_mips - 1;
    const int level = a->level < 0 ? 0 : a->level;
    uint32_t lw, lh;
    if (level > top || gv_level_size(&s->geo, level, &lw, &lh) < 0) {
        fprintf(stderr, ME ": no level %d (image '%s' has 0..%d)\n", level,
                a->image, top);
        return 1;
    }
    struct region r;
    int rc = region_arg_check(ME, a->region, level, lw, lh, a->max_pixels, &r);
    if (rc)
        return rc;
    if (picture_alloc(pic, r.w, r.h, s->pc) < 0)
        return 1;
    if (render_region(s, level, &r, pic->px, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    return 0;
}

/* The display window (--window, else the store's default) over the
 * picture, as gigaviewd applies it to a region: the same tables
 * (render/window.h) on the same 8-bit samples (a height store's gray; a
 * sample store's window went on its codes, to_display).  Returns the exit
 * status. */
static int apply_window(const struct session *s, const struct render_args *a,
                        struct picture *pic)
{
    if (s->hdr.kind == GV_KIND_SAMPLES)
        return 0;
    const char *text = a->window ? a->window : s->img.window;
    if (!*text || !strcmp(text, "none"))
        return 0;
    struct gv_window w;
    struct gv_error err = {0};
    if (gv_window_parse(text, 255, &w, &err) < 0 ||
        gv_window_apply8(&w, pic->px, (size_t)pic->w * pic->h, s->pc, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return a->window ? 2 : 1;
    }
    return 0;
}

/* --verbose: what was fetched over HTTP and decoded on the GPU. */
static void print_stats(const struct session *s)
{
    struct gv_http_stats hs;
    gv_http_stats(s->http, &hs);
    fprintf(stderr, "render: %zu tiles needed (ancestors included); http: %llu "
            "requests, %llu tiles downloaded, %llu revalidated (304), %llu bytes, "
            "%.1f ms waited\n",
            s->nd.n, (unsigned long long)hs.requests,
            (unsigned long long)hs.downloaded, (unsigned long long)hs.revalidated,
            (unsigned long long)hs.bytes, (double)hs.wait_us / 1000.0);
    if (!s->cache)
        return;
    struct gv_gpu_cache_stats gs;
    gv_gpu_cache_stats(s->cache, &gs);
    const struct gv_gpu_info *gi = gv_gpu_info(s->gpu);
    fprintf(stderr, "render: gpu %s (%s): %llu tiles decoded, %llu cache hits, "
            "%llu evictions, peak %zu bytes\n", gi->renderer, gi->platform,
            (unsigned long long)gs.decodes, (unsigned long long)gs.hits,
            (unsigned long long)gs.evictions, gs.peak_bytes);
}

int cmd_render(int argc, char **argv)
{
    struct render_args a = {.level = -1, .zoom = NAN,
                            .max_pixels = REGION_DEFAULT_MAX_PIXELS};
    remote_opts_init(&a.remote);
    int first, rc = opt_parse(&render_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    struct view v;
    if ((rc = check_args(&a, argc - first, &v)) != OPT_GO_ON)
        return rc;
    enum gv_gpu_platform platform;
    if (platform_from_env(&platform) < 0)
        return 2;
    struct session s;
    struct picture pic = {NULL, 0, 0};
    struct gv_error err = {0};
    rc = 1;
    if (session_open(&s, argv[first], &a, platform) == 0 &&
        (rc = samples_display_setup(&s, &a)) == 0) {
        rc = is_view_form(&a) ? draw_view(&s, &a, &v, &pic) : draw_region(&s, &a, &pic);
        if (rc == 0)
            rc = apply_window(&s, &a, &pic);
        if (rc == 0 && gv_image_write(a.output, pic.w, pic.h, s.pc, pic.px,
                                      &err) < 0) {
            fprintf(stderr, ME ": %s\n", err.text);
            rc = 1;
        }
        if (rc == 0 && a.verbose)
            print_stats(&s);
    }
    free(pic.px);
    session_close(&s);
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
