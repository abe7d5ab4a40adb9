/*
 * catalog.c - the store directory and its reference-counted images (see
 * catalog.h).
 *
 * The list is a sorted array of image pointers under one mutex; a request
 * holds the mutex only to find an image and take a reference.  Opening a
 * store (which validates its header, root and index) happens outside the
 * lock, so a rescan never stalls requests.  A file is "changed" when its
 * device, inode, size or mtime differ; stores are immutable and replaced
 * by rename, so that catches every replacement.
 */
#include <dirent.h>
#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "base/ids.h"
#include "catalog.h"
#include "log.h"

struct catalog {
    char *dir;
    struct gv_tile_cache *tiles;
    int pool_max;
    uint64_t resident_left;   /* resident_bytes not pinned (under lock) */
    pthread_mutex_t lock;     /* guards items, n, every image's refs */
    pthread_mutex_t scan_lock;/* one scan at a time */
    struct image **items;
    int n;
    uint64_t next_serial;
    void (*on_close)(uint64_t, void *);
    void *on_close_arg;
};

struct catalog *catalog_new(const char *dir, struct gv_tile_cache *tiles,
                            int pool_max, uint64_t resident_bytes)
{
    struct catalog *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->dir = strdup(dir);
    if (!c->dir) {
        free(c);
        return NULL;
    }
    c->tiles = tiles;
    c->pool_max = pool_max > 0 ? pool_max : 1;
    c->resident_left = resident_bytes;
    c->next_serial = 1;
    pthread_mutex_init(&c->lock, NULL);
    pthread_mutex_init(&c->scan_lock, NULL);
    return c;
}

void catalog_on_close(struct catalog *c, void (*fn)(uint64_t, void *), void *arg)
{
    c->on_close = fn;
    c->on_close_arg = arg;
}

static void image_destroy(struct image *img)
{
    for (int i = 0; i < img->npool; i++)
        gv_decoder_free(img->pool[i]);
    free(img->pool);
    if (img->cat) {
        for (int i = 0; i < img->npins; i++)
            gv_tile_cache_release(img->cat->tiles, img->pins[i]);
        pthread_mutex_lock(&img->cat->lock);
        img->cat->resident_left += img->pinned;
        pthread_mutex_unlock(&img->cat->lock);
        gv_tile_cache_forget(img->cat->tiles, img->serial);
    }
    free(img->pins);
    if (img->cat && img->cat->on_close)
        img->cat->on_close(img->serial, img->cat->on_close_arg);
    gv_store_close(img->store);
    free(img);
}

void image_put(struct image *img)
{
    if (!img)
        return;
    struct catalog *c = img->cat;
    pthread_mutex_lock(&c->lock);
    int last = --img->refs == 0;
    pthread_mutex_unlock(&c->lock);
    if (last) {
        log_msg(LOG_DEBUG, "catalog", "closing %s (instance %llu)", img->id,
                (unsigned long long)img->serial);
        image_destroy(img);
    }
}

void catalog_free(struct catalog *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++)
        image_put(c->items[i]);
    free(c->items);
    pthread_mutex_destroy(&c->lock);
    pthread_mutex_destroy(&c->scan_lock);
    free(c->dir);
    free(c);
}

static int by_id(const void *a, const void *b)
{
    return strcmp((*(struct image *const *)a)->id, (*(struct image *const *)b)->id);
}

/* Index of id in the sorted array, or -1.  Caller holds the lock. */
static int find(struct catalog *c, const char *id)
{
    int lo = 0, hi = c->n - 1;
    while (lo <= hi) {
        int mid = (lo + hi) / 2;
        int d = strcmp(c->items[mid]->id, id);
        if (d == 0)
            return mid;
        if (d < 0)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return -1;
}

static struct image *open_image(struct catalog *c, const char *id,
                                const char *path, const struct stat *st)
{
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(path, &err);
    if (!s) {
        log_msg(LOG_WARN, "catalog", "skipping %s: %s", path, err.text);
        return NULL;
    }
    struct image *img = calloc(1, sizeof *img);
    if (!img) {
        gv_store_close(s);
        return NULL;
    }
    snprintf(img->id, sizeof img->id, "%s", id);
    img->store = s;
    img->info = gv_store_info(s);
    img->identity = gv_store_identity(s);
    img->bytes = (uint64_t)st->st_size;
    img->dev = (uint64_t)st->st_dev;
    img->ino = (uint64_t)st->st_ino;
    img->mtime_ns = (uint64_t)st->st_mtim.tv_sec * 1000000000u +
                    (uint64_t)st->st_mtim.tv_nsec;
    /* A default window that does not fit the image is left out, logged:
     * the image is served as if it had none. */
    if (img->info->header.kind != GV_KIND_HEIGHT &&
        gv_window_from_meta(gv_store_meta(s),
                            img->info->header.kind == GV_KIND_SAMPLES ? 65535 : 255,
                            img->info->geometry.channels,
                            &img->window, &err) < 0)
        log_msg(LOG_WARN, "catalog", "%s: default window ignored: %s", path,
                err.text);
    if (img->info->header.kind == GV_KIND_SAMPLES &&
        gv_colours_from_meta(gv_store_meta(s), img->info->geometry.channels,
                             &img->colours, &err) < 0)
        log_msg(LOG_WARN, "catalog", "%s: colours ignored: %s", path, err.text);
    img->refs = 1;
    img->cat = c;
    return img;
}

/* Decode img's coarsest levels and pin them, within what is left of
 * resident_bytes (img->serial must be set).  A failure is logged: the
 * image is served all the same, its tiles decoded on demand. */
static void pin_levels(struct catalog *c, struct image *img)
{
    pthread_mutex_lock(&c->lock);
    uint64_t avail = c->resident_left;
    c->resident_left = 0;
    pthread_mutex_unlock(&c->lock);
    struct gv_error err = {0};
    struct gv_decoder *d = avail ? gv_decoder_new_shared(img->store, c->tiles,
                                                         img->serial) : NULL;
    if (d && gv_decoder_pin_levels(d, avail, &img->pins, &img->npins,
                                   &img->pinned, &err) < 0)
        log_msg(LOG_WARN, "catalog", "%s: its coarse levels are not kept "
                "decoded: %s", img->id, err.text);
    gv_decoder_free(d);
    pthread_mutex_lock(&c->lock);
    c->resident_left += avail - img->pinned;
    pthread_mutex_unlock(&c->lock);
}

static int same_file(const struct image *img, const struct stat *st)
{
    return img->dev == (uint64_t)st->st_dev && img->ino == (uint64_t)st->st_ino &&
           img->bytes == (uint64_t)st->st_size &&
           img->mtime_ns == (uint64_t)st->st_mtim.tv_sec * 1000000000u +
                                (uint64_t)st->st_mtim.tv_nsec;
}

/* The image for directory entry `name` ("ID.gv"): the one served now if
 * the file is unchanged (a new reference), else the store opened anew.
 * NULL for anything else.  *added counts opened stores, *kept reused ones. */
static struct image *scan_entry(struct catalog *c, const char *name,
                                int *added, int *kept)
{
    size_t len = strlen(name);
    if (len <= 3 || strcmp(name + len - 3, ".gv"))
        return NULL;
    char id[CATALOG_ID_MAX + 1];
    if (len - 3 > CATALOG_ID_MAX)
        return NULL;
    memcpy(id, name, len - 3);
    id[len - 3] = '\0';
    if (!gv_image_id_valid(id)) {
        if (id[0] != '.') /* hidden files are encoders at work */
            log_msg(LOG_WARN, "catalog", "skipping %s: not a valid id", name);
        return NULL;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", c->dir, name);
    struct stat st;
    if (stat(path, &st) < 0 || !S_ISREG(st.st_mode))
        return NULL;
    struct image *img = NULL;
    pthread_mutex_lock(&c->lock);
    int i = find(c, id);
    if (i >= 0 && same_file(c->items[i], &st)) {
        img = c->items[i];
        img->refs++;
    }
    pthread_mutex_unlock(&c->lock);
    if (img) {
        (*kept)++;
        return img;
    }
    img = open_image(c, id, path, &st);
    if (!img)
        return NULL;
    (*added)++;
    log_msg(LOG_INFO, "catalog", "serving %s (%ux%u, %llu bytes)", id,
            img->info->geometry.width, img->info->geometry.height,
            (unsigned long long)img->bytes);
    return img;
}

/* Put the images of the old list back, logging those replaced or no
 * longer served.  Returns how many are no longer served. */
static int drop_old(struct catalog *c, struct image **old, int nold)
{
    int dropped = 0;
    for (int i = 0; i < nold; i++) {
        pthread_mutex_lock(&c->lock);
        int j = find(c, old[i]->id);
        int still = j >= 0 && c->items[j] == old[i];
        pthread_mutex_unlock(&c->lock);
        if (!still && j >= 0) {
            log_msg(LOG_INFO, "catalog", "replaced %s (instance %llu by %llu)",
                    old[i]->id, (unsigned long long)old[i]->serial,
                    (unsigned long long)c->items[j]->serial);
        } else if (!still) {
            dropped++;
            log_msg(LOG_INFO, "catalog", "no longer serving %s (instance %llu)",
                    old[i]->id, (unsigned long long)old[i]->serial);
        }
        image_put(old[i]);
    }
    free(old);
    return dropped;
}

int catalog_scan(struct catalog *c)
{
    pthread_mutex_lock(&c->scan_lock);
    DIR *d = opendir(c->dir);
    if (!d) {
        log_msg(LOG_ERROR, "catalog", "cannot read %s: %s", c->dir,
                strerror(errno));
        pthread_mutex_unlock(&c->scan_lock);
        return -1;
    }
    struct image **next = NULL;
    int n = 0, cap = 0, added = 0, kept = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        struct image *img = scan_entry(c, e->d_name, &added, &kept);
        if (!img)
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 16;
            struct image **t = realloc(next, (size_t)cap * sizeof *t);
            if (!t) {
                image_put(img);
                break;
            }
            next = t;
        }
        next[n++] = img;
    }
    closedir(d);
    if (n > 0)   /* an empty directory leaves next NULL, which qsort may not take */
        qsort(next, (size_t)n, sizeof *next, by_id);

    pthread_mutex_lock(&c->lock);
    const uint64_t first_new = c->next_serial;
    for (int i = 0; i < n; i++)
        if (next[i]->serial == 0)
            next[i]->serial = c->next_serial++;
    pthread_mutex_unlock(&c->lock);
    /* The stores opened now keep their coarse levels, before any request
     * can reach them (in id order, while the budget lasts). */
    for (int i = 0; i < n; i++)
        if (next[i]->serial >= first_new)
            pin_levels(c, next[i]);

    pthread_mutex_lock(&c->lock);
    struct image **old = c->items;
    int nold = c->n;
    c->items = next;
    c->n = n;
    pthread_mutex_unlock(&c->lock);

    int dropped = drop_old(c, old, nold);
    log_msg(LOG_INFO, "catalog", "%s: %d images (%d new, %d unchanged, %d dropped)",
            c->dir, n, added, kept, dropped);
    pthread_mutex_unlock(&c->scan_lock);
    return n;
}

struct image *catalog_get(struct catalog *c, const char *id)
{
    if (!gv_image_id_valid(id))
        return NULL;
    struct image *img = NULL;
    pthread_mutex_lock(&c->lock);
    int i = find(c, id);
    if (i >= 0) {
        img = c->items[i];
        img->refs++;
    }
    pthread_mutex_unlock(&c->lock);
    return img;
}

int catalog_list(struct catalog *c, struct image ***out)
{
    pthread_mutex_lock(&c->lock);
    struct image **a = malloc(((size_t)c->n + 1) * sizeof *a);
    if (!a) {
        pthread_mutex_unlock(&c->lock);
        return -1;
    }
    for (int i = 0; i < c->n; i++) {
        a[i] = c->items[i];
        a[i]->refs++;
    }
    int n = c->n;
    pthread_mutex_unlock(&c->lock);
    *out = a;
    return n;
}

int catalog_count(struct catalog *c)
{
    pthread_mutex_lock(&c->lock);
    int n = c->n;
    pthread_mutex_unlock(&c->lock);
    return n;
}

struct gv_decoder *image_decoder_get(struct image *img)
{
    struct catalog *c = img->cat;
    struct gv_decoder *d = NULL;
    pthread_mutex_lock(&c->lock);
    if (img->npool > 0)
        d = img->pool[--img->npool];
    pthread_mutex_unlock(&c->lock);
    if (!d)
        d = gv_decoder_new_shared(img->store, c->tiles, img->serial);
    return d;
}

void image_decoder_put(struct image *img, struct gv_decoder *d)
{
    if (!d)
        return;
    gv_decoder_idle(d); /* pooled decoders pin no tile */
    struct catalog *c = img->cat;
    pthread_mutex_lock(&c->lock);
    if (!img->pool)
        img->pool = calloc((size_t)c->pool_max, sizeof *img->pool);
    if (img->pool && img->npool < c->pool_max) {
        img->pool[img->npool++] = d;
        d = NULL;
    }
    pthread_mutex_unlock(&c->lock);
    gv_decoder_free(d);
}
