/*
 * fuzz_router.c - libFuzzer target for gigaviewd's router (server/router.c):
 * percent-decoding of the path and query arguments, and route matching.
 *
 * The input is a request line without the version: "METHOD TARGET"
 * (no space: the whole input is the target, method GET), cut at the
 * first NUL or newline, which an HTTP parser would never hand on, and at
 * 8 KiB.  TARGET splits at the first '?' into the path and the query, as
 * libmicrohttpd splits it; every query key and value is decoded with
 * router_unescape, as the daemon's unescape callback does, and the raw
 * path is routed with the method (HEAD as GET, as http.c does), then with
 * GET and POST as well (and its decoded copy is checked by
 * router_unescape's rules).  Every answer is checked against what the
 * table says:
 *  - router_unescape: the length it returns is strlen of the result, no
 *    longer than the input, and the result equals the input when that
 *    holds no '%';
 *  - a match names a route of that method, no earlier route of that
 *    method matches, the parameters are as many as the pattern's '*'
 *    segments, each non-empty, the path has as many segments as the
 *    pattern, and each raw segment, decoded, equals the pattern's literal
 *    or the parameter in its place (so "%2F" never splits a segment);
 *  - "not found": no pattern matches (router_match_pattern agrees);
 *  - "method not allowed": some pattern matches, none with this method,
 *    and the Allow list names every method that does match (GET with
 *    HEAD) and not this one.
 * Anything else aborts.
 */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "router.h"

#define MAX_TARGET 8192

static void check_unescape(char *s)
{
    size_t before = strlen(s);
    int has_pct = strchr(s, '%') != NULL;
    char copy[MAX_TARGET + 1];
    memcpy(copy, s, before + 1);
    size_t n = router_unescape(s);
    if (n != strlen(s) || n > before)
        abort();
    if (!has_pct && strcmp(s, copy))
        abort();
    /* "%00" is never decoded: a NUL cannot appear, so strlen above holds;
     * every "%00" of the input survives (its '%' cannot be a hex digit
     * of an escape before it), so their count cannot drop. */
    size_t zin = 0, zout = 0;
    for (const char *p = copy; (p = strstr(p, "%00")) != NULL; p++)
        zin++;
    for (const char *p = s; (p = strstr(p, "%00")) != NULL; p++)
        zout++;
    if (zout < zin)
        abort();
}

static int stars(const char *pattern)
{
    int n = 0;
    for (const char *p = pattern; *p; p++)
        if (*p == '*' && p > pattern && p[-1] == '/'
            && (p[1] == '/' || p[1] == '\0'))
            n++;
    return n;
}

/* Does the Allow list `allow` hold the token `name`? */
static int allows(const char *allow, const char *name)
{
    size_t k = strlen(name);
    if (k == 0)
        return 0;
    for (const char *s = allow; (s = strstr(s, name)) != NULL; s += k)
        if ((s == allow || s[-1] == ' ') && (s[k] == ',' || s[k] == '\0'))
            return 1;
    return 0;
}

static void check_route(const char *method, const char *path)
{
    struct router_match m;
    enum router_result res = router_find(method, path, &m);
    int any = 0;
    for (int i = 0; i < ROUTE_COUNT; i++) {
        const char *seg[ROUTER_MAX_PARAMS];
        size_t len[ROUTER_MAX_PARAMS];
        if (router_match_pattern(router_routes[i].pattern, path, seg, len,
                                 ROUTER_MAX_PARAMS) >= 0) {
            any = 1;
            if (res == ROUTER_BAD_METHOD) {
                if (!strcmp(router_routes[i].method, method))
                    abort();
                if (!allows(m.allow, router_routes[i].method))
                    abort();
                if (!strcmp(router_routes[i].method, "GET")
                    && !allows(m.allow, "HEAD"))
                    abort();
            }
            if (res == ROUTER_MATCH && i < m.route
                && !strcmp(router_routes[i].method, method))
                abort(); /* an earlier route should have won */
        }
    }
    switch (res) {
    case ROUTER_MATCH: {
        if (m.route < 0 || m.route >= ROUTE_COUNT)
            abort();
        const struct router_route *rt = &router_routes[m.route];
        if (strcmp(rt->method, method) || m.iiif != rt->iiif || m.allow[0])
            abort();
        if (m.nparam != stars(rt->pattern) || (m.nparam && !m.segbuf))
            abort();
        /* Walk the pattern's and the path's segments side by side. */
        if (!strcmp(rt->pattern, "/")) {
            if (strcmp(path, "/") || m.nparam)
                abort();
            break;
        }
        const char *p = rt->pattern, *u = path;
        int k = 0;
        while (*p || *u) {
            if (*p != '/' || *u != '/')
                abort();
            p++;
            u++;
            size_t pl = strcspn(p, "/"), ul = strcspn(u, "/");
            char seg[MAX_TARGET + 1];
            memcpy(seg, u, ul);
            seg[ul] = '\0';
            router_unescape(seg);
            const char *want = (pl == 1 && *p == '*') ? m.param[k++] : NULL;
            if (want ? (!want[0] || strcmp(seg, want))
                     : (strlen(seg) != pl || memcmp(seg, p, pl)))
                abort();
            p += pl;
            u += ul;
        }
        if (k != m.nparam)
            abort();
        break;
    }
    case ROUTER_NOT_FOUND:
        if (any || m.route != -1 || m.nparam || m.segbuf || m.allow[0])
            abort();
        break;
    case ROUTER_BAD_METHOD:
        if (!any || m.route != -1 || m.nparam || m.segbuf || !m.allow[0]
            || allows(m.allow, method))
            abort();
        break;
    case ROUTER_NOMEM:
        break; /* only under a malloc limit */
    default:
        abort();
    }
    router_match_free(&m);
    if (m.segbuf || m.nparam)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char buf[MAX_TARGET + 1];
    size_t n = 0;
    while (n < size && n < MAX_TARGET && data[n] != '\0' && data[n] != '\n')
        n++;
    memcpy(buf, data, n);
    buf[n] = '\0';

    char method[32] = "GET";
    char *target = buf;
    char *sp = strchr(buf, ' ');
    if (sp && (size_t)(sp - buf) < sizeof method) {
        memcpy(method, buf, (size_t)(sp - buf));
        method[sp - buf] = '\0';
        target = sp + 1;
    }
    if (!strcmp(method, "HEAD"))
        strcpy(method, "GET");

    char *query = strchr(target, '?');
    if (query)
        *query++ = '\0';
    check_route(method, target);
    check_route("GET", target);
    check_route("POST", target);
    check_unescape(target);
    while (query && *query) {
        char *amp = strchr(query, '&');
        if (amp)
            *amp = '\0';
        char *eq = strchr(query, '=');
        if (eq) {
            *eq = '\0';
            check_unescape(eq + 1);
        }
        check_unescape(query);
        query = amp ? amp + 1 : NULL;
    }
    return 0;
}
