/*
 * batch_request.c - parsing a batch request's tile list (see
 * batch_request.h).
 *
 * The query form is scanned twice: once to count the ';' separators, so
 * that more than `max` triples are refused before anything is allocated,
 * then to fill the array.  A number is a run of decimal digits, compared
 * against GV_MAX_DIM as it is accumulated, so no input can overflow it.
 * The JSON form goes through jansson with duplicate keys refused; jansson
 * bounds its own nesting depth (2048), and the HTTP layer bounds the
 * body's size (max_request_bytes).
 */
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "batch_request.h"
#include "store/geometry.h"

#define SYNTAX "batch: t must be L,X,Y triples separated by ';'"

/* Read a decimal number at *p (advancing it) into *out.  Returns 0, or -1
 * when there is no digit or the value exceeds GV_MAX_DIM (checked digit
 * by digit, so the 64-bit accumulator cannot overflow however long the
 * run of digits). */
static int number(const char **p, uint32_t max, uint32_t *out,
                  struct gv_error *err)
{
    const char *s = *p;
    if (*s < '0' || *s > '9')
        return gv_fail(err, GV_EINVAL, SYNTAX);
    uint64_t v = 0;
    for (; *s >= '0' && *s <= '9'; s++) {
        v = v * 10 + (uint64_t)(*s - '0');
        if (v > max)
            return gv_fail(err, GV_EINVAL, "batch: number out of range (a "
                           "level is 0..%u, tx and ty 0..%u)",
                           BATCH_LEVEL_MAX, GV_MAX_DIM);
    }
    *out = (uint32_t)v;
    *p = s;
    return 0;
}

static int fail_free(struct batch_tile **tiles, size_t *n)
{
    free(*tiles);
    *tiles = NULL;
    *n = 0;
    return -1;
}

int batch_parse_query(const char *t, size_t max, struct batch_tile **tiles,
                      size_t *n, struct gv_error *err)
{
    *tiles = NULL;
    *n = 0;
    size_t cap = 1;
    for (const char *p = t; *p; p++)
        cap += *p == ';';
    if (cap > max)
        return gv_fail(err, GV_ELIMIT, "batch: %zu tiles, at most %zu", cap, max);
    *tiles = calloc(cap, sizeof **tiles);
    if (!*tiles)
        return gv_fail(err, GV_ENOMEM, "batch: out of memory");
    const char *p = t;
    while (*p) {
        /* Each triple after the first follows a ';', so *n < cap here. */
        struct batch_tile *b = &(*tiles)[*n];
        if (number(&p, BATCH_LEVEL_MAX, &b->level, err) < 0)
            goto bad;
        if (*p++ != ',')
            goto syntax;
        if (number(&p, GV_MAX_DIM, &b->tx, err) < 0)
            goto bad;
        if (*p++ != ',')
            goto syntax;
        if (number(&p, GV_MAX_DIM, &b->ty, err) < 0)
            goto bad;
        (*n)++;
        if (*p == ';' && p[1])
            p++;
        else if (*p)
            goto syntax;
    }
    if (*n == 0) {
        gv_fail(err, GV_EINVAL, "batch: no tiles asked for");
        goto bad;
    }
    return 0;
syntax:
    gv_fail(err, GV_EINVAL, SYNTAX);
bad:
    return fail_free(tiles, n);
}

int batch_parse_json(const char *body, size_t len, size_t max,
                     struct batch_tile **tiles, size_t *n,
                     struct gv_error *err)
{
    *tiles = NULL;
    *n = 0;
    json_error_t je;
    json_t *root = json_loadb(body ? body : "", body ? len : 0,
                              JSON_REJECT_DUPLICATES, &je);
    if (!root)
        return gv_fail(err, GV_EINVAL, "batch: bad JSON at line %d, column %d: %s",
                       je.line, je.column, je.text);
    int rc = 0;
    json_t *list = json_object_get(root, "tiles");
    if (!json_is_array(list) || json_array_size(list) == 0) {
        rc = gv_fail(err, GV_EINVAL,
                     "batch: body must be {\"tiles\": [[level, tx, ty], ...]}");
        goto out;
    }
    size_t count = json_array_size(list);
    if (count > max) {
        rc = gv_fail(err, GV_ELIMIT, "batch: %zu tiles, at most %zu", count, max);
        goto out;
    }
    *tiles = calloc(count, sizeof **tiles);
    if (!*tiles) {
        rc = gv_fail(err, GV_ENOMEM, "batch: out of memory");
        goto out;
    }
    for (size_t i = 0; i < count; i++) {
        json_t *t = json_array_get(list, i);
        if (!json_is_array(t) || json_array_size(t) != 3) {
            rc = gv_fail(err, GV_EINVAL, "batch: tiles[%zu] is not [level, tx, ty]", i);
            goto out;
        }
        uint32_t v[3];
        for (size_t k = 0; k < 3; k++) {
            json_t *e = json_array_get(t, k);
            json_int_t top = k ? (json_int_t)GV_MAX_DIM : BATCH_LEVEL_MAX;
            if (!json_is_integer(e) || json_integer_value(e) < 0 ||
                json_integer_value(e) > top) {
                rc = gv_fail(err, GV_EINVAL,
                             "batch: tiles[%zu][%zu] is not a non-negative integer "
                             "in range", i, k);
                goto out;
            }
            v[k] = (uint32_t)json_integer_value(e);
        }
        (*tiles)[i] = (struct batch_tile){v[0], v[1], v[2]};
    }
    *n = count;
out:
    json_decref(root);
    if (rc < 0)
        fail_free(tiles, n);
    return rc;
}
