/*
 * main.c - gigaviewd: serve a directory of gigaview stores over HTTP.
 *
 *   gigaviewd [-c FILE] [-t] [-p PORT] [-d STOREDIR] [-l ADDR]
 *
 * Life cycle: read the configuration (defaults, then FILE, then the
 * command-line overrides), scan the store directory, open the GPU context
 * (gpu = auto, on the EGL platform gpu_platform names; on failure one
 * error line and the daemon serves without it), start the HTTP daemon,
 * log "listening on http://ADDR:PORT/", then wait for signals in
 * the main thread (sigwait; they are blocked in every other thread, which
 * inherit the mask):
 *   SIGHUP           rescan the store directory (added, replaced and
 *                    removed stores; requests in flight keep their store),
 *                    the filter graph directories and the access policy
 *                    (a bad one is logged and the old one stays)
 *   SIGTERM, SIGINT  let filter jobs finish, stop accepting, let requests
 *                    in flight finish (up to drain_timeout seconds each),
 *                    exit 0
 * Filter graphs run in a pool of worker processes (filter_jobs.h) started
 * after the GPU context: only when it opened, since a worker needs EGL
 * just as much (on the same gpu_platform).  A build configured
 * --without-gpu never touches EGL: it serves tiles, regions and IIIF, and
 * answers filter runs 501 not_implemented.
 * -t checks the configuration (and that the store directory, the access
 * policy and the token secret are readable) and exits 0 or 1 without
 * serving.
 */
#include <assert.h>
#include <errno.h>
#include <malloc.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.h" /* autoconf: PACKAGE_VERSION, GV_HAVE_GPU */

#include "access.h"
#include "catalog.h"
#include "filter.h"
#include "filter_jobs.h"
#include "filter_store.h"
#include "gpu/gpu.h"
#include "http.h"
#include "log.h"
#include "page_cache.h"
#include "rate_limit.h"
#include "output_cache.h"
#include "render_pool.h"
#include "render/tile_cache.h"
#include "settings.h"

static void usage(FILE *out)
{
    fprintf(out,
        "usage: gigaviewd [-c FILE] [-t] [-p PORT] [-d STOREDIR] [-l ADDR]\n"
        "\n"
        "  -c FILE      configuration file (see gigaviewd.conf)\n"
        "  -t           check the configuration and exit (0 good, 1 bad)\n"
        "  -p PORT      listen port (0: any free port), overrides the file\n"
        "  -d STOREDIR  store directory, overrides the file\n"
        "  -l ADDR      listen address, overrides the file\n"
        "  -S           print a sample configuration with every key\n"
        "  -V           print the version\n"
        "\n"
        "SIGHUP rescans the store directory; SIGTERM drains and exits.\n");
}

/* A closed store's pages can never be asked for again (serials are not
 * reused): free them now rather than waiting for the LRU. */
static void forget_pages(uint64_t serial, void *pages)
{
    page_cache_forget(pages, serial);
}

#ifdef GV_HAVE_GPU
#define GPU_BUILT 1
#else
#define GPU_BUILT 0
#endif

/* gpu = auto: open the EGL context on gpu_platform, logging what was
 * chosen (INFO) or the one final failure with every attempt (ERROR); the
 * daemon serves without a GPU then.  gpu = off: EGL is not touched.  A
 * build without the GPU says so (INFO).  Called with the signals blocked,
 * so the GL thread (and the driver's threads) inherit the mask. */
static void open_gpu(struct server *srv)
{
#ifndef GV_HAVE_GPU
    snprintf(srv->gpu_reason, sizeof srv->gpu_reason,
             "gpu: not built: this gigaviewd was configured --without-gpu");
    log_msg(LOG_INFO, "gpu", "not built (configured --without-gpu): serving "
            "tiles, regions and IIIF on the CPU, no filters");
#else
    if (!strcmp(srv->cfg->gpu, "off")) {
        snprintf(srv->gpu_reason, sizeof srv->gpu_reason,
                 "disabled by configuration");
        log_msg(LOG_INFO, "gpu", "disabled by configuration");
        return;
    }
    int platform = gv_gpu_platform_parse(srv->cfg->gpu_platform);
    assert(platform >= 0); /* settings.c accepts only these names */
    struct gv_error err = {0};
    gv_error_clear(&err);
    srv->gpu = gv_gpu_open((enum gv_gpu_platform)platform, &err);
    if (!srv->gpu) {
        /* err.text reads "gpu: no usable EGL context: ATTEMPT; ATTEMPT; "
         * (lib/gpu/gpu_context.c): drop the last separator. */
        size_t n = strlen(err.text);
        while (n > 0 && (err.text[n - 1] == ' ' || err.text[n - 1] == ';'))
            err.text[--n] = '\0';
        snprintf(srv->gpu_reason, sizeof srv->gpu_reason, "%s",
                 n ? err.text : "gpu: no usable EGL context");
        const char *msg = srv->gpu_reason;
        if (!strncmp(msg, "gpu: ", 5))
            msg += 5; /* the module name says it */
        log_msg(LOG_ERROR, "gpu", "%s; serving without a GPU", msg);
        return;
    }
    const struct gv_gpu_info *in = gv_gpu_info(srv->gpu);
    log_msg(LOG_INFO, "gpu", "EGL %s platform, %s: %s / %s / %s", in->platform,
            in->api, in->vendor, in->renderer, in->version);
#endif
}

/* Close the context open_gpu opened, if any. */
static void close_gpu(struct server *srv)
{
#ifdef GV_HAVE_GPU
    gv_gpu_close(srv->gpu);
#else
    (void)srv;
#endif
}

#ifndef GV_FILTER_WORKER
#define GV_FILTER_WORKER "/usr/local/libexec/gigaview-filter-worker"
#endif

/* The worker program: filter_worker, else gigaview-filter-worker next to
 * this executable (a build tree), else the installed one.  0 and path, or
 * -1 with the places tried in why. */
static int find_worker(const struct settings *cfg, char *path, size_t size,
                       char *why, size_t whysize)
{
    if (cfg->filter_worker[0]) {
        snprintf(path, size, "%s", cfg->filter_worker);
        if (access(path, X_OK) == 0)
            return 0;
        snprintf(why, whysize, "filter_worker %.200s: %s", path, strerror(errno));
        return -1;
    }
    char self[2048]; /* with the name appended, fits path[4096] */
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n > 0) {
        self[n] = '\0';
        char *slash = strrchr(self, '/');
        if (slash) {
            *slash = '\0';
            snprintf(path, size, "%s/gigaview-filter-worker", self);
            if (access(path, X_OK) == 0)
                return 0;
        }
    }
    snprintf(path, size, "%s", GV_FILTER_WORKER);
    if (access(path, X_OK) == 0)
        return 0;
    snprintf(why, whysize, "no gigaview-filter-worker next to gigaviewd or at %s",
             GV_FILTER_WORKER);
    return -1;
}

/* The stock and stored graphs, and (with a GPU) the worker pool; when
 * there is no pool, filter_reason and filter_code say why. */
static int start_filters(struct server *srv)
{
    const struct settings *cfg = srv->cfg;
    struct gv_filter_limits lim = {
        (size_t)cfg->filter_max_json_bytes, (int)cfg->filter_max_json_depth,
        (int)cfg->filter_max_modules, (size_t)cfg->filter_max_glsl_bytes,
        (int)cfg->filter_max_padding};
    srv->filter_store = filter_store_new(cfg->filter_library_dir, cfg->filter_dir, &lim);
    if (!srv->filter_store) {
        log_msg(LOG_ERROR, "main", "out of memory");
        return -1;
    }
    char path[4096], why[300];
    srv->filter_code = GV_EUNAVAIL;
    if (!GPU_BUILT) {
        srv->filter_code = GV_EFORMAT;
        snprintf(srv->filter_reason, sizeof srv->filter_reason,
                 "filter: filters need GPU support, which this gigaviewd "
                 "lacks (configured --without-gpu)");
    } else if (!strcmp(cfg->gpu, "off")) {
        snprintf(srv->filter_reason, sizeof srv->filter_reason,
                 "filter: filters are disabled: they need the GPU, and gpu = off");
    } else if (!srv->gpu) {
        snprintf(srv->filter_reason, sizeof srv->filter_reason,
                 "filter: filters need an EGL context and there is none: %s",
                 srv->gpu_reason);
    } else if (cfg->filter_workers == 0) {
        snprintf(srv->filter_reason, sizeof srv->filter_reason,
                 "filter: filters are disabled (filter_workers = 0)");
    } else if (find_worker(cfg, path, sizeof path, why, sizeof why) < 0) {
        snprintf(srv->filter_reason, sizeof srv->filter_reason,
                 "filter: filters are unavailable: %s", why);
    } else {
        struct filter_jobs_config fc = {
            .worker_path = path, .workers = (int)cfg->filter_workers,
            .timeout_ms = (int)cfg->filter_timeout_ms,
            .start_timeout_ms = (int)cfg->filter_start_timeout_ms,
            .memory_limit = cfg->filter_memory_limit,
            .max_pixels = cfg->max_filter_pixels,
            .max_jobs = (int)cfg->filter_max_jobs,
            .gpu_platform = cfg->gpu_platform};
        struct gv_error err = {0};
        srv->filters = filter_jobs_new(&fc, &err);
        if (!srv->filters) {
            log_msg(LOG_ERROR, "filter", "%s", err.text);
            return -1;
        }
        log_msg(LOG_INFO, "filter", "%d workers (%s), %llu ms per job, memory "
                "limit %llu bytes, stock graphs in %s", (int)cfg->filter_workers,
                path, (unsigned long long)cfg->filter_timeout_ms,
                (unsigned long long)cfg->filter_memory_limit,
                cfg->filter_library_dir);
        return 0;
    }
    log_msg(LOG_INFO, "filter", "%s", srv->filter_reason + 8 /* "filter: " */);
    return 0;
}

/* Read the configuration: the defaults, then -c FILE, then the command-
 * line overrides; check the store directory.  Returns -1 to go on and
 * serve, else the exit status (-t, -S, -V, -h, a usage error, a bad
 * configuration). */
static int configure(int argc, char **argv, struct settings *cfg)
{
    struct gv_error err = {0};
    const char *file = NULL, *port = NULL, *dir = NULL, *addr = NULL;
    int test = 0, c;
    settings_defaults(cfg);
    while ((c = getopt(argc, argv, "c:tp:d:l:SVh")) != -1) {
        switch (c) {
        case 'c': file = optarg; break;
        case 't': test = 1; break;
        case 'p': port = optarg; break;
        case 'd': dir = optarg; break;
        case 'l': addr = optarg; break;
        case 'S': settings_print_sample(); return 0;
        case 'V': printf("gigaviewd %s\n", PACKAGE_VERSION); return 0;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc) {
        usage(stderr);
        return 2;
    }
    if ((file && settings_load(cfg, file, &err) < 0) ||
        (port && settings_set(cfg, "port", port, "-p", &err) < 0) ||
        (dir && settings_set(cfg, "store_dir", dir, "-d", &err) < 0) ||
        (addr && settings_set(cfg, "listen", addr, "-l", &err) < 0)) {
        fprintf(stderr, "gigaviewd: %s\n", err.text);
        return 1;
    }
    struct stat st;
    errno = 0;
    if (stat(cfg->store_dir, &st) < 0 || !S_ISDIR(st.st_mode) ||
        access(cfg->store_dir, R_OK | X_OK) < 0) {
        fprintf(stderr, "gigaviewd: %s%sstore_dir %s: %s\n", file ? file : "",
                file ? ": " : "", cfg->store_dir,
                errno ? strerror(errno) : "not a directory");
        return 1;
    }
    settings_resolve(cfg);
    if (test) {
        /* The access policy and the token secret (main() refuses to
         * serve without them as well). */
        struct access *acc = access_new(cfg, &err);
        if (!acc) {
            fprintf(stderr, "gigaviewd: %s\n", err.text);
            return 1;
        }
        access_free(acc);
        printf("gigaviewd: configuration %s is valid\n", file ? file : "(defaults)");
        return 0;
    }
    return -1;
}

/* The decoded-tile cache every decoder shares, the render threads and the
 * encoded-output cache (the IIIF and region routes).  Call with the
 * signals blocked.  0, or -1 (logged). */
static int start_rendering(struct server *srv)
{
    const struct settings *cfg = srv->cfg;
    srv->tiles = gv_tile_cache_new((size_t)cfg->decoder_cache_bytes);
    srv->outputs = output_cache_new((size_t)cfg->output_cache_bytes);
    srv->render = render_pool_new((int)cfg->render_threads,
                                  (int)cfg->render_queue);
    if (!srv->tiles || !srv->outputs || !srv->render) {
        log_msg(LOG_ERROR, "main", "cannot start the render threads and caches");
        return -1;
    }
    return 0;
}

/* After the drain (the catalog is freed: no decoder uses the tiles). */
static void stop_rendering(struct server *srv)
{
    render_pool_free(srv->render);
    output_cache_free(srv->outputs);
    gv_tile_cache_free(srv->tiles);
}

/* Serve until SIGTERM or SIGINT (blocked in every thread, taken here with
 * sigwait); SIGHUP rescans the stores and the filter graphs and rereads
 * the access policy. */
static void wait_for_stop(struct server *srv, const sigset_t *set)
{
    for (;;) {
        int sig;
        if (sigwait(set, &sig) != 0)
            continue;
        if (sig == SIGHUP) {
            log_msg(LOG_INFO, "main", "SIGHUP: rescanning %s", srv->cfg->store_dir);
            catalog_scan(srv->catalog);
            filter_store_scan(srv->filter_store);
            struct gv_error err = {0};
            if (access_reload(srv->access, &err) < 0)
                log_msg(LOG_ERROR, "access", "%s (the previous policy stays "
                        "in force)", err.text);
            continue;
        }
        log_msg(LOG_INFO, "main", "%s: draining (up to %llus)",
                sig == SIGTERM ? "SIGTERM" : "SIGINT",
                (unsigned long long)srv->cfg->drain_timeout);
        return;
    }
}

int main(int argc, char **argv)
{
    static struct settings cfg;
    /* Pages and outputs are large blocks freed in any order as the caches
     * evict; with glibc's sliding mmap threshold they end up on the heap,
     * whose freed pages stay resident (measured: RSS 150 MiB above the
     * configured caches under eviction, bench/README.md "Load and soak").
     * A fixed threshold keeps such blocks in their own mappings, returned
     * to the system when freed.  Decoded tiles, the largest and most
     * frequent, come from the tile cache's slab (base/slab.h) instead,
     * whose slots are reused without a page fault. */
    mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    int rc = configure(argc, argv, &cfg);
    if (rc >= 0)
        return rc;
    if (log_init((enum log_level)log_level_parse(cfg.log_level), cfg.access_log) < 0)
        return 1;

    /* Block the signals we wait for before any thread exists. */
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGHUP);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    pthread_sigmask(SIG_BLOCK, &set, NULL);
    signal(SIGPIPE, SIG_IGN);

    struct server srv;
    memset(&srv, 0, sizeof srv);
    srv.cfg = &cfg;
    srv.pages = page_cache_new(cfg.cache_bytes);
    if (start_rendering(&srv) < 0)
        return 1;
    /* The resident levels live in the tile cache: at most half of it, so
     * that the cache still holds the tiles requests decode. */
    uint64_t resident = cfg.resident_bytes < cfg.decoder_cache_bytes / 2
                            ? cfg.resident_bytes : cfg.decoder_cache_bytes / 2;
    srv.catalog = catalog_new(cfg.store_dir, srv.tiles,
                              (int)(cfg.threads + cfg.render_threads),
                              resident);
    if (!srv.pages || !srv.catalog) {
        log_msg(LOG_ERROR, "main", "out of memory");
        return 1;
    }
    struct gv_error aerr = {0};
    srv.access = access_new(&cfg, &aerr);
    if (!srv.access) {
        log_msg(LOG_ERROR, "access", "%s", aerr.text);
        return 1;
    }
    if (cfg.rate_limit > 0 &&
        !(srv.rate = rate_limit_new(cfg.rate_limit, cfg.rate_limit_burst,
                                    (size_t)cfg.connection_limit * 16, 0))) {
        log_msg(LOG_ERROR, "main", "out of memory");
        return 1;
    }
    catalog_on_close(srv.catalog, forget_pages, srv.pages);
    catalog_scan(srv.catalog);
    open_gpu(&srv);
    if (start_filters(&srv) < 0 || http_start(&srv) < 0) {
        filter_jobs_free(srv.filters);
        filter_store_free(srv.filter_store);
        close_gpu(&srv);
        return 1;
    }
    if (strchr(cfg.listen, ':'))
        log_msg(LOG_INFO, "main", "listening on http://[%s]:%u/", cfg.listen,
                srv.port);
    else
        log_msg(LOG_INFO, "main", "listening on http://%s:%u/", cfg.listen,
                srv.port);

    wait_for_stop(&srv, &set);
    /* Filter jobs first: a request waiting for one is suspended, and
     * every job's end (done or cancelled) resumes it before the HTTP
     * drain. */
    filter_jobs_stop(srv.filters, (unsigned)cfg.drain_timeout * 1000u);
    render_pool_stop(srv.render); /* runs what is queued: resumes them all */
    http_drain_and_stop(&srv, (unsigned)cfg.drain_timeout);
    filter_jobs_free(srv.filters);
    filter_store_free(srv.filter_store);
    close_gpu(&srv);
    catalog_free(srv.catalog);
    access_free(srv.access);
    rate_limit_free(srv.rate);
    stop_rendering(&srv);
    page_cache_free(srv.pages);
    log_msg(LOG_INFO, "main", "stopped");
    log_close();
    return 0;
}
