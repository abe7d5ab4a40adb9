/*
 * view_fetch.c - the fetch thread of `gigaview view` (view_fetch.h).
 *
 * One mutex guards the request side (the image asked for, the wanted
 * list) and the result queue.  The thread takes a batch from the front
 * of the wanted list, marks it in flight, fetches it with gv_http_tiles
 * outside the lock, and queues one result per tile.  A key in flight or
 * queued is filtered out of every new wanted list, so a tile is never
 * asked for twice at once.  Each image open bumps a generation; results
 * of an older generation are freed instead of queued.  vf_free does not
 * wait for the round trip in progress: gv_http_abort drops it.
 *
 * An image's root mips come from one request, the root level as the
 * store's lossless WebP (docs/API.md), decoded and box-filtered here as
 * the store reader does (docs/FORMAT.md section 6); a server without that
 * form answers 400, and the raw mips are fetched one by one instead.
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "remote/http_fetch.h"
#include "remote/tile_cache_disk.h"
#include "store/store_format.h"
#include "view_fetch.h"

struct rnode {
    struct vf_result r;
    struct rnode *next;
};

struct vf {
    struct vf_options o;
    char *url, *cache_dir;
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    int stop;
    /* requests */
    char open_id[129];
    int open_pending;
    unsigned gen;                /* bumped by every vf_open */
    struct vf_key *want;
    size_t nwant, capwant;
    /* in flight (the thread's batch) */
    struct vf_key flight[VF_BATCH];
    size_t nflight;
    /* results */
    struct rnode *head, *tail;
    /* the thread's own */
    struct gv_http *http;
    struct gv_remote_image img;
    int have_img;
    struct gv_disk_cache *dc;
    struct gv_http_stats stats;
};

static int same_key(const struct vf_key *a, const struct vf_key *b)
{
    return a->level == b->level && a->tx == b->tx && a->ty == b->ty;
}

/* Whether key k is in flight or queued (lock held). */
static int busy(const struct vf *f, const struct vf_key *k)
{
    for (size_t i = 0; i < f->nflight; i++)
        if (same_key(&f->flight[i], k))
            return 1;
    for (const struct rnode *n = f->head; n; n = n->next)
        if (n->r.kind == VF_TILE && same_key(&n->r.key, k))
            return 1;
    return 0;
}

/* Queue result r (moved) if it belongs to generation gen (lock held). */
static void push(struct vf *f, unsigned gen, struct vf_result *r)
{
    struct rnode *n = gen == f->gen ? malloc(sizeof *n) : NULL;
    if (!n) {
        vf_result_free(r);
        return;
    }
    n->r = *r;
    n->next = NULL;
    if (f->tail)
        f->tail->next = n;
    else
        f->head = n;
    f->tail = n;
}

void vf_result_free(struct vf_result *r)
{
    free(r->buf);
    r->buf = NULL;
    for (int i = 0; i < GV_MAX_LEVELS; i++) {
        free(r->mip[i]);
        r->mip[i] = NULL;
    }
}

/* The root mips of r->img from the root level as the store keeps it (a
 * lossless WebP; a gray root has three equal channels, channel 0 is kept),
 * with the format's 2x2 box filter (gv_root_build_mips): the samples of
 * the server's raw mips, bit for bit, in one request instead of one per
 * mip and in under half their bytes (bench/README.md, browser-bytes). */
static int mips_from_webp(struct vf_result *r, const uint8_t *webp, size_t len,
                          struct gv_error *err)
{
    const struct gv_remote_image *im = &r->img;
    const int c = im->channels;
    int count = 1;
    for (uint32_t w = im->root_w, h = im->root_h; w > 1 || h > 1; count++) {
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
    if (im->root_mips > count)
        return gv_fail(err, GV_ECORRUPT, "image '%s': %d root mips for a %ux%u "
                       "root", im->id, im->root_mips, im->root_w, im->root_h);
    uint8_t *all = malloc(gv_root_pixels_size(im->root_w, im->root_h, c));
    if (!all)
        return gv_fail(err, GV_ENOMEM, "view: out of memory for the root");
    struct gv_error e = {0};
    if (gv_root_unpack(webp, len, im->root_w, im->root_h, c, all, &e) < 0) {
        free(all);
        return gv_fail(err, e.code, "root (WebP) from the server: %s", e.text);
    }
    gv_root_build_mips(all, im->root_w, im->root_h, c);
    size_t off = 0;
    for (int m = 0; m < im->root_mips; m++) {
        gv_remote_mip_size(im, m, &r->mip_w[m], &r->mip_h[m]);
        size_t n = (size_t)r->mip_w[m] * r->mip_h[m] * c;
        if (!(r->mip[m] = malloc(n))) {
            free(all);
            return gv_fail(err, GV_ENOMEM, "view: out of memory for the root");
        }
        memcpy(r->mip[m], all + off, n);
        off += n;
    }
    free(all);
    return 0;
}

/* Open image id on the thread: metadata, disk cache, root mips (from the
 * root's WebP, or as raw samples from a server without that form). */
static void do_open(struct vf *f, const char *id, unsigned gen)
{
    struct vf_result r;
    struct gv_error err = {0};
    memset(&r, 0, sizeof r);
    r.kind = VF_IMAGE;
    f->have_img = 0;
    gv_disk_cache_free(f->dc);
    f->dc = NULL;
    if (gv_http_image(f->http, id, &r.img, &err) < 0)
        goto fail;
    if (r.img.levels_tiled + r.img.root_mips > GV_MAX_LEVELS) {
        gv_fail(&err, GV_ECORRUPT, "image '%s': too many levels", id);
        goto fail;
    }
    if (!f->o.no_cache)
        f->dc = gv_disk_cache_open(f->cache_dir, gv_http_base(f->http), id);
    uint8_t *webp = NULL;
    size_t wlen = 0;
    int rc = gv_http_root_webp(f->http, &r.img, f->dc, &webp, &wlen, &err);
    if (rc == 0) {
        rc = mips_from_webp(&r, webp, wlen, &err);
        free(webp);
    } else if (rc > 0) {
        for (int m = 0; m < r.img.root_mips && rc >= 0; m++)
            rc = gv_http_root(f->http, &r.img, m, f->dc, &r.mip[m], &r.mip_w[m],
                              &r.mip_h[m], &err);
    }
    if (rc < 0)
        goto fail;
    f->img = r.img;
    f->have_img = 1;
    r.ok = 1;
    pthread_mutex_lock(&f->lock);
    push(f, gen, &r);
    pthread_mutex_unlock(&f->lock);
    return;
fail:
    snprintf(r.msg, sizeof r.msg, "%s", err.text);
    vf_result_free(&r);
    pthread_mutex_lock(&f->lock);
    push(f, gen, &r);
    pthread_mutex_unlock(&f->lock);
}

/* Fetch the batch in f->flight (n tiles) and queue the results. */
static void do_tiles(struct vf *f, size_t n, unsigned gen)
{
    struct gv_tile_want t[VF_BATCH];
    struct gv_error err = {0};
    for (size_t i = 0; i < n; i++)
        t[i] = (struct gv_tile_want){.level = f->flight[i].level,
                                     .tx = f->flight[i].tx, .ty = f->flight[i].ty};
    int rc = gv_http_tiles(f->http, &f->img, t, n, f->dc, &err);
    pthread_mutex_lock(&f->lock);
    for (size_t i = 0; i < n; i++) {
        struct vf_result r;
        memset(&r, 0, sizeof r);
        r.kind = VF_TILE;
        r.key = f->flight[i];
        if (t[i].buf) {
            r.ok = 1;
            r.buf = t[i].buf;
            r.len = t[i].len;
        } else {
            snprintf(r.msg, sizeof r.msg, "%s", rc < 0 ? err.text : "no data");
        }
        push(f, gen, &r);
    }
    f->nflight = 0;
    gv_http_stats(f->http, &f->stats);
    pthread_mutex_unlock(&f->lock);
}

static void *fetch_thread(void *arg)
{
    struct vf *f = arg;
    pthread_mutex_lock(&f->lock);
    while (!f->stop) {
        if (f->open_pending) {
            char id[sizeof f->open_id];
            memcpy(id, f->open_id, sizeof id);
            unsigned gen = f->gen;
            f->open_pending = 0;
            pthread_mutex_unlock(&f->lock);
            do_open(f, id, gen);
            pthread_mutex_lock(&f->lock);
            continue;
        }
        if (f->have_img && f->nwant) {
            size_t n = f->nwant < VF_BATCH ? f->nwant : VF_BATCH;
            memcpy(f->flight, f->want, n * sizeof *f->want);
            memmove(f->want, f->want + n, (f->nwant - n) * sizeof *f->want);
            f->nwant -= n;
            f->nflight = n;
            unsigned gen = f->gen;
            pthread_mutex_unlock(&f->lock);
            do_tiles(f, n, gen);
            pthread_mutex_lock(&f->lock);
            continue;
        }
        pthread_cond_wait(&f->wake, &f->lock);
    }
    pthread_mutex_unlock(&f->lock);
    return NULL;
}

struct vf *vf_new(const struct vf_options *o, struct gv_error *err)
{
    struct vf *f = calloc(1, sizeof *f);
    if (!f) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    f->o = *o;
    if (!(f->http = gv_http_new(o->url, o->timeout_ms, o->verbose, err))) {
        free(f);
        return NULL;
    }
    gv_http_use_batches(f->http, !o->no_batch);
    f->cache_dir = o->cache_dir ? strdup(o->cache_dir) : NULL;
    pthread_mutex_init(&f->lock, NULL);
    pthread_cond_init(&f->wake, NULL);
    if (pthread_create(&f->thread, NULL, fetch_thread, f) != 0) {
        gv_fail(err, GV_ENOMEM, "view: cannot start the fetch thread");
        pthread_mutex_destroy(&f->lock);
        pthread_cond_destroy(&f->wake);
        gv_http_free(f->http);
        free(f->cache_dir);
        free(f);
        return NULL;
    }
    return f;
}

void vf_free(struct vf *f)
{
    if (!f)
        return;
    pthread_mutex_lock(&f->lock);
    f->stop = 1;
    pthread_cond_broadcast(&f->wake);
    pthread_mutex_unlock(&f->lock);
    gv_http_abort(f->http);      /* a hanging request ends now */
    pthread_join(f->thread, NULL);
    while (f->head) {
        struct rnode *n = f->head;
        f->head = n->next;
        vf_result_free(&n->r);
        free(n);
    }
    pthread_mutex_destroy(&f->lock);
    pthread_cond_destroy(&f->wake);
    gv_disk_cache_free(f->dc);
    gv_http_free(f->http);
    free(f->want);
    free(f->cache_dir);
    free(f);
}

void vf_open(struct vf *f, const char *id)
{
    pthread_mutex_lock(&f->lock);
    snprintf(f->open_id, sizeof f->open_id, "%s", id);
    f->open_pending = 1;
    f->gen++;
    f->nwant = 0;
    /* Drop queued results of the old image. */
    while (f->head) {
        struct rnode *n = f->head;
        f->head = n->next;
        vf_result_free(&n->r);
        free(n);
    }
    f->tail = NULL;
    pthread_cond_broadcast(&f->wake);
    pthread_mutex_unlock(&f->lock);
}

void vf_want(struct vf *f, const struct vf_key *keys, size_t n)
{
    pthread_mutex_lock(&f->lock);
    if (n > f->capwant) {
        struct vf_key *w = realloc(f->want, n * sizeof *w);
        if (!w) {
            pthread_mutex_unlock(&f->lock);
            return;             /* asked again next frame */
        }
        f->want = w;
        f->capwant = n;
    }
    f->nwant = 0;
    for (size_t i = 0; i < n; i++)
        if (!busy(f, &keys[i]))
            f->want[f->nwant++] = keys[i];
    if (f->nwant)
        pthread_cond_broadcast(&f->wake);
    pthread_mutex_unlock(&f->lock);
}

int vf_poll(struct vf *f, struct vf_result *r)
{
    pthread_mutex_lock(&f->lock);
    struct rnode *n = f->head;
    if (n) {
        f->head = n->next;
        if (!f->head)
            f->tail = NULL;
    }
    pthread_mutex_unlock(&f->lock);
    if (!n)
        return 0;
    *r = n->r;
    free(n);
    return 1;
}

size_t vf_in_flight(struct vf *f)
{
    pthread_mutex_lock(&f->lock);
    size_t n = f->nflight;
    pthread_mutex_unlock(&f->lock);
    return n;
}

void vf_stats(struct vf *f, struct gv_http_stats *st)
{
    pthread_mutex_lock(&f->lock);
    *st = f->stats;
    pthread_mutex_unlock(&f->lock);
}
