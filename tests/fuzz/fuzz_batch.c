/*
 * fuzz_batch.c - libFuzzer target for the batch request parsers
 * (server/batch_request.c): the GET query value "L,X,Y;..." and the POST
 * body {"tiles": [[L, X, Y], ...]}.
 *
 * Byte 0 picks the parser (bit 0: 1 JSON, 0 query) and the tile limit
 * (max = 1 + (byte >> 1), 1..128, so both sides of batch_max_tiles get
 * reached); the rest is the query value (cut at the first NUL, as a C
 * string from libmicrohttpd would be) or the body (as is).  Checked:
 *  - success: 1 <= n <= max, every level <= BATCH_LEVEL_MAX and every
 *    tx, ty <= GV_MAX_DIM; a query holds
 *    only digits, ',' and ';'; printing the triples back in the same
 *    form and parsing that again gives the same triples;
 *  - failure: no array, n = 0, a message, and a code the HTTP error
 *    table maps to 400, 413 or 503 (EINVAL, ELIMIT, ENOMEM); ELIMIT only
 *    when the input names more than max triples.
 * Anything else aborts.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "batch_request.h"
#include "fuzz.h"
#include "store/geometry.h"

#define MAX_INPUT (64u << 10) /* far above any useful request; keeps it fast */

/* Print tiles in the form `json` selects; malloc'ed. */
static char *print(const struct batch_tile *t, size_t n, int json)
{
    size_t cap = 32 + n * 40; /* 3 numbers of <= 10 digits + punctuation */
    char *s = malloc(cap);
    if (!s)
        abort();
    size_t len = 0;
    if (json)
        len += (size_t)snprintf(s + len, cap - len, "{\"tiles\":[");
    for (size_t i = 0; i < n; i++)
        len += (size_t)snprintf(s + len, cap - len,
                                json ? "%s[%u,%u,%u]" : "%s%u,%u,%u",
                                i ? (json ? "," : ";") : "", t[i].level,
                                t[i].tx, t[i].ty);
    if (json)
        len += (size_t)snprintf(s + len, cap - len, "]}");
    if (len >= cap)
        abort();
    return s;
}

static int parse(const char *s, size_t len, int json, size_t max,
                 struct batch_tile **t, size_t *n, struct gv_error *err)
{
    return json ? batch_parse_json(s, len, max, t, n, err)
                : batch_parse_query(s, max, t, n, err);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > MAX_INPUT)
        return 0;
    int json = data[0] & 1;
    size_t max = 1 + (size_t)(data[0] >> 1);
    size_t len = size - 1;
    char *in = malloc(len + 1);
    if (!in)
        return 0;
    memcpy(in, data + 1, len);
    in[len] = '\0';
    if (!json)
        len = strlen(in);

    struct batch_tile *t = (struct batch_tile *)1; /* must be overwritten */
    size_t n = 12345;
    struct gv_error err = {0};
    gv_error_clear(&err);
    if (parse(in, len, json, max, &t, &n, &err) < 0) {
        if (t || n || !err.text[0])
            abort();
        if (err.code != GV_EINVAL && err.code != GV_ELIMIT && err.code != GV_ENOMEM)
            abort();
        if (err.code == GV_ELIMIT && !json) {
            size_t semis = 0;
            for (const char *p = in; *p; p++)
                semis += *p == ';';
            if (semis + 1 <= max)
                abort();
        }
        free(in);
        return 0;
    }
    if (!t || n < 1 || n > max)
        abort();
    for (size_t i = 0; i < n; i++)
        if (t[i].level > BATCH_LEVEL_MAX || t[i].tx > GV_MAX_DIM || t[i].ty > GV_MAX_DIM)
            abort();
    if (!json && in[strspn(in, "0123456789,;")] != '\0')
        abort();
    /* Round trip. */
    char *again = print(t, n, json);
    struct batch_tile *t2 = NULL;
    size_t n2 = 0;
    if (parse(again, strlen(again), json, max, &t2, &n2, &err) < 0 || n2 != n ||
        memcmp(t, t2, n * sizeof *t))
        abort();
    free(t2);
    free(again);
    free(t);
    free(in);
    return 0;
}
