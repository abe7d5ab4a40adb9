/*
 * filter_store.c - stock and stored filter graphs (filter_store.h).
 *
 * The whole list lives in memory (graph documents are at most
 * filter_max_json_bytes, 64 KiB by default, and a library holds dozens):
 * an array of entries sorted stock first, then by id, each with its
 * document and the summary that GET /v1/filters shows.  The lock guards
 * the array; file writes happen outside it, and the entry is inserted
 * afterwards, so a slow fsync never blocks readers.
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "base/atomic_file.h"
#include "base/ids.h"
#include "filter_store.h"
#include "log.h"

#define STORED_PREFIX "user-"
#define STORED_ID_LEN 21 /* "user-" + 16 hex digits */

struct entry {
    char id[GV_FILTER_ID_MAX];
    int stock;
    char *doc;
    size_t len;
    json_t *summary;
};

struct filter_store {
    char *library_dir, *filter_dir;
    struct gv_filter_limits lim;
    pthread_mutex_t lock;
    struct entry *e;
    int n;
    char unwritable[sizeof ((struct gv_error *)0)->text]; /* "" if writable */
};

static void entry_clear(struct entry *e)
{
    free(e->doc);
    json_decref(e->summary);
    memset(e, 0, sizeof *e);
}

static int entry_cmp(const void *a, const void *b)
{
    const struct entry *x = a, *y = b;
    if (x->stock != y->stock)
        return y->stock - x->stock;
    return strcmp(x->id, y->id);
}

static int stored_id(const char *s, size_t n)
{
    if (n != STORED_ID_LEN || strncmp(s, STORED_PREFIX, 5))
        return 0;
    for (size_t i = 5; i < n; i++)
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return 0;
    return 1;
}

static uint64_t fnv1a(const char *s, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull; /* FNV-1a 64 offset basis, prime */
    for (size_t i = 0; i < n; i++) {
        h ^= (unsigned char)s[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

static json_t *summary(const struct gv_filter_graph *g, const char *id, int stock)
{
    json_t *params = json_array();
    for (int i = 0; params && i < g->nmodules; i++)
        for (int k = 0; k < g->module[i].nparams; k++) {
            const struct gv_filter_param *p = &g->module[i].param[k];
            if (json_array_append_new(params, json_pack(
                    "{s:s,s:s,s:f,s:f,s:f}", "module", g->module[i].id, "name",
                    p->name, "min", p->min, "max", p->max, "default", p->def)) < 0) {
                json_decref(params);
                return NULL;
            }
        }
    if (!params)
        return NULL;
    return json_pack("{s:s,s:s,s:s,s:b,s:i,s:o}", "id", id, "name", g->name,
                     "description", g->description, "stock", stock,
                     "output_channels", g->output_channels, "params", params);
}

/* Parse doc and fill *e (taking doc).  0, or -1 with *err (doc freed). */
static int make_entry(struct filter_store *fs, const char *id, int stock,
                      char *doc, size_t len, struct entry *e,
                      struct gv_error *err)
{
    memset(e, 0, sizeof *e);
    struct gv_filter_graph *g = gv_filter_graph_parse(doc, len, &fs->lim, err);
    if (!g) {
        free(doc);
        return -1;
    }
    snprintf(e->id, sizeof e->id, "%s", id);
    e->stock = stock;
    e->doc = doc;
    e->len = len;
    e->summary = summary(g, id, stock);
    gv_filter_graph_free(g);
    if (!e->summary) {
        entry_clear(e);
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    }
    return 0;
}

/* Read dir/name: at most max bytes, NUL-terminated. */
static char *read_file(const char *dir, const char *name, size_t max,
                       size_t *len, struct gv_error *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        gv_fail_errno(err, errno, "filter: %s", path);
        return NULL;
    }
    char *buf = malloc(max + 2);
    size_t n = 0;
    while (buf && n <= max) {
        ssize_t k = read(fd, buf + n, max + 1 - n);
        if (k < 0 && errno == EINTR)
            continue;
        if (k <= 0) {
            if (k < 0) {
                gv_fail_errno(err, errno, "filter: %s", path);
                free(buf);
                buf = NULL;
            }
            break;
        }
        n += (size_t)k;
    }
    close(fd);
    if (!buf) {
        if (err->code == GV_OK)
            gv_fail(err, GV_ENOMEM, "filter: out of memory");
        return NULL;
    }
    if (n > max) {
        gv_fail(err, GV_ELIMIT, "filter: %s is larger than filter_max_json_bytes "
                "(%zu)", path, max);
        free(buf);
        return NULL;
    }
    buf[n] = '\0';
    *len = n;
    return buf;
}

/* Append the graphs of dir to *v (stock, or stored ids only). */
static void scan_dir(struct filter_store *fs, const char *dir, int stock,
                     struct entry **v, int *n, int *cap)
{
    DIR *d = opendir(dir);
    if (!d) {
        log_msg(stock ? LOG_WARN : LOG_ERROR, "filter", "%s: %s%s", dir,
                strerror(errno), stock ? " (no stock filters)" : "");
        return;
    }
    struct dirent *de;
    while ((de = readdir(d)) != NULL) {
        size_t k = strlen(de->d_name);
        if (k < 6 || strcmp(de->d_name + k - 5, ".json") || de->d_name[0] == '.')
            continue;
        k -= 5;
        if (stock ? !gv_filter_id_valid_n(de->d_name, k) : !stored_id(de->d_name, k))
            continue;
        char id[GV_FILTER_ID_MAX];
        memcpy(id, de->d_name, k);
        id[k] = '\0';
        struct gv_error err = {0};
        gv_error_clear(&err);
        size_t len;
        char *doc = read_file(dir, de->d_name, fs->lim.max_json_bytes, &len, &err);
        if (*n == *cap) {
            int c = *cap ? 2 * *cap : 16;
            struct entry *nv = realloc(*v, (size_t)c * sizeof *nv);
            if (!nv) {
                free(doc);
                break;
            }
            *v = nv;
            *cap = c;
        }
        if (!doc || make_entry(fs, id, stock, doc, len, &(*v)[*n], &err) < 0) {
            char esc[400];
            log_msg(LOG_WARN, "filter", "skipping %s/%s: %s", dir, de->d_name,
                    log_escape(esc, sizeof esc, err.text));
            continue;
        }
        (*n)++;
    }
    closedir(d);
}

int filter_store_scan(struct filter_store *fs)
{
    struct entry *v = NULL;
    int n = 0, cap = 0;
    if (fs->library_dir[0])
        scan_dir(fs, fs->library_dir, 1, &v, &n, &cap);
    int nstock = n;
    /* filter_dir is made by the first POST: missing is not an error */
    if (fs->filter_dir[0] && access(fs->filter_dir, F_OK) == 0)
        scan_dir(fs, fs->filter_dir, 0, &v, &n, &cap);
    if (n)
        qsort(v, (size_t)n, sizeof *v, entry_cmp);
    pthread_mutex_lock(&fs->lock);
    struct entry *old = fs->e;
    int nold = fs->n;
    fs->e = v;
    fs->n = n;
    pthread_mutex_unlock(&fs->lock);
    for (int i = 0; i < nold; i++)
        entry_clear(&old[i]);
    free(old);
    log_msg(LOG_INFO, "filter", "%d stock and %d stored filter graphs", nstock,
            n - nstock);
    return n;
}

struct filter_store *filter_store_new(const char *library_dir,
                                      const char *filter_dir,
                                      const struct gv_filter_limits *lim)
{
    struct filter_store *fs = calloc(1, sizeof *fs);
    if (!fs)
        return NULL;
    fs->library_dir = strdup(library_dir);
    fs->filter_dir = strdup(filter_dir);
    if (!fs->library_dir || !fs->filter_dir) {
        free(fs->library_dir);
        free(fs->filter_dir);
        free(fs);
        return NULL;
    }
    fs->lim = *lim;
    pthread_mutex_init(&fs->lock, NULL);
    if (!filter_dir[0])
        snprintf(fs->unwritable, sizeof fs->unwritable,
                 "storing graphs is disabled (filter_dir = \"\")");
    else if (access(filter_dir, F_OK) == 0 &&
             access(filter_dir, R_OK | W_OK | X_OK) < 0)
        log_msg(LOG_ERROR, "filter", "filter_dir %s: %s: storing graphs will "
                "fail", filter_dir, strerror(errno));
    filter_store_scan(fs);
    return fs;
}

void filter_store_free(struct filter_store *fs)
{
    if (!fs)
        return;
    for (int i = 0; i < fs->n; i++)
        entry_clear(&fs->e[i]);
    free(fs->e);
    pthread_mutex_destroy(&fs->lock);
    free(fs->library_dir);
    free(fs->filter_dir);
    free(fs);
}

int filter_store_writable(struct filter_store *fs, char *buf, size_t size)
{
    snprintf(buf, size, "%s", fs->unwritable);
    return !fs->unwritable[0];
}

json_t *filter_store_list(struct filter_store *fs)
{
    json_t *arr = json_array();
    pthread_mutex_lock(&fs->lock);
    for (int i = 0; arr && i < fs->n; i++)
        if (json_array_append(arr, fs->e[i].summary) < 0) {
            json_decref(arr);
            arr = NULL;
        }
    pthread_mutex_unlock(&fs->lock);
    return arr ? json_pack("{s:o}", "filters", arr) : NULL;
}

static int find(struct filter_store *fs, const char *id)
{
    for (int i = 0; i < fs->n; i++)
        if (!strcmp(fs->e[i].id, id))
            return i;
    return -1;
}

int filter_store_get(struct filter_store *fs, const char *id, char **doc,
                     size_t *len, int *stock, struct gv_error *err)
{
    int rc = 0;
    pthread_mutex_lock(&fs->lock);
    int i = find(fs, id);
    if (i < 0) {
        char esc[100];
        rc = gv_fail(err, GV_ENOTFOUND, "filter: no graph '%s'",
                     log_escape(esc, sizeof esc, id));
    } else if (!(*doc = malloc(fs->e[i].len + 1))) {
        rc = gv_fail(err, GV_ENOMEM, "filter: out of memory");
    } else {
        memcpy(*doc, fs->e[i].doc, fs->e[i].len + 1);
        *len = fs->e[i].len;
        *stock = fs->e[i].stock;
    }
    pthread_mutex_unlock(&fs->lock);
    return rc;
}

/* fsync a directory so that a rename or unlink in it is durable. */
static int sync_dir(const char *dir, struct gv_error *err)
{
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0 || fsync(fd) < 0) {
        int e = errno;
        if (fd >= 0)
            close(fd);
        return gv_fail_errno(err, e, "filter: %s", dir);
    }
    close(fd);
    return 0;
}

/* Write dir/name atomically (base/atomic_file.h: fsync, rename, fsync of
 * the directory), readable by gigaviewd's user only, as filter_dir is. */
static int write_atomic(const char *dir, const char *name, const char *data,
                        size_t len, struct gv_error *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    const struct gv_atomic_opts opts = {.module = "filter", .mode = 0600};
    return gv_atomic_file_write(path, data, len, &opts, err);
}

int filter_store_put(struct filter_store *fs, const char *doc, size_t len,
                     char *id, int *created, struct gv_error *err)
{
    if (fs->unwritable[0])
        return gv_fail(err, GV_EIO, "filter: %s", fs->unwritable);
    snprintf(id, GV_FILTER_ID_MAX, STORED_PREFIX "%016llx",
             (unsigned long long)fnv1a(doc, len));
    *created = 0;
    pthread_mutex_lock(&fs->lock);
    int i = find(fs, id), same = i >= 0 && fs->e[i].len == len &&
                                 !memcmp(fs->e[i].doc, doc, len);
    pthread_mutex_unlock(&fs->lock);
    if (same)
        return 0;
    if (i >= 0)
        return gv_fail(err, GV_EINVAL, "filter: another graph has id %s", id);
    char *copy = malloc(len + 1);
    if (!copy)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    memcpy(copy, doc, len);
    copy[len] = '\0';
    struct entry e;
    if (make_entry(fs, id, 0, copy, len, &e, err) < 0)
        return -1;
    char name[GV_FILTER_ID_MAX + 8];
    snprintf(name, sizeof name, "%s.json", id);
    if ((mkdir(fs->filter_dir, 0700) < 0 && errno != EEXIST &&
         gv_fail_errno(err, errno, "filter: creating filter_dir %s",
                       fs->filter_dir) < 0) ||
        write_atomic(fs->filter_dir, name, doc, len, err) < 0) {
        entry_clear(&e);
        return -1;
    }
    pthread_mutex_lock(&fs->lock);
    int rc = 0;
    if (find(fs, id) >= 0) { /* stored meanwhile by a concurrent request */
        entry_clear(&e);
    } else {
        struct entry *v = realloc(fs->e, (size_t)(fs->n + 1) * sizeof *v);
        if (!v) {
            entry_clear(&e);
            rc = gv_fail(err, GV_ENOMEM, "filter: out of memory");
        } else {
            fs->e = v;
            fs->e[fs->n++] = e;
            qsort(fs->e, (size_t)fs->n, sizeof *fs->e, entry_cmp);
            *created = 1;
        }
    }
    pthread_mutex_unlock(&fs->lock);
    return rc;
}

int filter_store_delete(struct filter_store *fs, const char *id,
                        struct gv_error *err)
{
    char esc[100];
    pthread_mutex_lock(&fs->lock);
    int i = find(fs, id), rc = 0;
    if (i < 0) {
        rc = gv_fail(err, GV_ENOTFOUND, "filter: no graph '%s'",
                     log_escape(esc, sizeof esc, id));
    } else if (fs->e[i].stock) {
        rc = 1;
    } else {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.json", fs->filter_dir, id);
        if (unlink(path) < 0 && errno != ENOENT) {
            rc = gv_fail_errno(err, errno, "filter: %s", path);
        } else {
            entry_clear(&fs->e[i]);
            memmove(&fs->e[i], &fs->e[i + 1],
                    (size_t)(fs->n - i - 1) * sizeof *fs->e);
            fs->n--;
        }
    }
    pthread_mutex_unlock(&fs->lock);
    if (rc == 0)
        rc = sync_dir(fs->filter_dir, err);
    return rc;
}
