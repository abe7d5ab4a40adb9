/*
 * settings.c - the configuration table and its parser (see settings.h).
 *
 * Modelled on redis' static_configs[]: adding a key is adding a row.
 * Numbers accept decimal digits only (no sign, no hex) with an optional
 * K, M, G or T suffix (powers of 1024) for sizes; overflow and values
 * outside [min, max] are errors, never silently clamped.
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "settings.h"
#include "base/ids.h"
#include "base/parse_uint.h"
#include "log.h"

/* Where `make install` puts the stock filter graphs (Makefile.am). */
#ifndef GV_FILTER_LIBRARY_DIR
#define GV_FILTER_LIBRARY_DIR "/usr/local/share/gigaview/filters"
#endif
/* The build directory this gigaviewd was built in and the stock graphs
 * of its source tree (Makefile.am); "" in other builds (the fuzz
 * targets), which then always use the installed graphs. */
#ifndef GV_BUILD_DIR
#define GV_BUILD_DIR ""
#endif
#ifndef GV_SOURCE_FILTER_LIBRARY_DIR
#define GV_SOURCE_FILTER_LIBRARY_DIR ""
#endif

enum settings_type { T_STR, T_UINT, T_SIZE, T_DOUBLE, T_LEVEL, T_GPU,
                     T_GPU_PLATFORM, T_WATER };

struct settings_key {
    const char *name;
    enum settings_type type;
    size_t offset;
    size_t size;            /* T_STR: the field's capacity */
    const char *def;
    double min, max;
    const char *help;
};

#define F(field) offsetof(struct settings, field), sizeof(((struct settings *)0)->field)

/* One key a row: the rows share one shape on purpose (a declarative table). */
static const struct settings_key keys[] = {
    {"listen", T_STR, F(listen), "127.0.0.1", 0, 0,
     "address to listen on (IPv4 or IPv6 literal)"},
    {"port", T_UINT, F(port), "8080", 0, 65535,
     "TCP port; 0 picks a free one (logged at start)"},
    {"store_dir", T_STR, F(store_dir), "/var/lib/gigaview/stores", 0, 0,
     "directory of *.gv stores; the id is the file name without .gv"},
    {"threads", T_UINT, F(threads), "4", 1, 256,
     "HTTP threads (one libmicrohttpd daemon each, epoll), fed by one accepting thread"},
    {"cache_bytes", T_SIZE, F(cache_bytes), "256M", 0, 1e15,
     "page cache bound in bytes (K, M, G suffixes); 0 disables caching"},
    {"decoder_cache_bytes", T_SIZE, F(decoder_cache_bytes), "128M", 0, 1e12,
     "the one decoded-tile cache, shared by every thread and store"},
    {"resident_bytes", T_SIZE, F(resident_bytes), "32M", 0, 1e12,
     "of decoder_cache_bytes, the stores' coarsest levels, kept decoded "
     "from their opening"},
    {"max_region_pixels", T_SIZE, F(max_region_pixels), "64M", 1, 1e15,
     "largest region decoded for one request, in pixels (413 beyond)"},
    /* meshes of height stores (route_mesh.c) */
    {"max_mesh_samples", T_SIZE, F(max_mesh_samples), "4M", 4, 4294836225.0,
     "largest grid of height samples meshed for one request (413 beyond)"},
    {"max_mesh_triangles", T_SIZE, F(max_mesh_triangles), "2M", 2, 4294967295.0,
     "most triangles of one mesh (413 beyond)"},
    {"mesh_time_limit", T_DOUBLE, F(mesh_time_limit), "10", 0.01, 3600,
     "seconds of meshing for one request (504 beyond)"},
    /* terrain tiles (route_terrain.c) */
    {"terrain_error_scale", T_DOUBLE, F(terrain_error_scale), "0.03125", 0, 1000,
     "terrain tile error bound of level z: this times 77067 m / 2^z"},
    {"terrain_water_below", T_WATER, F(terrain_water_below), "", 0, 0,
     "height stores whose terrain tiles carry a water mask: ID:HEIGHT "
     "entries (* for every store), water where the height is below HEIGHT "
     "(\"\": none)"},
    /* mesh simplification (route_mesh_simplify.c) */
    {"simplify_max_bytes", T_SIZE, F(simplify_max_bytes), "64M", 1024, 4294967295.0,
     "largest mesh file POSTed to /v1/meshes/simplify (413 beyond)"},
    {"simplify_max_faces", T_SIZE, F(simplify_max_faces), "4M", 1, 268435456,
     "most triangles of a mesh to simplify, and of a request (413 beyond)"},
    {"simplify_time_limit", T_DOUBLE, F(simplify_time_limit), "10", 0.01, 3600,
     "seconds one simplification may take in its filter worker (504 beyond)"},
    {"max_output_pixels", T_SIZE, F(max_output_pixels), "16M", 1, 1e15,
     "largest output image in pixels (IIIF maxArea)"},
    {"max_output_side", T_UINT, F(max_output_side), "16384", 1, 2147483647,
     "largest output width or height (IIIF maxWidth, maxHeight)"},
    {"max_upscale", T_DOUBLE, F(max_upscale), "4", 1, 64,
     "largest IIIF ^ upscaling factor"},
    {"connection_limit", T_UINT, F(connection_limit), "1024", 1, 1000000,
     "simultaneous connections; further ones wait in the accept queue"},
    {"rate_limit", T_DOUBLE, F(rate_limit), "0", 0, 1e6,
     "requests a second each client may make, past its burst (429 with "
     "Retry-After beyond; /healthz and /metrics are not counted); 0: no limit"},
    {"rate_limit_burst", T_DOUBLE, F(rate_limit_burst), "200", 1, 1e6,
     "requests a client may make at once before rate_limit paces it"},
    {"rate_limit_header", T_STR, F(rate_limit_header), "", 0, 0,
     "request header a trusted reverse proxy sets to the client's address, "
     "which then names the client (\"\": the connection's address)"},
    {"connection_timeout", T_UINT, F(connection_timeout), "30", 1, 86400,
     "seconds a connection may stay idle (slow clients are closed)"},
    {"request_timeout", T_UINT, F(request_timeout), "60", 0, 86400,
     "seconds a whole request (head and body) may take to arrive, from its "
     "connection's start or its previous answer; 0: no bound"},
    {"max_url_bytes", T_SIZE, F(max_url_bytes), "8K", 256, 1048576,
     "longest request target (path and query) in bytes; 414 beyond"},
    {"max_header_bytes", T_SIZE, F(max_header_bytes), "16K", 1024, 1048576,
     "largest request head (every header line) in bytes; 431 beyond"},
    {"max_query_args", T_UINT, F(max_query_args), "64", 1, 4096,
     "most query arguments in one request; 400 beyond"},
    {"drain_timeout", T_UINT, F(drain_timeout), "10", 0, 3600,
     "seconds SIGTERM waits for in-flight requests before exiting"},
    {"cors_origin", T_STR, F(cors_origin), "*", 0, 0,
     "Access-Control-Allow-Origin of /v1 responses (\"\" for none); IIIF always sends *"},
    {"auth_token", T_STR, F(auth_token), "", 0, 0,
     "bearer token required by write endpoints (\"\" disables them)"},
    /* access control (access.h, docs/OPERATIONS.md "Access control") */
    {"access_policy", T_STR, F(access_policy), "", 0, 0,
     "JSON file mapping image ids to public or an access group (\"\": every "
     "image public); reread on SIGHUP"},
    {"access_token_secret_file", T_STR, F(access_token_secret_file), "", 0, 0,
     "file holding the HMAC-SHA256 secret of signed access tokens, at least "
     "32 bytes (\"\": no signed tokens from elsewhere)"},
    {"access_trusted_header", T_STR, F(access_trusted_header), "", 0, 0,
     "request header a reverse proxy sets to the user's groups on "
     "/iiif/auth/login only (\"\": off)"},
    {"access_origins", T_STR, F(access_origins), "", 0, 0,
     "origins (scheme://host[:port], space separated) the IIIF token service "
     "gives tokens to (\"\": any)"},
    {"access_token_ttl", T_UINT, F(access_token_ttl), "3600", 60, 31536000,
     "seconds a token minted by /iiif/auth/login stays valid"},
    {"public_url", T_STR, F(public_url), "", 0, 0,
     "base URL for absolute links, e.g. https://img.example.org (\"\": from Host)"},
    {"log_level", T_LEVEL, F(log_level), "info", 0, 0,
     "error, warn, info or debug"},
    {"access_log", T_STR, F(access_log), "stderr", 0, 0,
     "access log: a file path, \"stderr\" or \"off\""},
    {"batch_max_tiles", T_UINT, F(batch_max_tiles), "256", 1, 65536,
     "most tiles in one batch request"},
    {"max_request_bytes", T_SIZE, F(max_request_bytes), "1M", 1024, 67108864,
     "largest request body (POST) in bytes; 413 beyond, refused before reading "
     "when announced"},
    {"jpeg_quality", T_UINT, F(jpeg_quality), "90", 1, 100,
     "quality of JPEG and WebP output"},
    {"gpu", T_GPU, F(gpu), "auto", 0, 0,
     "auto: open an EGL context at start (CPU only if none works); off: never"},
    {"gpu_platform", T_GPU_PLATFORM, F(gpu_platform), "auto", 0, 0,
     "EGL platform of gigaviewd and its filter workers: auto (device, then "
     "surfaceless, then default), device, surfaceless or default"},
    {"filter_workers", T_UINT, F(filter_workers), "2", 0, 64,
     "filter worker processes (each with its own EGL context); 0 disables filters"},
    {"filter_timeout_ms", T_UINT, F(filter_timeout_ms), "10000", 100, 3600000,
     "time limit of one filter job in ms; the worker is killed past it (504)"},
    {"filter_compile_timeout_ms", T_UINT, F(filter_compile_timeout_ms),
     "10000", 100, 3600000,
     "time limit in ms of validating and compiling a graph that is stored "
     "(POST /v1/filters) in its worker (504 beyond)"},
    {"filter_start_timeout_ms", T_UINT, F(filter_start_timeout_ms), "60000",
     1000, 3600000,
     "time in ms a new filter worker has to start its EGL context and say "
     "it is ready; past it the worker is killed and started again later"},
    {"filter_memory_limit", T_SIZE, F(filter_memory_limit), "1G", 0, 1e15,
     "RLIMIT_DATA of each filter worker (heap and private mappings); 0: none"},
    {"filter_max_jobs", T_UINT, F(filter_max_jobs), "8", 1, 4096,
     "filter jobs queued or running at once; more get 503 with Retry-After"},
    {"max_filter_pixels", T_SIZE, F(max_filter_pixels), "4M", 1, 268435456,
     "largest padded region of one filter request, in pixels (413 beyond)"},
    {"filter_worker", T_STR, F(filter_worker), "", 0, 0,
     "the gigaview-filter-worker program (\"\": next to gigaviewd, else installed)"},
    {"filter_dir", T_STR, F(filter_dir), "/var/lib/gigaview-filters", 0, 0,
     "directory of graphs stored with POST /v1/filters (\"\": storing disabled)"},
    {"filter_library_dir", T_STR, F(filter_library_dir), "", 0, 0,
     "directory of the stock filter graphs (*.json) (\"\": the source tree's "
     "filters/library when gigaviewd runs from its build tree, else the "
     "installed ones)"},
    {"filter_max_json_bytes", T_SIZE, F(filter_max_json_bytes), "64K", 64, 1048576,
     "largest filter graph document in bytes"},
    {"filter_max_json_depth", T_UINT, F(filter_max_json_depth), "16", 4, 64,
     "deepest nesting of arrays and objects in a graph document"},
    {"filter_max_modules", T_UINT, F(filter_max_modules), "32", 1, 64,
     "most modules in one filter graph"},
    {"filter_max_glsl_bytes", T_SIZE, F(filter_max_glsl_bytes), "16K", 1, 1048576,
     "largest GLSL body of one module in bytes"},
    {"filter_max_padding", T_UINT, F(filter_max_padding), "512", 0, 16384,
     "largest region padding per side in pixels (sum of supports)"},
    /* IIIF and region rendering (render_pool.h, output_cache.h) */
    {"render_threads", T_UINT, F(render_threads), "4", 1, 256,
     "threads that render IIIF images and regions (off the HTTP threads)"},
    {"render_queue", T_UINT, F(render_queue), "64", 1, 65536,
     "renders waiting for a render thread; more get 503 with Retry-After"},
    {"output_cache_bytes", T_SIZE, F(output_cache_bytes), "64M", 0, 1e12,
     "encoded IIIF images and regions kept by canonical request; 0 disables"},
};

#define NKEYS (sizeof keys / sizeof keys[0])

static int set_key(struct settings *c, const struct settings_key *k,
                   const char *value, const char *where,
                   struct gv_error *err)
{
    char *field = (char *)c + k->offset;
    switch (k->type) {
    case T_STR:
        if (strlen(value) >= k->size)
            return gv_fail(err, GV_EINVAL, "%s: %s: value longer than %zu bytes",
                           where, k->name, k->size - 1);
        memcpy(field, value, strlen(value) + 1);
        return 0;
    case T_LEVEL:
        if (log_level_parse(value) < 0)
            return gv_fail(err, GV_EINVAL,
                           "%s: %s: '%s' is not error, warn, info or debug",
                           where, k->name, value);
        snprintf(field, k->size, "%s", value);
        return 0;
    case T_GPU:
        if (strcmp(value, "auto") && strcmp(value, "off"))
            return gv_fail(err, GV_EINVAL, "%s: %s: '%s' is not auto or off",
                           where, k->name, value);
        snprintf(field, k->size, "%s", value);
        return 0;
    case T_GPU_PLATFORM: /* the names of lib/gpu's gv_gpu_platform_parse */
        if (strcmp(value, "auto") && strcmp(value, "device") &&
            strcmp(value, "surfaceless") && strcmp(value, "default"))
            return gv_fail(err, GV_EINVAL, "%s: %s: '%s' is not auto, device, "
                           "surfaceless or default", where, k->name, value);
        snprintf(field, k->size, "%s", value);
        return 0;
    case T_WATER: {
        double h;
        if (strlen(value) >= k->size)
            return gv_fail(err, GV_EINVAL, "%s: %s: value longer than %zu bytes",
                           where, k->name, k->size - 1);
        if (settings_water_below(value, "*", &h) < 0)
            return gv_fail(err, GV_EINVAL, "%s: %s: '%s' is not a list of "
                           "ID:HEIGHT (an image id or *, a number)", where,
                           k->name, value);
        memcpy(field, value, strlen(value) + 1);
        return 0;
    }
    case T_UINT:
    case T_SIZE: {
        uint64_t v;
        if (gv_parse_uint(value, k->type == T_SIZE, &v) < 0)
            return gv_fail(err, GV_EINVAL, "%s: %s: '%s' is not a %s", where,
                           k->name, value,
                           k->type == T_SIZE ? "size (digits with optional K, M, G, T)"
                                             : "non-negative integer");
        if ((double)v < k->min || (double)v > k->max)
            return gv_fail(err, GV_EINVAL, "%s: %s: %s is outside %.0f..%.0f",
                           where, k->name, value, k->min, k->max);
        memcpy(field, &v, sizeof v);
        return 0;
    }
    case T_DOUBLE: {
        char *end;
        errno = 0;
        double v = strtod(value, &end);
        if (end == value || *end || errno || !isfinite(v))
            return gv_fail(err, GV_EINVAL, "%s: %s: '%s' is not a number",
                           where, k->name, value);
        if (v < k->min || v > k->max)
            return gv_fail(err, GV_EINVAL, "%s: %s: %s is outside %g..%g",
                           where, k->name, value, k->min, k->max);
        memcpy(field, &v, sizeof v);
        return 0;
    }
    }
    return gv_fail(err, GV_EINVAL, "%s: %s: bad type", where, k->name);
}

int settings_water_below(const char *spec, const char *id, double *height)
{
    int found = 0, exact = 0;
    size_t idn = strlen(id);
    for (const char *p = spec;;) {
        while (*p == ' ' || *p == '\t' || *p == ',')
            p++;
        if (!*p)
            return found;
        const char *colon = p;
        while (*colon && *colon != ':' && *colon != ' ' && *colon != '\t' &&
               *colon != ',')
            colon++;
        size_t n = (size_t)(colon - p);
        int star = n == 1 && *p == '*';
        if (*colon != ':' || (!star && !gv_image_id_valid_n(p, n)))
            return -1;
        char num[64], *end;
        const char *e = colon + 1;
        while (*e && *e != ' ' && *e != '\t' && *e != ',')
            e++;
        size_t nn = (size_t)(e - colon - 1);
        if (nn == 0 || nn >= sizeof num)
            return -1;
        memcpy(num, colon + 1, nn);
        num[nn] = 0;
        errno = 0;
        double v = strtod(num, &end);
        if (*end || errno || !isfinite(v))
            return -1;
        if (n == idn && !memcmp(p, id, n)) {
            *height = v;
            found = exact = 1;
        } else if (star && !exact) {
            *height = v;
            found = 1;
        }
        p = e;
    }
}

void settings_defaults(struct settings *c)
{
    memset(c, 0, sizeof *c);
    for (size_t i = 0; i < NKEYS; i++) {
        struct gv_error err = {0};
        if (set_key(c, &keys[i], keys[i].def, "default", &err) < 0)
            log_msg(LOG_ERROR, "config", "%s", err.text); /* a bug */
    }
}

int settings_set(struct settings *c, const char *key, const char *value,
               const char *where, struct gv_error *err)
{
    for (size_t i = 0; i < NKEYS; i++)
        if (!strcmp(keys[i].name, key))
            return set_key(c, &keys[i], value, where, err);
    return gv_fail(err, GV_EINVAL, "%s: unknown key '%s'", where, key);
}

static char *trim(char *s)
{
    while (*s == ' ' || *s == '\t')
        s++;
    size_t n = strlen(s);
    while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' ||
                     s[n - 1] == '\n'))
        s[--n] = '\0';
    return s;
}

int settings_load(struct settings *c, const char *path, struct gv_error *err)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        int e = errno;
        if (e == ENOENT)
            return gv_fail(err, GV_ENOTFOUND, "%s: no such file", path);
        return gv_fail_errno(err, e, "%s", path);
    }
    char line[4096], where[1200];
    int lineno = 0, rc = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        snprintf(where, sizeof where, "%s:%d", path, lineno);
        if (!strchr(line, '\n') && !feof(f)) {
            rc = gv_fail(err, GV_EINVAL, "%s: line too long", where);
            break;
        }
        char *s = trim(line);
        if (*s == '#' || *s == '\0')
            continue;
        char *eq = strchr(s, '=');
        if (!eq) {
            rc = gv_fail(err, GV_EINVAL, "%s: expected 'key = value'", where);
            break;
        }
        *eq = '\0';
        char *key = trim(s), *value = trim(eq + 1);
        size_t n = strlen(value);
        if (n > 0 && value[0] == '"') {
            if (n < 2 || value[n - 1] != '"') {
                rc = gv_fail(err, GV_EINVAL, "%s: unterminated quote", where);
                break;
            }
            value[n - 1] = '\0';
            value++;
        } else {
            char *hash = strchr(value, '#'); /* trailing comment */
            if (hash) {
                *hash = '\0';
                value = trim(value);
            }
        }
        if (settings_set(c, key, value, where, err) < 0) {
            rc = -1;
            break;
        }
    }
    if (rc == 0 && ferror(f))
        rc = gv_fail_errno(err, errno, "%s: read error", path);
    fclose(f);
    return rc;
}

/* 1 if this process's executable lies in directory `dir` (both resolved
 * with realpath, so symbolic links and ".." compare equal). */
static int running_from(const char *dir)
{
    char exe[PATH_MAX], want[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (!dir[0] || n <= 0 || !realpath(dir, want))
        return 0;
    exe[n] = '\0';
    char *slash = strrchr(exe, '/');
    if (!slash)
        return 0;
    *slash = '\0';
    char here[PATH_MAX];
    return realpath(exe[0] ? exe : "/", here) && !strcmp(here, want);
}

void settings_resolve(struct settings *c)
{
    if (c->filter_library_dir[0])
        return;
    const char *dir = GV_FILTER_LIBRARY_DIR;
    if (GV_SOURCE_FILTER_LIBRARY_DIR[0] && running_from(GV_BUILD_DIR))
        dir = GV_SOURCE_FILTER_LIBRARY_DIR;
    snprintf(c->filter_library_dir, sizeof c->filter_library_dir, "%s", dir);
}

void settings_print_sample(void)
{
    for (size_t i = 0; i < NKEYS; i++) {
        const char *q =
            keys[i].type == T_STR || keys[i].type == T_WATER ? "\"" : "";
        printf("# %s\n%s = %s%s%s\n\n", keys[i].help, keys[i].name, q,
               keys[i].def, q);
    }
}
