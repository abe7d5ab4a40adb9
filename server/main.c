/*
 * main.c - gigaviewd: serve a directory of gigaview stores over HTTP.
 *
 *   gigaviewd [-c FILE] [-t] [-p PORT] [-d STOREDIR] [-l ADDR]
 *
 * Life cycle: read the configuration (defaults, then FILE, then the
 * command-line overrides), scan the store directory, open the GPU context
 * (gpu = auto; on failure one error line and the daemon serves without
 * it), start the HTTP daemon, log "listening on http://ADDR:PORT/", then wait for signals in
 * the main thread (sigwait; they are blocked in every other thread, which
 * inherit the mask):
 *   SIGHUP           rescan the store directory (added, replaced and
 *                    removed stores; requests in flight keep their store)
 *   SIGTERM, SIGINT  stop accepting, let requests in flight finish (up to
 *                    drain_timeout seconds), exit 0
 * -t checks the configuration (and that the store directory is readable)
 * and exits 0 or 1 without serving.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.h" /* autoconf: PACKAGE_VERSION */

#include "catalog.h"
#include "gpu.h"
#include "http.h"
#include "log.h"
#include "page_cache.h"
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

/* gpu = auto: open the EGL context, logging what was chosen (INFO) or the
 * one final failure with every attempt (ERROR); the daemon serves without
 * a GPU then.  gpu = off: EGL is not touched.  Called with the signals
 * blocked, so the GL thread (and the driver's threads) inherit the mask. */
static void open_gpu(struct server *srv)
{
    if (!strcmp(srv->cfg->gpu, "off")) {
        snprintf(srv->gpu_reason, sizeof srv->gpu_reason,
                 "disabled by configuration");
        log_msg(LOG_INFO, "gpu", "disabled by configuration");
        return;
    }
    struct gv_error err;
    gv_error_clear(&err);
    srv->gpu = gv_gpu_open(&err);
    if (!srv->gpu) {
        /* err.text reads "gpu: no usable EGL context: ATTEMPT; ATTEMPT; "
         * (lib/gpu_context.c): drop the last separator. */
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
}

int main(int argc, char **argv)
{
    static struct settings cfg;
    struct gv_error err;
    const char *file = NULL, *port = NULL, *dir = NULL, *addr = NULL;
    int test = 0, c;
    settings_defaults(&cfg);
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
    if ((file && settings_load(&cfg, file, &err) < 0) ||
        (port && settings_set(&cfg, "port", port, "-p", &err) < 0) ||
        (dir && settings_set(&cfg, "store_dir", dir, "-d", &err) < 0) ||
        (addr && settings_set(&cfg, "listen", addr, "-l", &err) < 0)) {
        fprintf(stderr, "gigaviewd: %s\n", err.text);
        return 1;
    }
    struct stat st;
    errno = 0;
    if (stat(cfg.store_dir, &st) < 0 || !S_ISDIR(st.st_mode) ||
        access(cfg.store_dir, R_OK | X_OK) < 0) {
        fprintf(stderr, "gigaviewd: %s%sstore_dir %s: %s\n", file ? file : "",
                file ? ": " : "", cfg.store_dir,
                errno ? strerror(errno) : "not a directory");
        return 1;
    }
    if (test) {
        printf("gigaviewd: configuration %s is valid\n", file ? file : "(defaults)");
        return 0;
    }
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
    srv.catalog = catalog_new(cfg.store_dir, (size_t)cfg.decoder_cache_bytes,
                              (int)cfg.threads);
    if (!srv.pages || !srv.catalog) {
        log_msg(LOG_ERROR, "main", "out of memory");
        return 1;
    }
    catalog_on_close(srv.catalog, forget_pages, srv.pages);
    catalog_scan(srv.catalog);
    open_gpu(&srv);
    if (http_start(&srv) < 0) {
        gv_gpu_close(srv.gpu);
        return 1;
    }
    if (strchr(cfg.listen, ':'))
        log_msg(LOG_INFO, "main", "listening on http://[%s]:%u/", cfg.listen,
                srv.port);
    else
        log_msg(LOG_INFO, "main", "listening on http://%s:%u/", cfg.listen,
                srv.port);

    for (;;) {
        int sig;
        if (sigwait(&set, &sig) != 0)
            continue;
        if (sig == SIGHUP) {
            log_msg(LOG_INFO, "main", "SIGHUP: rescanning %s", cfg.store_dir);
            catalog_scan(srv.catalog);
            continue;
        }
        log_msg(LOG_INFO, "main", "%s: draining (up to %llus)",
                sig == SIGTERM ? "SIGTERM" : "SIGINT",
                (unsigned long long)cfg.drain_timeout);
        break;
    }
    http_drain_and_stop(&srv, (unsigned)cfg.drain_timeout);
    gv_gpu_close(srv.gpu);
    catalog_free(srv.catalog);
    page_cache_free(srv.pages);
    log_msg(LOG_INFO, "main", "stopped");
    log_close();
    return 0;
}
