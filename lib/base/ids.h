/*
 * ids.h - the one rule for the names that travel between gigaview,
 * gigaviewd and the filter worker: image ids and filter ids.
 *
 * An image id is a store's file name without ".gv" (server/catalog.c),
 * a path segment of every route (/v1/images/{id}/...) and a name the
 * client puts into URLs (client/remote/http_fetch.c): 1..GV_IMAGE_ID_MAX
 * bytes of [A-Za-z0-9._-], not starting with '.' and without "..", so
 * that it can never name a hidden file or climb a directory.
 *
 * A filter id names a stock graph (filters/library/NAME.json, listed by
 * server/filter_store.c), a module of a graph document and a parameter
 * (filters/graph.c): 1..GV_FILTER_ID_LEN bytes of [A-Za-z0-9_-], no dot
 * at all.
 *
 * Both tests are ASCII ranges, not isalnum(), so that no locale can widen
 * them.  Pure functions, safe from any thread.
 */
#ifndef GV_BASE_IDS_H
#define GV_BASE_IDS_H

#include <stddef.h>

#define GV_IMAGE_ID_MAX 128   /* bytes of an image id, without the NUL */
#define GV_FILTER_ID_LEN 63   /* bytes of a filter id, without the NUL */

/* 1 if the n bytes at id are a well-formed image id, else 0. */
int gv_image_id_valid_n(const char *id, size_t n);

/* 1 if the NUL-terminated id is a well-formed image id, else 0. */
int gv_image_id_valid(const char *id);

/* 1 if the n bytes at id are a well-formed filter id (or module or
 * parameter name of a graph), else 0. */
int gv_filter_id_valid_n(const char *id, size_t n);

/* 1 if the NUL-terminated id is a well-formed filter id, else 0. */
int gv_filter_id_valid(const char *id);

#endif
