/*
 * settings.h - gigaviewd's configuration: one declarative table.
 *
 * (Named settings, not config.h, which is autoconf's header and is
 * git-ignored.)
 *
 * Every key is a row of settings.c's table {name, type, field offset,
 * default, min, max, help}: the defaults are parsed by the same code as
 * the file, so a default can never be out of range.  The file format is
 * "key = value" per line, '#' starts a comment, values may be quoted.
 * Unknown keys and bad values are reported as "file:line: message".
 * conf/gigaviewd.conf documents every key in place.
 */
#ifndef GV_SERVER_SETTINGS_H
#define GV_SERVER_SETTINGS_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define SETTINGS_STR 256
#define SETTINGS_PATH 1024

struct settings {
    char listen[SETTINGS_STR];       /* address to bind, "0.0.0.0", "::" */
    uint64_t port;
    char store_dir[SETTINGS_PATH];
    uint64_t threads;              /* libmicrohttpd thread pool size */
    uint64_t cache_bytes;          /* page cache bound */
    uint64_t decoder_cache_bytes;  /* the shared decoded-tile cache */
    uint64_t resident_bytes;       /* of it, the coarse levels kept */
    uint64_t max_region_pixels;    /* decoded pixels per region request */
    uint64_t max_mesh_samples;     /* height samples per mesh request */
    uint64_t max_mesh_triangles;   /* triangles per mesh */
    double mesh_time_limit;        /* seconds of meshing per request */
    double terrain_error_scale;    /* terrain tiles: times Cesium's level error */
    char terrain_water_below[SETTINGS_PATH]; /* "ID:HEIGHT ..." water masks */
    uint64_t simplify_max_bytes;   /* mesh upload to /v1/meshes/simplify */
    uint64_t simplify_max_faces;   /* its triangles, in and asked */
    double simplify_time_limit;    /* seconds of one job in its worker */
    uint64_t max_output_pixels;    /* IIIF maxArea */
    uint64_t max_output_side;      /* IIIF maxWidth = maxHeight */
    double max_upscale;            /* largest IIIF '^' factor */
    uint64_t connection_limit;
    double rate_limit;             /* requests a second per client, 0 off */
    double rate_limit_burst;       /* a client's bucket */
    char rate_limit_header[SETTINGS_STR]; /* the client's key from a proxy */
    uint64_t connection_timeout;   /* seconds idle before a close */
    uint64_t request_timeout;      /* seconds for a whole request to arrive */
    uint64_t max_url_bytes;        /* request target (414 beyond) */
    uint64_t max_header_bytes;     /* request head (431 beyond) */
    uint64_t max_query_args;       /* query arguments (400 beyond) */
    uint64_t drain_timeout;        /* seconds SIGTERM waits for requests */
    char cors_origin[SETTINGS_STR];  /* Access-Control-Allow-Origin, "" off */
    char auth_token[SETTINGS_STR];   /* bearer token for write endpoints */
    char public_url[SETTINGS_STR];   /* base URL for absolute links, "" auto */
    /* access control (access.h) */
    char access_policy[SETTINGS_PATH];            /* policy file, "" none */
    char access_token_secret_file[SETTINGS_PATH]; /* token secret, "" none */
    char access_trusted_header[SETTINGS_STR];     /* proxy's groups header */
    char access_origins[SETTINGS_PATH];           /* token service origins */
    uint64_t access_token_ttl;                    /* seconds of a minted token */
    char log_level[16];
    char access_log[SETTINGS_PATH];
    uint64_t batch_max_tiles;
    uint64_t max_request_bytes;    /* POST body cap (413 beyond) */
    uint64_t jpeg_quality;
    char gpu[8];                   /* "auto" (open EGL at start) or "off" */
    char gpu_platform[16];         /* "auto", "device", "surfaceless", "default" */
    /* filter graphs (docs/FILTERS.md sections 7 and 9) */
    uint64_t filter_workers;       /* worker processes; 0 disables filters */
    uint64_t filter_timeout_ms;    /* per job; the worker is killed past it */
    uint64_t filter_compile_timeout_ms; /* storing a graph: its compile job */
    uint64_t filter_start_timeout_ms; /* a new worker's hello */
    uint64_t filter_memory_limit;  /* RLIMIT_DATA of a worker; 0 none */
    uint64_t filter_max_jobs;      /* queued plus running; 503 beyond */
    uint64_t max_filter_pixels;    /* padded region of one filter request */
    char filter_worker[SETTINGS_PATH];      /* program; "" finds it */
    char filter_dir[SETTINGS_PATH];         /* stored graphs; "" none */
    char filter_library_dir[SETTINGS_PATH]; /* stock graphs; "" finds
                                               them (settings_resolve) */
    uint64_t filter_max_json_bytes;
    uint64_t filter_max_json_depth;
    uint64_t filter_max_modules;
    uint64_t filter_max_glsl_bytes;
    uint64_t filter_max_padding;
    /* IIIF and region rendering */
    uint64_t render_threads;       /* render pool threads */
    uint64_t render_queue;         /* renders waiting; 503 beyond */
    uint64_t output_cache_bytes;   /* encoded-output cache bound */
};

/* Fill *c with every default.  Cannot fail. */
void settings_defaults(struct settings *c);

/*
 * Read `path` over the current values of *c.  Returns 0, or -1 with *err
 * (GV_EINVAL, "FILE:LINE: message"; GV_ENOTFOUND/GV_EIO if unreadable).
 */
int settings_load(struct settings *c, const char *path, struct gv_error *err);

/* Set one key from a string (command-line overrides); `where` prefixes
 * messages.  Returns 0 or -1 with *err. */
int settings_set(struct settings *c, const char *key, const char *value,
               const char *where, struct gv_error *err);

/*
 * Fill in the values whose default depends on where gigaviewd runs, after
 * the file and the overrides: filter_library_dir "" becomes the source
 * tree's filters/library when this executable lies in the build directory
 * it was built in (a daemon run from its build tree, as scripts/demo.sh
 * and the tests do), else the installed $(pkgdatadir)/filters.  A value
 * set in the file is kept as it is.
 */
void settings_resolve(struct settings *c);

/*
 * The water height of image id in spec, a terrain_water_below value:
 * entries ID:HEIGHT separated by spaces, tabs or commas, ID an image id
 * or * (every image not named), HEIGHT a finite number (strtod).  Returns
 * 1 with *height, 0 when no entry applies, -1 when spec is malformed
 * (gigaviewd refuses such a configuration, so a loaded one never is).
 * Pure; any thread.
 */
int settings_water_below(const char *spec, const char *id, double *height);

/* Print every key with its default and help, as a sample file. */
void settings_print_sample(void);

#endif
