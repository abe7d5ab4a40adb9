/*
 * view_decode.c - the decode thread of `gigaview view` (view_decode.h).
 *
 * Jobs and results are singly linked lists under one mutex; the thread
 * sleeps on a condition variable while there is no job.  All GL work runs
 * on the shared context's own GL thread (lib/gpu, through gv_gpu_call,
 * which this thread may block on: the render thread never calls it): the
 * decodes (gpu_cache.c pulls missing parents from the job's buffers), then
 * one call that waits on the GPU for the render context's fence, copies
 * the decoded tile into the reserved atlas layer, makes the fence of the
 * result and flushes, so that the fence can signal without this context
 * doing anything more (OpenGL ES 3.2 section 4.1.2: a fence in a context
 * that is never flushed may never signal).
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl32.h>

#include "gpu/gpu_cache.h"
#include "gpu/gpu_decode.h"
#include "view_decode.h"

struct node {
    struct node *next;
    struct vdt_job job;
    struct vdt_done done;
};

struct vdt {
    struct gv_gpu *gpu;
    struct gv_geometry geo;
    uint8_t *root;
    uint32_t root_w, root_h;
    size_t decode_bytes;
    unsigned atlas;
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    int stop;
    struct node *jobs, **jobs_tail;  /* FIFO */
    struct node *done, **done_tail;  /* FIFO */
    /* the thread's own */
    struct gv_gpu_decoder *dec;
    struct gv_gpu_height *hdec;   /* stores of codes */
    int codes;                    /* 1: tiles of 16-bit codes, a layer a channel */
    struct gv_gpu_cache *cache;
    struct vdt_job *cur;
};

/* The cache's fetch callback: the current job's buffers (moved out). */
static int from_job(void *arg, int level, uint32_t tx, uint32_t ty, uint8_t **buf,
                    size_t *len, struct gv_error *err)
{
    struct vdt *d = arg;
    struct vdt_job *j = d->cur;
    for (int i = 0; j && i < j->nchain; i++) {
        struct vdt_buf *b = &j->chain[i];
        if (b->level == level && b->tx == tx && b->ty == ty && b->buf) {
            *buf = b->buf;
            *len = b->len;
            b->buf = NULL;
            return 0;
        }
    }
    return gv_fail(err, GV_EUNAVAIL, "view: tile %d/%u/%u has no buffer in the job",
                   level, tx, ty);
}

static void free_job(struct vdt_job *j)
{
    for (int i = 0; i < j->nchain; i++) {
        free(j->chain[i].buf);
        j->chain[i].buf = NULL;
    }
    j->nchain = 0;
}

struct copy_arg {
    GLsync wait;          /* in: the render context's fence (deleted) */
    GLuint from;          /* in: the decoded tile (0: none, only wait) */
    GLuint atlas;
    int slot;
    int layers;           /* 0: an image tile (RGBA8UI); else a tile of codes'
                           * channels, into layers slot * layers ... */
    GLsync fence;         /* out */
};

/* On the GL thread: wait for the render context, copy, fence, flush. */
static int copy_gl(void *arg, struct gv_error *err)
{
    struct copy_arg *c = arg;
    if (c->wait) {
        glWaitSync(c->wait, 0, GL_TIMEOUT_IGNORED);
        glDeleteSync(c->wait);
        c->wait = NULL;
    }
    if (!c->from)
        return 0;
    while (glGetError() != GL_NO_ERROR)
        ;
    if (c->layers)
        glCopyImageSubData(c->from, GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, c->atlas,
                           GL_TEXTURE_2D_ARRAY, 0, 0, 0, c->slot * c->layers, GV_TILE,
                           GV_TILE, c->layers);
    else
        glCopyImageSubData(c->from, GL_TEXTURE_2D, 0, 0, 0, 0, c->atlas,
                           GL_TEXTURE_2D_ARRAY, 0, 0, 0, c->slot, GV_TILE, GV_TILE, 1);
    c->fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    glFlush();
    GLenum e = glGetError();
    if (e != GL_NO_ERROR || !c->fence) {
        if (c->fence)
            glDeleteSync(c->fence);
        c->fence = NULL;
        return gv_fail(err, GV_EIO, "view: copying a tile into the atlas failed "
                       "(GL error 0x%x)", (unsigned)e);
    }
    return 0;
}

static int finish_gl(void *arg, struct gv_error *err)
{
    (void)arg;
    (void)err;
    glFinish();
    return 0;
}

static void post_done(struct vdt *d, struct node *n)
{
    n->next = NULL;
    pthread_mutex_lock(&d->lock);
    *d->done_tail = n;
    d->done_tail = &n->next;
    pthread_mutex_unlock(&d->lock);
}

/* Decode job n->job into its layer and fill n->done. */
static void run_job(struct vdt *d, struct node *n)
{
    struct vdt_job *j = &n->job;
    struct vdt_done *r = &n->done;
    struct gv_error err = {0};
    *r = (struct vdt_done){.level = j->level, .tx = j->tx, .ty = j->ty, .slot = j->slot};
    struct copy_arg c = {.wait = j->fence, .atlas = d->atlas, .slot = j->slot,
                         .layers = d->codes ? d->geo.channels : 0};
    j->fence = NULL;
    uint32_t h = 0;
    d->cur = j;
    int rc = d->cache ? gv_gpu_cache_get(d->cache, j->level, j->tx, j->ty, &h, &err)
                      : gv_fail(&err, GV_EUNAVAIL, "view: no decoder");
    d->cur = NULL;
    c.from = rc == 0 ? h : 0;
    struct gv_error cerr = {0};
    int crc = gv_gpu_call(d->gpu, copy_gl, &c, &cerr);
    if (rc == 0 && crc < 0)
        err = cerr, rc = -1;
    r->ok = rc == 0;
    r->fence = c.fence;
    if (!r->ok)
        snprintf(r->msg, sizeof r->msg, "%s", err.text);
    if (d->cache) {
        struct gv_gpu_cache_stats cs;
        gv_gpu_cache_stats(d->cache, &cs);
        r->decodes = cs.decodes;
    }
    free_job(j);
}

static void *decode_thread(void *arg)
{
    struct vdt *d = arg;
    struct gv_error err = {0};
    const int c = d->geo.channels;
    struct gv_gpu_tiles tiles = {0};
    if (d->codes ? !!(d->hdec = gv_gpu_height_new(d->gpu, &(struct gv_gpu_height_opts){
                                                      .channels = c}, &err))
                 : !!(d->dec = gv_gpu_decoder_new(d->gpu, &(struct gv_gpu_decoder_opts){
                                                      .channels = c}, &err)))
        tiles = d->codes ? gv_gpu_tiles_codes(d->hdec, c) : gv_gpu_tiles_image(d->dec, c);
    if (!tiles.dec ||
        !(d->cache = gv_gpu_cache_new(&tiles, &d->geo, d->root, d->root_w, d->root_h,
                                      d->decode_bytes, from_job, d, &err))) {
        struct node *n = calloc(1, sizeof *n);
        if (n) {
            n->done.slot = -1;
            snprintf(n->done.msg, sizeof n->done.msg, "%s", err.text);
            post_done(d, n);
        }
    }
    pthread_mutex_lock(&d->lock);
    for (;;) {
        while (!d->jobs && !d->stop)
            pthread_cond_wait(&d->wake, &d->lock);
        if (d->stop)
            break;
        struct node *n = d->jobs;
        d->jobs = n->next;
        if (!d->jobs)
            d->jobs_tail = &d->jobs;
        pthread_mutex_unlock(&d->lock);
        run_job(d, n);
        post_done(d, n);
        pthread_mutex_lock(&d->lock);
    }
    pthread_mutex_unlock(&d->lock);
    gv_gpu_cache_free(d->cache);
    gv_gpu_decoder_free(d->dec);
    gv_gpu_height_free(d->hdec);
    d->cache = NULL;
    d->dec = NULL;
    d->hdec = NULL;
    /* Nothing of this context's may still run on the atlas once the
     * render thread deletes it. */
    gv_gpu_call(d->gpu, finish_gl, NULL, NULL);
    return NULL;
}

struct vdt *vdt_new(struct gv_gpu *g, const struct gv_geometry *geo, int codes,
                    const void *root, uint32_t root_w, uint32_t root_h,
                    size_t decode_bytes, unsigned atlas, struct gv_error *err)
{
    struct vdt *d = calloc(1, sizeof *d);
    size_t rb = (size_t)root_w * root_h * (size_t)geo->channels * (codes ? 2 : 1);
    if (!d || !(d->root = malloc(rb ? rb : 1))) {
        free(d);
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    memcpy(d->root, root, rb);
    d->gpu = g;
    d->geo = *geo;
    d->codes = codes;
    d->root_w = root_w;
    d->root_h = root_h;
    d->decode_bytes = decode_bytes;
    d->atlas = atlas;
    d->jobs_tail = &d->jobs;
    d->done_tail = &d->done;
    pthread_mutex_init(&d->lock, NULL);
    pthread_cond_init(&d->wake, NULL);
    if (pthread_create(&d->thread, NULL, decode_thread, d) != 0) {
        gv_fail(err, GV_ENOMEM, "view: cannot start the decode thread");
        pthread_mutex_destroy(&d->lock);
        pthread_cond_destroy(&d->wake);
        free(d->root);
        free(d);
        return NULL;
    }
    return d;
}

int vdt_post(struct vdt *d, struct vdt_job *j)
{
    struct node *n = calloc(1, sizeof *n);
    if (!n) {
        if (j->fence)
            glDeleteSync(j->fence);
        j->fence = NULL;
        free_job(j);
        return -1;
    }
    n->job = *j;
    j->fence = NULL;
    j->nchain = 0;
    pthread_mutex_lock(&d->lock);
    *d->jobs_tail = n;
    d->jobs_tail = &n->next;
    pthread_cond_signal(&d->wake);
    pthread_mutex_unlock(&d->lock);
    return 0;
}

int vdt_poll(struct vdt *d, struct vdt_done *out)
{
    pthread_mutex_lock(&d->lock);
    struct node *n = d->done;
    if (n) {
        d->done = n->next;
        if (!d->done)
            d->done_tail = &d->done;
    }
    pthread_mutex_unlock(&d->lock);
    if (!n)
        return 0;
    *out = n->done;
    free(n);
    return 1;
}

void vdt_free(struct vdt *d)
{
    if (!d)
        return;
    pthread_mutex_lock(&d->lock);
    d->stop = 1;
    pthread_cond_signal(&d->wake);
    pthread_mutex_unlock(&d->lock);
    pthread_join(d->thread, NULL);
    for (struct node *n = d->jobs, *next; n; n = next) {
        next = n->next;
        if (n->job.fence)
            glDeleteSync(n->job.fence);
        free_job(&n->job);
        free(n);
    }
    for (struct node *n = d->done, *next; n; n = next) {
        next = n->next;
        if (n->done.fence)
            glDeleteSync(n->done.fence);
        free(n);
    }
    pthread_mutex_destroy(&d->lock);
    pthread_cond_destroy(&d->wake);
    free(d->root);
    free(d);
}
