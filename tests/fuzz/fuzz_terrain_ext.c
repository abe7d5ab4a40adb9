/*
 * fuzz_terrain_ext.c - libFuzzer target for the quantized-mesh extension
 * lists of terrain tile requests (server/terrain_ext.c): the Accept
 * header and the extensions query value.
 *
 * The input up to its first newline is the Accept value, the rest the
 * query value (each cut at a NUL, as a header or a decoded query would
 * be).  Checked: only TERRAIN_EXT_* bits; the two values ask for the
 * union of what each asks alone; a value asks exactly what its first
 * TERRAIN_EXT_SCAN bytes ask (the bound); and a bit is set only when its
 * name occurs (in any case) within those bytes.  Anything else aborts.
 */
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "fuzz.h"
#include "terrain_ext.h"

#define MAX_INPUT (64u << 10)

/* Whether name occurs, in any case, in the first TERRAIN_EXT_SCAN bytes
 * of s. */
static int mentions(const char *s, const char *name)
{
    size_t n = strnlen(s, TERRAIN_EXT_SCAN), k = strlen(name);
    for (size_t i = 0; i + k <= n; i++)
        if (!strncasecmp(s + i, name, k))
            return 1;
    return 0;
}

static void check(const char *accept, const char *query)
{
    static const struct { const char *name; unsigned bit; } known[] = {
        {"octvertexnormals", TERRAIN_EXT_NORMALS},
        {"watermask", TERRAIN_EXT_WATERMASK},
        {"metadata", TERRAIN_EXT_METADATA},
    };
    unsigned both = terrain_extensions(accept, query);
    unsigned a = terrain_extensions(accept, NULL);
    unsigned q = terrain_extensions(NULL, query);
    if (both & ~(TERRAIN_EXT_NORMALS | TERRAIN_EXT_WATERMASK |
                 TERRAIN_EXT_METADATA) || both != (a | q))
        abort();
    if (terrain_extensions(NULL, NULL) != 0)
        abort();
    for (size_t k = 0; k < sizeof known / sizeof known[0]; k++) {
        if ((a & known[k].bit) && !mentions(accept, known[k].name))
            abort();
        if ((q & known[k].bit) && !mentions(query, known[k].name))
            abort();
    }
    /* the bound: only the first TERRAIN_EXT_SCAN bytes count */
    if (strlen(accept) > TERRAIN_EXT_SCAN) {
        char *cut = strndup(accept, TERRAIN_EXT_SCAN);
        if (!cut)
            abort();
        if (terrain_extensions(cut, NULL) != a)
            abort();
        free(cut);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > MAX_INPUT)
        return 0;
    char *buf = malloc(size + 2);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = buf[size + 1] = 0;
    char *nl = memchr(buf, '\n', size);
    const char *query = "";
    if (nl) {
        *nl = 0;
        query = nl + 1;
    }
    check(buf, query);
    free(buf);
    return 0;
}
