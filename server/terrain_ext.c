/*
 * terrain_ext.c - the quantized-mesh extensions a request asks for (see
 * terrain_ext.h).
 *
 * One pass over at most TERRAIN_EXT_SCAN bytes of each value: the Accept
 * header is split into media ranges at ',', a range counts when its type
 * is application/vnd.quantized-mesh (any case), and its parameters are
 * split at ';'; the extensions parameter's value (quotes allowed) and the
 * query value are lists of names joined by '-'.  No allocation.
 */
#include <string.h>
#include <strings.h>

#include "terrain_ext.h"

#define QM_TYPE "application/vnd.quantized-mesh"

/* The bits of the '-'-joined names in s[0 .. n-1]. */
static unsigned names(const char *s, size_t n)
{
    static const struct { const char *name; unsigned bit; } known[] = {
        {"octvertexnormals", TERRAIN_EXT_NORMALS},
        {"watermask", TERRAIN_EXT_WATERMASK},
        {"metadata", TERRAIN_EXT_METADATA},
    };
    unsigned bits = 0;
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && s[j] != '-')
            j++;
        for (size_t k = 0; k < sizeof known / sizeof known[0]; k++)
            if (j - i == strlen(known[k].name) &&
                !strncasecmp(s + i, known[k].name, j - i))
                bits |= known[k].bit;
        i = j + 1;
    }
    return bits;
}

static int space(char c)
{
    return c == ' ' || c == '\t';
}

/* The bits named by the media range r[0 .. n-1] of an Accept value. */
static unsigned media_range(const char *r, size_t n)
{
    size_t i = 0, tl = strlen(QM_TYPE);
    while (i < n && space(r[i]))
        i++;
    if (n - i < tl || strncasecmp(r + i, QM_TYPE, tl))
        return 0;
    i += tl;
    while (i < n && space(r[i]))
        i++;
    if (i < n && r[i] != ';')
        return 0; /* another type that begins alike */
    unsigned bits = 0;
    while (i < n) { /* at a ';' */
        size_t p = ++i;
        while (i < n && r[i] != ';')
            i++;
        while (p < i && space(r[p]))
            p++;
        size_t e = i;
        while (e > p && space(r[e - 1]))
            e--;
        if (e - p < 11 || strncasecmp(r + p, "extensions=", 11))
            continue;
        p += 11;
        if (e - p >= 2 && r[p] == '"' && r[e - 1] == '"') {
            p++;
            e--;
        }
        bits |= names(r + p, e - p);
    }
    return bits;
}

unsigned terrain_extensions(const char *accept, const char *query)
{
    unsigned bits = 0;
    if (query)
        bits |= names(query, strnlen(query, TERRAIN_EXT_SCAN));
    if (accept) {
        size_t n = strnlen(accept, TERRAIN_EXT_SCAN);
        for (size_t i = 0; i < n;) {
            const char *c = memchr(accept + i, ',', n - i);
            size_t j = c ? (size_t)(c - accept) : n;
            bits |= media_range(accept + i, j - i);
            i = j + 1;
        }
    }
    return bits;
}
