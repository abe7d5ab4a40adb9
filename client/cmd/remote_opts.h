/*
 * remote_opts.h - the options of every command that talks to a
 * gigaviewd (gigaview render, gigaview view), declared once.
 *
 * A remote command keeps a `struct remote_opts` in its argument struct
 * and puts the rows below into its option table (options.h) at the place
 * its help lists them, passing the offset of that member; opt_parse then
 * parses --timeout, --cache-dir, --no-cache and --gpu-cache with one
 * range, one default and one message for every such command.  A new
 * option that any command with a server URL should take goes here; an
 * option of one command only goes into that command's table
 * (docs/ARCHITECTURE.md, "client/").  `gigaview info URL` takes
 * --timeout alone.
 */
#ifndef GV_REMOTE_OPTS_H
#define GV_REMOTE_OPTS_H

#include <stddef.h>

#include "options.h"

/* Seconds each HTTP request may take.  A limit, not a wait: a working
 * server answers well within it, and quitting the viewer never waits for
 * it (the transfers are dropped). */
#define REMOTE_TIMEOUT_DEFAULT 30
/* MiB of GPU memory for decoded tiles: 256 holds ~190 tiles with their
 * mips (1.3 MB each), two screens at 4K; 16 still holds a tile with its
 * ancestors down from the root; 65536 is past any GPU of today. */
#define REMOTE_GPU_MIB_DEFAULT 256
#define REMOTE_GPU_MIB_MIN 16
#define REMOTE_GPU_MIB_MAX 65536

struct remote_opts {
    const char *cache_dir;   /* --cache-dir, NULL: the default folder */
    int no_cache;            /* --no-cache */
    double timeout;          /* --timeout, seconds */
    double gpu_mib;          /* --gpu-cache, MiB */
};

#define REMOTE_F_(base, field) ((base) + offsetof(struct remote_opts, field))

/* --timeout SEC (-t).  base: offsetof the command's struct remote_opts. */
#define REMOTE_OPT_TIMEOUT(base)                                              \
    {.name = "timeout", .short_name = 't', .kind = OPT_DOUBLE, .arg = "SEC", \
     .field = REMOTE_F_(base, timeout), .min = 0, .max = 86400,              \
     .flags = OPT_FINITE | OPT_MIN_OPEN,                                      \
     .help = "limit for each HTTP request (default "                         \
             OPT_STR(REMOTE_TIMEOUT_DEFAULT) ")"}

/* --cache-dir DIR and --no-cache, two rows. */
#define REMOTE_OPT_CACHE(base)                                                \
    {.name = "cache-dir", .kind = OPT_STRING, .arg = "DIR",                   \
     .field = REMOTE_F_(base, cache_dir),                                     \
     .help = "tile cache (default $XDG_CACHE_HOME/gigaview\n"                 \
             "or ~/.cache/gigaview)"},                                        \
    {.name = "no-cache", .kind = OPT_FLAG, .field = REMOTE_F_(base, no_cache), \
     .help = "do not use the tile cache"}

/* --gpu-cache MIB. */
#define REMOTE_OPT_GPU_CACHE(base)                                            \
    {.name = "gpu-cache", .kind = OPT_DOUBLE, .arg = "MIB",                   \
     .field = REMOTE_F_(base, gpu_mib), .min = REMOTE_GPU_MIB_MIN,            \
     .max = REMOTE_GPU_MIB_MAX, .flags = OPT_FINITE,                          \
     .help = "GPU memory for decoded tiles (default "                         \
             OPT_STR(REMOTE_GPU_MIB_DEFAULT) ")"}

/* Set r to the defaults above; call before opt_parse. */
void remote_opts_init(struct remote_opts *r);

/* --timeout in milliseconds, as gv_http_new takes it. */
long remote_timeout_ms(const struct remote_opts *r);

/* --gpu-cache in bytes. */
size_t remote_gpu_bytes(const struct remote_opts *r);

#endif
