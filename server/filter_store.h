/*
 * filter_store.h - the filter graphs gigaviewd knows by id: the stock
 * library (filter_library_dir, read-only) and the graphs users stored
 * with POST /v1/filters (filter_dir).
 *
 * Stock graphs are the library's *.json files; a graph's id is its file
 * name without ".json" ([A-Za-z0-9_-], 1-63 bytes).  A stored graph's id
 * is "user-" and 16 hex digits of a 64-bit FNV-1a hash of its document,
 * so storing the same document twice gives the same id, and its file is
 * filter_dir/ID.json, written atomically (a temporary file, fsync,
 * rename, fsync of the directory).  Every graph is parsed with the
 * configured limits when it is loaded; files that fail are logged and
 * skipped.  The list is kept in memory and reloaded by filter_store_scan
 * (start-up and SIGHUP).
 *
 * Every function is thread-safe.
 */
#ifndef GV_SERVER_FILTER_STORE_H
#define GV_SERVER_FILTER_STORE_H

#include <stddef.h>

#include <jansson.h>

#include "base/error.h"
#include "filter.h"

struct filter_store;

/*
 * A store over library_dir (may be "" for none) and filter_dir ("":
 * storing disabled; created with mode 0700 by the first store when
 * missing), parsing graphs with lim (copied).  Scans both.  Returns NULL
 * only on allocation failure.
 */
struct filter_store *filter_store_new(const char *library_dir,
                                      const char *filter_dir,
                                      const struct gv_filter_limits *lim);

/* Free.  NULL does nothing. */
void filter_store_free(struct filter_store *fs);

/* Reload both directories.  Returns the number of graphs. */
int filter_store_scan(struct filter_store *fs);

/* 1 if graphs can be stored; else 0 with the reason in buf. */
int filter_store_writable(struct filter_store *fs, char *buf, size_t size);

/*
 * {"filters": [{"id", "name", "description", "stock", "output_channels",
 * "params": [{"module", "name", "min", "max", "default"}]}]}, stock
 * graphs first, each group sorted by id.  New reference or NULL.
 */
json_t *filter_store_list(struct filter_store *fs);

/* A malloc'ed, NUL-terminated copy of graph id's document (*len bytes)
 * and whether it is stock.  Returns 0, or -1 with GV_ENOTFOUND /
 * GV_ENOMEM. */
int filter_store_get(struct filter_store *fs, const char *id, char **doc,
                     size_t *len, int *stock, struct gv_error *err);

/*
 * Store a document (already validated by the caller, parsed again here).
 * Fills id (GV_FILTER_ID_MAX bytes) and *created (0 when the same
 * document was stored before).  Returns 0, or -1 with *err: GV_EINVAL
 * (does not parse; another document has this id), GV_ENOSPC, GV_EIO.
 */
int filter_store_put(struct filter_store *fs, const char *doc, size_t len,
                     char *id, int *created, struct gv_error *err);

/*
 * Delete stored graph id.  Returns 0; -1 with GV_ENOTFOUND, GV_EIO; or 1
 * if id is a stock graph (not deletable).
 */
int filter_store_delete(struct filter_store *fs, const char *id,
                        struct gv_error *err);

#endif
