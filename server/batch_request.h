/*
 * batch_request.h - the two spellings of a batch request's tile list,
 * parsed without libmicrohttpd (route_tiles.c answers the request;
 * tests/fuzz/fuzz_batch.c fuzzes these parsers).
 *
 *   GET  ?t=L,X,Y;L,X,Y;...          batch_parse_query
 *   POST {"tiles": [[L, X, Y], ...]} batch_parse_json
 *
 * Both produce the same thing: an array of (level, tx, ty) triples, the
 * level a decimal in 0..BATCH_LEVEL_MAX (a frame holds it in one byte;
 * the single-tile route takes the same range), tx and ty in
 * 0..GV_MAX_DIM, at least one and at most `max`.
 * Whether a triple names a real tile is the caller's business (a batch
 * answers 404 per tile for those).  Pure functions: thread-safe.
 */
#ifndef GV_SERVER_BATCH_REQUEST_H
#define GV_SERVER_BATCH_REQUEST_H

#include <stddef.h>
#include <stdint.h>

#include "base/error.h"

#define BATCH_LEVEL_MAX 255u

struct batch_tile {
    uint32_t level, tx, ty;
};

/*
 * Parse the NUL-terminated query value `t` ("L,X,Y" triples separated by
 * ';', digits only).  On success returns 0 with *tiles (malloc'ed, the
 * caller frees it) holding *n triples, 1 <= *n <= max.  On failure
 * returns -1 with *tiles NULL, *n 0 and *err filled: GV_ELIMIT for more
 * than `max` triples, GV_ENOMEM, GV_EINVAL for anything malformed.
 */
int batch_parse_query(const char *t, size_t max, struct batch_tile **tiles,
                      size_t *n, struct gv_error *err);

/*
 * Parse a JSON body of `len` bytes ({"tiles": [[L, X, Y], ...]}; other
 * members are ignored, duplicate keys refused).  `body` need not be
 * NUL-terminated and may be NULL when len is 0.  Same results as
 * batch_parse_query; a JSON syntax error names its line and column.
 */
int batch_parse_json(const char *body, size_t len, size_t max,
                     struct batch_tile **tiles, size_t *n,
                     struct gv_error *err);

#endif
