/*
 * view_tiles.c - tile scheduling, the atlas and the page table of
 * `gigaview view` (view_tiles.h).
 *
 * Every tile ever asked for has an entry in an open-addressing hash (a
 * few dozen bytes each: a gigapixel pan touches thousands, not millions):
 * its compressed buffer when it came, its fetch failures, its atlas layer.
 * A frame lists the tiles its two levels need (cmd_render.c's rule: the
 * window's level-0 bounding box, widened by a pixel for the bilinear
 * taps), coarse level first and nearest the centre first.  A tile is
 * decoded once its buffer and those of all its tiled ancestors are in
 * (gv_gpu_cache_get pulls the parents, from its own cache or from those
 * buffers), then copied into an atlas layer: the least recently drawn one
 * that this frame does not draw.  What is missing is posted to the fetch
 * thread, ancestors first.  A failed fetch is asked again after a delay
 * that doubles up to 2 s, and the view meanwhile draws the ancestor.
 * Prefetching (thesis section 7.5) starts once the view is complete: the
 * tiles of level f in the window's box moved half a window ahead of the
 * motion (or grown by a quarter on every side at rest) are fetched, and
 * decoded into layers no frame drew for a second, within what is left of
 * the budget.
 *
 * With the decode thread (view_decode.h) a tile's layer is reserved when
 * its job is posted (the slot is busy: never drawn, never taken) and its
 * old tile leaves the page table at once; a fence made then on the window's
 * context (and flushed) lets the decode context wait on the GPU for the
 * draws that still read the old tile.  Results are polled each frame and
 * published once their fence has signalled (glClientWaitSync with a
 * timeout of 0: the render thread never waits); a fence not signalled yet
 * is tested again next frame.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <GLES3/gl32.h>

#include "gpu/gpu_cache.h"
#include "gpu/gpu_decode.h"
#include "view_decode.h"
#include "view_tiles.h"

#define TILE_TEX_BYTES ((size_t)GV_TILE * GV_TILE * 4)

enum { E_NONE, E_HAVE, E_FAILED };

struct entry {
    int level;
    uint32_t tx, ty;
    uint8_t *buf;
    size_t len;
    int state, fails;
    int slot;                 /* atlas layer, -1 */
    int pending;              /* its decode job is in flight (slot reserved) */
    uint64_t used;            /* frame that last needed it (or an offspring) */
    uint64_t listed;          /* frame that last put it on a list */
    double retry_at;
};

struct slot {
    struct entry *e;          /* NULL: free (or pinned when pinned) */
    uint64_t used;
    int pinned;
    int busy;                 /* reserved by a decode job in flight */
};

struct vt {
    struct gv_gpu *gpu;
    struct gv_gpu_decoder *dec;
    struct gv_gpu_height *hdec;   /* stores of codes */
    int layers;               /* atlas layers a tile: 1, or a store of codes' channels */
    size_t slot_bytes;        /* GPU bytes of one atlas slot */
    struct gv_gpu_cache *cache;
    struct vdt *dt;           /* the decode thread, or NULL */
    int dt_broken;            /* it failed to start: nothing more is posted */
    struct vdt_done *pend;    /* results whose fence has not signalled */
    size_t npend, cappend;
    double frame_t0;          /* when this frame's decode work began */
    int posted;               /* jobs posted this frame */
    struct gv_geometry geo;
    struct gv_remote_image img;
    int top;
    struct vt_options o;
    struct vt_gl gl;
    /* entries */
    struct entry **tab;
    size_t cap, count;
    size_t buf_bytes;
    /* atlas */
    struct slot *slots;
    int nslots;
    uint64_t frame;
    /* lists of this frame */
    struct entry **need;
    size_t nneed, capneed;
    struct vf_key *want;
    size_t nwant, capwant;
    struct vt_stats st;
};

static uint64_t key_of(int level, uint32_t tx, uint32_t ty)
{
    return (uint64_t)level << 58 | (uint64_t)ty << 29 | tx;
}

static size_t hash(uint64_t k)
{
    k ^= k >> 31;
    k *= 0x7fb5d329728ea185ull;
    k ^= k >> 27;
    return (size_t)k;
}

static int grow(struct vt *t)
{
    size_t cap = t->cap ? 2 * t->cap : 4096;
    struct entry **tab = calloc(cap, sizeof *tab);
    if (!tab)
        return -1;
    for (size_t i = 0; i < t->cap; i++) {
        struct entry *e = t->tab[i];
        if (!e)
            continue;
        size_t j = hash(key_of(e->level, e->tx, e->ty)) & (cap - 1);
        while (tab[j])
            j = (j + 1) & (cap - 1);
        tab[j] = e;
    }
    free(t->tab);
    t->tab = tab;
    t->cap = cap;
    return 0;
}

/* The entry of a tile, made when missing (NULL: out of memory). */
static struct entry *lookup(struct vt *t, int level, uint32_t tx, uint32_t ty,
                            int make)
{
    if (t->cap) {
        size_t j = hash(key_of(level, tx, ty)) & (t->cap - 1);
        for (; t->tab[j]; j = (j + 1) & (t->cap - 1)) {
            struct entry *e = t->tab[j];
            if (e->level == level && e->tx == tx && e->ty == ty)
                return e;
        }
    }
    if (!make)
        return NULL;
    if ((t->count + 1) * 2 > t->cap && grow(t) < 0)
        return NULL;
    struct entry *e = calloc(1, sizeof *e);
    if (!e)
        return NULL;
    *e = (struct entry){.level = level, .tx = tx, .ty = ty, .slot = -1};
    size_t j = hash(key_of(level, tx, ty)) & (t->cap - 1);
    while (t->tab[j])
        j = (j + 1) & (t->cap - 1);
    t->tab[j] = e;
    t->count++;
    return e;
}

/* The decoder cache's fetch callback: only buffers already here. */
static int from_memory(void *arg, int level, uint32_t tx, uint32_t ty,
                       uint8_t **buf, size_t *len, struct gv_error *err)
{
    struct vt *t = arg;
    struct entry *e = lookup(t, level, tx, ty, 0);
    if (!e || e->state != E_HAVE)
        return gv_fail(err, GV_EUNAVAIL, "view: tile %d/%u/%u not fetched yet",
                       level, tx, ty);
    if (!(*buf = malloc(e->len ? e->len : 1)))
        return gv_fail(err, GV_ENOMEM, "out of memory");
    memcpy(*buf, e->buf, e->len);
    *len = e->len;
    return 0;
}

/* Point the page-table texel of tile (level, tx, ty) at layer + 1 (0: none). */
static void pt_set(struct vt *t, int level, uint32_t tx, uint32_t ty, unsigned v)
{
    glBindTexture(GL_TEXTURE_2D, t->gl.page_table);
    glTexSubImage2D(GL_TEXTURE_2D, 0, (GLint)tx, t->gl.row[level] + (GLint)ty, 1, 1,
                    GL_RED_INTEGER, GL_UNSIGNED_INT, &v);
}

/* Upload root mip m (w x h x c codes, little-endian) of a store of codes
 * into pinned slot `slot`: a layer a channel. */
static int upload_mip_codes(struct vt *t, int slot, const uint8_t *px, uint32_t w,
                            uint32_t h, struct gv_error *err)
{
    const int c = t->geo.channels;
    uint16_t *plane = malloc(sizeof *plane * (size_t)w * h);
    if (!plane)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    glBindTexture(GL_TEXTURE_2D_ARRAY, t->gl.atlas);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
    for (int k = 0; k < c; k++) {
        for (size_t i = 0; i < (size_t)w * h; i++) {
            const uint8_t *b = px + 2 * (i * c + (size_t)k);
            plane[i] = (uint16_t)(b[0] | b[1] << 8);
        }
        glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, slot * c + k, (GLsizei)w,
                        (GLsizei)h, 1, GL_RED_INTEGER, GL_UNSIGNED_SHORT, plane);
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    free(plane);
    return 0;
}

/* Upload root mip m (w x h x c) into a pinned layer. */
static int upload_mip(struct vt *t, int layer, const uint8_t *px, uint32_t w,
                      uint32_t h, struct gv_error *err)
{
    if (t->gl.codes)
        return upload_mip_codes(t, layer, px, w, h, err);
    const int c = t->geo.channels;
    uint8_t *rgba = malloc((size_t)w * h * 4);
    if (!rgba)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    for (size_t i = 0; i < (size_t)w * h; i++) {
        for (int k = 0; k < 3; k++)
            rgba[4 * i + k] = px[i * c + (c == 3 ? k : 0)];
        rgba[4 * i + 3] = 255;
    }
    glBindTexture(GL_TEXTURE_2D_ARRAY, t->gl.atlas);
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, layer, (GLsizei)w, (GLsizei)h, 1,
                    GL_RGBA_INTEGER, GL_UNSIGNED_BYTE, rgba);
    free(rgba);
    return 0;
}

/* Geometry tables, the atlas and the page table. */
static int gl_setup(struct vt *t, struct vf_result *res, struct gv_error *err)
{
    const struct gv_geometry *g = &t->geo;
    GLint max_layers = 0, max_size = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    int rows = 0, ptw = 1;
    t->gl.nlevels = t->top + 1;
    t->gl.root = g->root;
    for (int k = 0; k <= t->top; k++) {
        uint32_t w, h;
        gv_level_size(g, k, &w, &h);
        int tx = k < g->root ? (int)g->level[k].tiles_x : 1;
        int ty = k < g->root ? (int)g->level[k].tiles_y : 1;
        t->gl.lv[k][0] = (int)w;
        t->gl.lv[k][1] = (int)h;
        t->gl.lv[k][2] = tx;
        t->gl.lv[k][3] = ty;
        t->gl.row[k] = rows;
        rows += ty;
        if (tx > ptw)
            ptw = tx;
    }
    if (ptw > max_size || rows > max_size)
        return gv_fail(err, GV_EINVAL, "view: the image is too large for this "
                       "GPU's page table (%dx%d texels, the limit is %d)",
                       ptw, rows, (int)max_size);
    int pinned = t->top - g->root + 1;
    long want = (long)(t->o.atlas_bytes / t->slot_bytes);
    if (want < pinned + 8)
        want = pinned + 8;
    if (want > max_layers / t->layers)
        want = max_layers / t->layers;
    t->nslots = (int)want;
    if (!(t->slots = calloc((size_t)t->nslots, sizeof *t->slots)))
        return gv_fail(err, GV_ENOMEM, "out of memory");
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_SKIP_ROWS, 0);
    glPixelStorei(GL_UNPACK_SKIP_PIXELS, 0);
    glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
    glPixelStorei(GL_UNPACK_SKIP_IMAGES, 0);
    glGenTextures(1, &t->gl.atlas);
    glBindTexture(GL_TEXTURE_2D_ARRAY, t->gl.atlas);
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, t->gl.codes ? GL_R16UI : GL_RGBA8UI, GV_TILE,
                   GV_TILE, t->nslots * t->layers);
    /* Integer textures are incomplete (read as 0) with linear filters. */
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glGenTextures(1, &t->gl.page_table);
    glBindTexture(GL_TEXTURE_2D, t->gl.page_table);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32UI, ptw, rows);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    uint32_t *zero = calloc((size_t)ptw * rows, 4);
    if (!zero)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, ptw, rows, GL_RED_INTEGER,
                    GL_UNSIGNED_INT, zero);
    free(zero);
    for (int m = 0; m < pinned; m++) {
        if (upload_mip(t, m, res->mip[m], res->mip_w[m], res->mip_h[m], err) < 0)
            return -1;
        t->slots[m].pinned = 1;
        pt_set(t, g->root + m, 0, 0, (unsigned)m + 1);
    }
    if (glGetError() != GL_NO_ERROR)
        return gv_fail(err, GV_EIO, "view: cannot make the atlas (%d layers)",
                       t->nslots);
    t->st.layers = t->nslots;
    return 0;
}

struct vt *vt_new(struct gv_gpu *g, struct vf_result *res,
                  const struct vt_options *o, struct gv_error *err)
{
    struct vt *t = calloc(1, sizeof *t);
    if (!t) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    t->gpu = g;
    t->o = *o;
    t->img = res->img;
    t->frame = 1;
    const struct gv_remote_image *im = &res->img;
    if (gv_geometry_init(&t->geo, im->width, im->height, im->channels,
                         im->root_side) < 0 ||
        t->geo.root != im->levels_tiled ||
        t->geo.level[t->geo.root].width != im->root_w ||
        t->geo.level[t->geo.root].height != im->root_h) {
        gv_fail(err, GV_ECORRUPT, "view: the server's metadata for '%s' is "
                "inconsistent", im->id);
        goto fail;
    }
    t->geo.root_mips = im->root_mips;
    t->top = t->geo.root + im->root_mips - 1;
    t->gl.codes = im->kind != GV_KIND_IMAGE;
    t->layers = t->gl.codes ? im->channels : 1;
    t->slot_bytes = t->gl.codes ? (size_t)GV_TILE * GV_TILE * 2 * (size_t)im->channels
                                : TILE_TEX_BYTES;
    if (gl_setup(t, res, err) < 0)
        goto fail;
    /* The root tile of a store of codes: host-order codes. */
    if (t->gl.codes) {
        uint8_t *b = res->mip[0];
        uint16_t *c = (uint16_t *)(void *)b;
        for (size_t i = 0; i < (size_t)res->mip_w[0] * res->mip_h[0] * im->channels; i++)
            c[i] = (uint16_t)(b[2 * i] | b[2 * i + 1] << 8);
    }
    if (o->decode_gpu) {
        /* The atlas must be complete before the decode context writes to
         * it: every job waits for a fence made after this. */
        glFlush();
        t->dt = vdt_new(o->decode_gpu, &t->geo, t->gl.codes, res->mip[0],
                        res->mip_w[0], res->mip_h[0], o->decode_bytes, t->gl.atlas,
                        err);
        if (!t->dt)
            goto fail;
        t->st.threaded = 1;
        vf_result_free(res);
        return t;
    }
    struct gv_gpu_tiles tiles;
    if (t->gl.codes) {
        if (!(t->hdec = gv_gpu_height_new(g, &(struct gv_gpu_height_opts){
                                              .channels = im->channels}, err)))
            goto fail;
        tiles = gv_gpu_tiles_codes(t->hdec, im->channels);
    } else {
        if (!(t->dec = gv_gpu_decoder_new(g, &(struct gv_gpu_decoder_opts){
                                              .channels = im->channels}, err)))
            goto fail;
        tiles = gv_gpu_tiles_image(t->dec, im->channels);
    }
    t->cache = gv_gpu_cache_new(&tiles, &t->geo, res->mip[0], res->mip_w[0],
                                res->mip_h[0], o->decode_bytes, from_memory, t, err);
    if (!t->cache)
        goto fail;
    vf_result_free(res);
    return t;
fail:
    vt_free(t);
    return NULL;
}

void vt_free(struct vt *t)
{
    if (!t)
        return;
    vdt_free(t->dt);          /* joined: nothing writes the atlas any more */
    for (size_t i = 0; i < t->npend; i++)
        glDeleteSync((GLsync)t->pend[i].fence);
    free(t->pend);
    gv_gpu_cache_free(t->cache);
    gv_gpu_decoder_free(t->dec);
    gv_gpu_height_free(t->hdec);
    if (t->gl.atlas)
        glDeleteTextures(1, &t->gl.atlas);
    if (t->gl.page_table)
        glDeleteTextures(1, &t->gl.page_table);
    for (size_t i = 0; i < t->cap; i++)
        if (t->tab[i]) {
            free(t->tab[i]->buf);
            free(t->tab[i]);
        }
    free(t->tab);
    free(t->slots);
    free(t->need);
    free(t->want);
    free(t);
}

const struct gv_geometry *vt_geometry(const struct vt *t) { return &t->geo; }
const char *vt_image(const struct vt *t) { return t->img.id; }
int vt_top(const struct vt *t) { return t->top; }
const struct vt_gl *vt_gl(const struct vt *t) { return &t->gl; }

void vt_plan_view(const struct vt *t, const struct vg_view *v, int w, int h,
                  struct vt_plan *p)
{
    p->f = (int)floor(v->zoom);
    p->t = v->zoom - p->f;
    if (p->f < 0) {
        p->f = 0;
        p->t = 0;
    }
    if (p->f >= t->top) {
        p->f = t->top;
        p->t = 0;
    }
    p->scale = exp2(v->zoom);
    const double th = v->rot * M_PI / 180.0;
    p->cs = cos(th);
    p->sn = -sin(th);
    double ax = 1e300, ay = 1e300, bx = -1e300, by = -1e300;
    for (int i = 0; i < 4; i++) {
        double dx = ((i & 1) ? 0.5 : -0.5) * w, dy = ((i & 2) ? 0.5 : -0.5) * h;
        double px = v->cx + p->scale * (dx * p->cs - dy * p->sn);
        double py = v->cy + p->scale * (dx * p->sn + dy * p->cs);
        ax = fmin(ax, px), bx = fmax(bx, px), ay = fmin(ay, py), by = fmax(by, py);
    }
    const struct gv_geometry *g = &t->geo;
    p->visible = !(bx <= 0 || by <= 0 || ax >= g->width || ay >= g->height);
    p->box[0] = fmax(ax, 0), p->box[1] = fmax(ay, 0);
    p->box[2] = fmin(bx, g->width), p->box[3] = fmin(by, g->height);
}

void vt_take(struct vt *t, struct vf_result *r, double now)
{
    struct entry *e = r->key.level >= 0 && r->key.level < t->geo.root
                          ? lookup(t, r->key.level, r->key.tx, r->key.ty, 1)
                          : NULL;
    if (!e) {
        vf_result_free(r);
        return;
    }
    if (r->ok && e->state != E_HAVE) {
        e->buf = r->buf;
        e->len = r->len;
        r->buf = NULL;
        e->state = E_HAVE;
        e->fails = 0;
        t->buf_bytes += e->len;
        t->st.fetched++;
    } else if (!r->ok) {
        e->state = E_FAILED;
        double delay = 0.05 * exp2(e->fails < 6 ? e->fails : 6);
        e->retry_at = now + (delay > 2 ? 2 : delay);
        e->fails++;
        t->st.failures++;
        if (t->o.verbose)
            fprintf(stderr, "view: tile %d/%u/%u: %s\n", e->level, e->tx, e->ty,
                    r->msg);
    }
    vf_result_free(r);
}

/* Tile range of level k covering level-0 box b (cmd_render.c's level_box
 * and tile_span): r = {t0x, t0y, t1x, t1y}. */
static void tile_range(const struct vt *t, int k, const double *b, uint32_t *r)
{
    const struct gv_level *l = &t->geo.level[k];
    const double s = exp2(k);
    double v[4] = {floor(b[0] / s - 0.5) - 1, floor(b[1] / s - 0.5) - 1,
                   ceil(b[2] / s - 0.5) + 1, ceil(b[3] / s - 0.5) + 1};
    double lim[4] = {l->width - 1.0, l->height - 1.0, l->width - 1.0, l->height - 1.0};
    for (int i = 0; i < 4; i++) {
        double x = v[i] < 0 ? 0 : v[i] > lim[i] ? lim[i] : v[i];
        r[i] = (uint32_t)x / GV_STEP;
    }
    if (r[2] >= l->tiles_x) r[2] = l->tiles_x - 1;
    if (r[3] >= l->tiles_y) r[3] = l->tiles_y - 1;
    if (r[0] > r[2]) r[0] = r[2];
    if (r[1] > r[3]) r[1] = r[3];
}

static double seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec / 1e9;
}

/* Whether the frame's decode budget is spent: the count, or the time
 * since `since` once one decode ran. */
static int spent(struct vt *t, uint64_t d0, double since)
{
    if (t->dt)                /* jobs in flight, and the frame's decode work */
        return t->dt_broken || t->st.inflight >= t->o.budget ||
               (t->posted > 0 && (seconds() - t->frame_t0) * 1000 >= t->o.budget_ms);
    struct gv_gpu_cache_stats cs;
    gv_gpu_cache_stats(t->cache, &cs);
    return cs.decodes - d0 >= (uint64_t)t->o.budget ||
           (cs.decodes > d0 && (seconds() - since) * 1000 >= t->o.budget_ms);
}

static int push_need(struct vt *t, struct entry *e)
{
    if (t->nneed == t->capneed) {
        size_t cap = t->capneed ? 2 * t->capneed : 256;
        struct entry **n = realloc(t->need, cap * sizeof *n);
        if (!n)
            return -1;
        t->need = n;
        t->capneed = cap;
    }
    t->need[t->nneed++] = e;
    return 0;
}

/* Put e on the wanted list (once a frame) when it needs a fetch. */
static void want(struct vt *t, struct entry *e, double now)
{
    if (e->listed == t->frame || e->state == E_HAVE ||
        (e->state == E_FAILED && now < e->retry_at))
        return;
    e->listed = t->frame;
    if (t->nwant == t->capwant) {
        size_t cap = t->capwant ? 2 * t->capwant : 256;
        struct vf_key *n = realloc(t->want, cap * sizeof *n);
        if (!n)
            return;
        t->want = n;
        t->capwant = cap;
    }
    t->want[t->nwant++] = (struct vf_key){e->level, e->tx, e->ty};
}

/* Whether e and all its tiled ancestors have their buffers; the missing
 * ones go on the wanted list, coarsest first.  Marks them used. */
static int chain_ready(struct vt *t, struct entry *e, double now)
{
    struct entry *chain[VT_MAX_LEVELS];
    int n = 0, ready = 1;
    for (int k = e->level; k < t->geo.root; k++) {
        uint32_t sh = (uint32_t)(k - e->level);
        struct entry *a = k == e->level ? e : lookup(t, k, e->tx >> sh, e->ty >> sh, 1);
        if (!a)
            return 0;
        a->used = t->frame;
        chain[n++] = a;
    }
    for (int i = n - 1; i >= 0; i--) {
        if (chain[i]->state != E_HAVE)
            ready = 0;
        want(t, chain[i], now);
    }
    return ready;
}

/* A layer for a new tile: a free one, else the least recently drawn one
 * that was last drawn before `before`.  -1: none. */
static int take_slot(struct vt *t, uint64_t before)
{
    int best = -1;
    for (int i = 0; i < t->nslots; i++) {
        struct slot *s = &t->slots[i];
        if (s->pinned || s->busy)
            continue;
        if (!s->e)
            return i;
        if (s->used < before && (best < 0 || s->used < t->slots[best].used))
            best = i;
    }
    if (best >= 0) {
        struct entry *old = t->slots[best].e;
        pt_set(t, old->level, old->tx, old->ty, 0);
        old->slot = -1;
        t->slots[best].e = NULL;
        t->st.evictions++;
    }
    return best;
}

/* A decode of e failed: say so, drop its buffer (it is fetched again
 * after a second). */
static void decode_failed(struct vt *t, struct entry *e, const char *msg, double now)
{
    fprintf(stderr, "view: tile %d/%u/%u: %s\n", e->level, e->tx, e->ty, msg);
    snprintf(t->st.error, sizeof t->st.error, "tile %d/%u/%u: %.160s", e->level,
             e->tx, e->ty, msg);
    t->st.errors++;
    free(e->buf);
    t->buf_bytes -= e->len;
    e->buf = NULL;
    e->len = 0;
    e->state = E_FAILED;
    e->retry_at = now + 1;
    e->fails++;
}

/* Post e's decode job for a layer taken with take_slot(before): copies of
 * the buffers of e and its tiled ancestors (chain_ready said they are all
 * here), and a fence after the page table stopped naming the layer's old
 * tile.  Returns 0 (e is pending), or -1 (no layer free, no memory). */
static int post_job(struct vt *t, struct entry *e, uint64_t before)
{
    struct vdt_job j = {.level = e->level, .tx = e->tx, .ty = e->ty};
    for (int k = e->level; k < t->geo.root; k++) {
        uint32_t sh = (uint32_t)(k - e->level);
        struct entry *a = k == e->level ? e : lookup(t, k, e->tx >> sh, e->ty >> sh, 0);
        if (!a || a->state != E_HAVE)
            goto fail;
        struct vdt_buf *b = &j.chain[j.nchain];
        *b = (struct vdt_buf){.level = k, .tx = a->tx, .ty = a->ty, .len = a->len};
        if (!(b->buf = malloc(a->len ? a->len : 1)))
            goto fail;
        memcpy(b->buf, a->buf, a->len);
        j.nchain++;
    }
    int s = take_slot(t, before);
    if (s < 0)
        goto fail;
    j.slot = s;
    j.fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    glFlush();                /* else the decode context may wait forever */
    t->slots[s].e = e;
    t->slots[s].busy = 1;
    t->slots[s].used = t->frame;
    e->slot = s;
    e->pending = 1;
    t->st.inflight++;
    t->posted++;
    if (vdt_post(t->dt, &j) < 0) {
        t->slots[s].e = NULL;
        t->slots[s].busy = 0;
        e->slot = -1;
        e->pending = 0;
        t->st.inflight--;
        return -1;
    }
    return 0;
fail:
    for (int i = 0; i < j.nchain; i++)
        free(j.chain[i].buf);
    return -1;
}

/* Publish a finished job whose fence signalled: the page table names its
 * layer from now on.  The atlas is bound again, so that this context sees
 * what the decode context wrote (OpenGL ES 3.2 section 5.3.3, "Rules"; the
 * display pass binds it for every draw as well). */
static void publish(struct vt *t, const struct vdt_done *r)
{
    glDeleteSync((GLsync)r->fence);
    struct entry *e = lookup(t, r->level, r->tx, r->ty, 0);
    struct slot *sl = &t->slots[r->slot];
    sl->busy = 0;
    t->st.inflight--;
    if (r->decodes > t->st.decodes)
        t->st.decodes = r->decodes;
    if (!e || sl->e != e || !e->pending)
        return;               /* cannot happen: the layer was reserved */
    e->pending = 0;
    glBindTexture(GL_TEXTURE_2D_ARRAY, t->gl.atlas);
    pt_set(t, e->level, e->tx, e->ty, (unsigned)r->slot + 1);
    t->st.published++;
}

/* Whether r's fence has signalled, without waiting. */
static int signalled(const struct vdt_done *r)
{
    GLenum w = glClientWaitSync((GLsync)r->fence, 0, 0);
    return w == GL_ALREADY_SIGNALED || w == GL_CONDITION_SATISFIED ||
           w == GL_WAIT_FAILED;     /* a lost fence: never wait for it */
}

/* Take the decode thread's results: publish those whose fence signalled,
 * keep the others for the next frame, free the layers of failed ones. */
static void take_results(struct vt *t, double now)
{
    size_t k = 0;
    for (size_t i = 0; i < t->npend; i++) {
        if (signalled(&t->pend[i]))
            publish(t, &t->pend[i]);
        else
            t->pend[k++] = t->pend[i];
    }
    t->npend = k;
    struct vdt_done r;
    while (vdt_poll(t->dt, &r)) {
        if (r.slot < 0) {         /* the thread has no decoder */
            snprintf(t->st.error, sizeof t->st.error, "%.190s", r.msg);
            t->st.errors++;
            t->dt_broken = 1;
            fprintf(stderr, "view: the decode thread failed: %s\n", r.msg);
            continue;
        }
        if (!r.ok) {
            struct entry *e = lookup(t, r.level, r.tx, r.ty, 0);
            t->slots[r.slot].busy = 0;
            t->slots[r.slot].e = NULL;
            t->st.inflight--;
            if (e) {
                e->slot = -1;
                e->pending = 0;
                decode_failed(t, e, r.msg, now);
            }
            continue;
        }
        if (signalled(&r)) {
            publish(t, &r);
            continue;
        }
        if (t->npend == t->cappend) {
            size_t cap = t->cappend ? 2 * t->cappend : 16;
            struct vdt_done *n = realloc(t->pend, cap * sizeof *n);
            if (!n) {             /* keep the order of GL: wait here, rarely */
                glWaitSync((GLsync)r.fence, 0, GL_TIMEOUT_IGNORED);
                publish(t, &r);
                continue;
            }
            t->pend = n;
            t->cappend = cap;
        }
        t->pend[t->npend++] = r;
    }
}

/* Decode e into a layer taken with take_slot(before), in the frame or on
 * the decode thread.  Returns 0 (resident, or pending on the thread), or
 * -1 (no layer free, or the decode failed: then e is fetched again later). */
static int make_resident(struct vt *t, struct entry *e, uint64_t before, double now)
{
    if (t->dt)
        return post_job(t, e, before);
    struct gv_error err = {0};
    uint32_t h;
    int s = take_slot(t, before);
    if (s < 0)
        return -1;
    if (gv_gpu_cache_get(t->cache, e->level, e->tx, e->ty, &h, &err) < 0) {
        decode_failed(t, e, err.text, now);
        return -1;
    }
    if (t->gl.codes)
        glCopyImageSubData(h, GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, t->gl.atlas,
                           GL_TEXTURE_2D_ARRAY, 0, 0, 0, s * t->layers, GV_TILE, GV_TILE,
                           t->layers);
    else
        glCopyImageSubData(h, GL_TEXTURE_2D, 0, 0, 0, 0, t->gl.atlas, GL_TEXTURE_2D_ARRAY,
                           0, 0, 0, s, GV_TILE, GV_TILE, 1);
    t->slots[s].e = e;
    t->slots[s].used = t->frame;
    e->slot = s;
    pt_set(t, e->level, e->tx, e->ty, (unsigned)s + 1);
    t->st.published++;
    return 0;
}

/* Free the buffers least recently used, down to 3/4 of the limit, when
 * over it; never those this frame uses. */
static int cmp_used(const void *a, const void *b)
{
    const struct entry *x = *(struct entry *const *)a, *y = *(struct entry *const *)b;
    return x->used < y->used ? -1 : x->used > y->used;
}

static void trim_buffers(struct vt *t)
{
    if (t->buf_bytes <= t->o.buffer_bytes)
        return;
    struct entry **v = malloc(t->count * sizeof *v);
    if (!v)
        return;
    size_t n = 0;
    for (size_t i = 0; i < t->cap; i++)
        if (t->tab[i] && t->tab[i]->buf && t->tab[i]->used < t->frame)
            v[n++] = t->tab[i];
    qsort(v, n, sizeof *v, cmp_used);
    for (size_t i = 0; i < n && t->buf_bytes > t->o.buffer_bytes / 4 * 3; i++) {
        t->buf_bytes -= v[i]->len;
        free(v[i]->buf);
        v[i]->buf = NULL;
        v[i]->state = E_NONE;
    }
    free(v);
}

/* Add the tiles of level k in level-0 box b, nearest (cx, cy) first. */
static void list_level(struct vt *t, int k, const double *b, double cx, double cy)
{
    uint32_t r[4];
    tile_range(t, k, b, r);
    size_t first = t->nneed;
    for (uint32_t ty = r[1]; ty <= r[3]; ty++)
        for (uint32_t tx = r[0]; tx <= r[2]; tx++) {
            struct entry *e = lookup(t, k, tx, ty, 1);
            if (e && push_need(t, e) < 0)
                return;
        }
    /* Insertion sort by distance to the centre: lists are short. */
    const double s = exp2(k) * GV_STEP;
    for (size_t i = first + 1; i < t->nneed; i++) {
        struct entry *e = t->need[i];
        double d = hypot((e->tx + 0.5) * s - cx, (e->ty + 0.5) * s - cy);
        size_t j = i;
        while (j > first) {
            struct entry *p = t->need[j - 1];
            if (hypot((p->tx + 0.5) * s - cx, (p->ty + 0.5) * s - cy) <= d)
                break;
            t->need[j] = p;
            j--;
        }
        t->need[j] = e;
    }
}

void vt_frame(struct vt *t, const struct vt_plan *p, double vx, double vy,
              struct vf *f, double now, struct vt_stats *st)
{
    t->frame++;
    t->nneed = t->nwant = 0;
    const double cx = (p->box[0] + p->box[2]) / 2, cy = (p->box[1] + p->box[3]) / 2;
    if (p->visible) {
        if (p->t > 0 && p->f + 1 < t->geo.root)
            list_level(t, p->f + 1, p->box, cx, cy);
        if (p->f < t->geo.root)
            list_level(t, p->f, p->box, cx, cy);
    }
    const double since = seconds();
    t->frame_t0 = since;
    t->posted = 0;
    uint64_t d0 = 0;
    double work = 0;          /* seconds of decode work in this frame */
    if (t->dt) {
        take_results(t, now);
        work += seconds() - since;
    } else {
        struct gv_gpu_cache_stats cs;
        gv_gpu_cache_stats(t->cache, &cs);
        d0 = cs.decodes;
    }
    size_t missing = 0;
    const size_t nview = t->nneed;
    /* Touch the resident tiles first, so that no layer this frame draws
     * is taken for another. */
    for (size_t i = 0; i < nview; i++) {
        struct entry *e = t->need[i];
        e->used = t->frame;
        if (e->slot >= 0)
            t->slots[e->slot].used = t->frame;
    }
    for (size_t i = 0; i < nview; i++) {
        struct entry *e = t->need[i];
        if (e->slot >= 0 && !e->pending)
            continue;
        missing++;
        if (e->pending)           /* on the decode thread */
            continue;
        if (!chain_ready(t, e, now) || spent(t, d0, since))
            continue;
        double w0 = seconds();
        if (make_resident(t, e, t->frame, now) == 0 && !e->pending)
            missing--;
        work += seconds() - w0;
    }
    /* Prefetch ahead of the motion once the view is complete. */
    if (p->visible && !missing && t->o.prefetch && p->f < t->geo.root) {
        double w = p->box[2] - p->box[0], h = p->box[3] - p->box[1];
        double b[4], sp = hypot(vx, vy);
        if (sp > 0) {
            double ux = vx / sp * w / 2, uy = vy / sp * h / 2;
            b[0] = p->box[0] + ux, b[2] = p->box[2] + ux;
            b[1] = p->box[1] + uy, b[3] = p->box[3] + uy;
        } else {
            b[0] = p->box[0] - w / 4, b[2] = p->box[2] + w / 4;
            b[1] = p->box[1] - h / 4, b[3] = p->box[3] + h / 4;
        }
        const struct gv_geometry *g = &t->geo;
        b[0] = fmax(b[0], 0), b[1] = fmax(b[1], 0);
        b[2] = fmin(b[2], g->width), b[3] = fmin(b[3], g->height);
        if (b[0] < b[2] && b[1] < b[3]) {
            size_t first = t->nneed;
            list_level(t, p->f, b, cx + vx * 8, cy + vy * 8);
            for (size_t i = first; i < t->nneed; i++) {
                struct entry *e = t->need[i];
                if (e->slot >= 0 || e->used == t->frame)
                    continue;
                if (!chain_ready(t, e, now) || spent(t, d0, since))
                    continue;
                uint64_t before = t->frame > 60 ? t->frame - 60 : 0;
                double w0 = seconds();
                if (make_resident(t, e, before, now) == 0) {
                    t->slots[e->slot].used = t->frame - 1;
                    t->st.prefetched++;
                }
                work += seconds() - w0;
            }
        }
    }
    vf_want(f, t->want, t->nwant);
    trim_buffers(t);
    if (!t->dt) {
        struct gv_gpu_cache_stats cs;
        gv_gpu_cache_stats(t->cache, &cs);
        t->st.decodes = cs.decodes;
    }
    t->st.needed = nview;
    t->st.missing = missing;
    t->st.wanted = t->nwant;
    t->st.decode_ms = work * 1000;
    *st = t->st;
}
