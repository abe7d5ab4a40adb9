/*
 * router.c - the route table and the path matcher (see router.h).
 * Order matters only between patterns of the same shape: the first match
 * wins.
 */
#include <stdlib.h>
#include <string.h>

#include "router.h"

const struct router_route router_routes[ROUTE_COUNT] = {
    [ROUTE_HOME] = {"GET", "/", "home", 0, ROUTER_NO_IMAGE},
    [ROUTE_HEALTHZ] = {"GET", "/healthz", "healthz", 0, ROUTER_NO_IMAGE},
    [ROUTE_METRICS] = {"GET", "/metrics", "metrics", 0, ROUTER_NO_IMAGE},
    [ROUTE_IMAGES] = {"GET", "/v1/images", "images", 0, ROUTER_NO_IMAGE},
    [ROUTE_IMAGE] = {"GET", "/v1/images/*", "image", 0, ROUTER_IMAGE},
    [ROUTE_ROOT] = {"GET", "/v1/images/*/root", "root", 0, ROUTER_IMAGE},
    [ROUTE_TILE] = {"GET", "/v1/images/*/tiles/*/*/*", "tile", 0, ROUTER_IMAGE},
    [ROUTE_BATCH_GET] = {"GET", "/v1/images/*/batch", "batch", 0, ROUTER_IMAGE},
    [ROUTE_BATCH_POST] = {"POST", "/v1/images/*/batch", "batch", 0, ROUTER_IMAGE},
    [ROUTE_REGION] = {"GET", "/v1/images/*/region", "region", 0, ROUTER_IMAGE},
    [ROUTE_IIIF_BASE] = {"GET", "/iiif/3/*", "iiif_base", 1, ROUTER_IMAGE},
    [ROUTE_IIIF_INFO] = {"GET", "/iiif/3/*/info.json", "iiif_info", 1, ROUTER_IMAGE},
    [ROUTE_IIIF_IMAGE] = {"GET", "/iiif/3/*/*/*/*/*", "iiif_image", 1, ROUTER_IMAGE},
    [ROUTE_FILTERS] = {"GET", "/v1/filters", "filters", 0, ROUTER_NO_IMAGE},
    [ROUTE_FILTERS_POST] = {"POST", "/v1/filters", "filters", 0, ROUTER_NO_IMAGE},
    [ROUTE_FILTER] = {"GET", "/v1/filters/*", "filter", 0, ROUTER_NO_IMAGE},
    [ROUTE_FILTER_DELETE] = {"DELETE", "/v1/filters/*", "filter", 0, ROUTER_NO_IMAGE},
    [ROUTE_IMAGE_FILTER] = {"POST", "/v1/images/*/filter", "image_filter", 0, ROUTER_IMAGE},
    [ROUTE_MESH] = {"GET", "/v1/images/*/mesh", "mesh", 0, ROUTER_IMAGE},
    [ROUTE_TERRAIN_LAYER] = {"GET", "/v1/images/*/terrain/layer.json",
                             "terrain_layer", 0, ROUTER_IMAGE},
    [ROUTE_TERRAIN_TILE] = {"GET", "/v1/images/*/terrain/*/*/*", "terrain", 0, ROUTER_IMAGE},
    [ROUTE_MESH_SIMPLIFY] = {"POST", "/v1/meshes/simplify", "mesh_simplify", 0, ROUTER_NO_IMAGE},
    [ROUTE_WEB] = {"GET", "/web/*", "web", 0, ROUTER_NO_IMAGE},
    [ROUTE_AUTH_PROBE] = {"GET", "/iiif/auth/probe/*", "auth_probe", 1,
                          ROUTER_IMAGE_OWN},
    [ROUTE_AUTH_LOGIN] = {"GET", "/iiif/auth/login", "auth_login", 0,
                          ROUTER_NO_IMAGE},
    [ROUTE_AUTH_TOKEN] = {"GET", "/iiif/auth/token", "auth_token", 0,
                          ROUTER_NO_IMAGE},
    [ROUTE_AUTH_LOGOUT] = {"GET", "/iiif/auth/logout", "auth_logout", 0,
                           ROUTER_NO_IMAGE},
};

/* Same shape as b64val in access_token.c: deliberately separate, hex digits
 * here, base64url there. */
static int hexval(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/* Decode the escape at s[0..2] ("%XY", not "%00") into *c: 3, or 0 when
 * s holds no such escape. */
static int escape_at(const char *s, size_t n, char *c)
{
    int hi, lo;
    if (n < 3 || s[0] != '%' || (hi = hexval(s[1])) < 0 ||
        (lo = hexval(s[2])) < 0 || (hi | lo) == 0)
        return 0;
    *c = (char)(hi << 4 | lo);
    return 3;
}

/* Does raw segment u[0..ul-1], decoded, equal literal p[0..pl-1]? */
static int segment_is(const char *u, size_t ul, const char *p, size_t pl)
{
    size_t i = 0, k = 0;
    while (i < ul && k < pl) {
        char c = u[i];
        int step = escape_at(u + i, ul - i, &c);
        if (c != p[k++])
            return 0;
        i += step ? (size_t)step : 1;
    }
    return i == ul && k == pl;
}

/* Decode raw segment u[0..ul-1] into o (room for ul + 1): its length. */
static size_t decode_segment(const char *u, size_t ul, char *o)
{
    size_t n = 0;
    for (size_t i = 0; i < ul;) {
        char c = u[i];
        int step = escape_at(u + i, ul - i, &c);
        o[n++] = c;
        i += step ? (size_t)step : 1;
    }
    o[n] = '\0';
    return n;
}

int router_match_pattern(const char *pattern, const char *path,
                         const char **seg, size_t *len, int max)
{
    const char *p = pattern, *u = path;
    int np = 0;
    if (!strcmp(pattern, "/"))
        return strcmp(path, "/") ? -1 : 0;
    while (*p && *u) {
        if (*p != '/' || *u != '/')
            return -1;
        p++;
        u++;
        const char *pe = strchr(p, '/'), *ue = strchr(u, '/');
        size_t pl = pe ? (size_t)(pe - p) : strlen(p);
        size_t ul = ue ? (size_t)(ue - u) : strlen(u);
        if (ul == 0)
            return -1;
        if (pl == 1 && *p == '*') {
            if (np == max)
                return -1;
            seg[np] = u;
            len[np++] = ul;
        } else if (!segment_is(u, ul, p, pl)) {
            return -1;
        }
        p += pl;
        u += ul;
    }
    return *p || *u ? -1 : np;
}

/* Append ", name" (or "name") to allow if it fits and is not there. */
static void allow_add(char *allow, size_t size, const char *name)
{
    size_t n = strlen(allow), k = strlen(name);
    for (const char *s = allow; (s = strstr(s, name)) != NULL; s += k)
        if ((s == allow || s[-1] == ' ') && (s[k] == ',' || s[k] == '\0'))
            return;
    if (n + (n ? 2 : 0) + k + 1 > size)
        return;
    if (n) {
        memcpy(allow + n, ", ", 2);
        n += 2;
    }
    memcpy(allow + n, name, k + 1);
}

enum router_result router_find(const char *method, const char *path,
                               struct router_match *m)
{
    memset(m, 0, sizeof *m);
    m->route = -1;
    int found = 0;
    for (int i = 0; i < ROUTE_COUNT; i++) {
        const struct router_route *rt = &router_routes[i];
        const char *seg[ROUTER_MAX_PARAMS];
        size_t len[ROUTER_MAX_PARAMS];
        int np = router_match_pattern(rt->pattern, path, seg, len,
                                      ROUTER_MAX_PARAMS);
        if (np < 0)
            continue;
        found = 1;
        m->iiif |= rt->iiif;
        if (strcmp(method, rt->method)) {
            allow_add(m->allow, sizeof m->allow, rt->method);
            if (!strcmp(rt->method, "GET"))
                allow_add(m->allow, sizeof m->allow, "HEAD");
            continue;
        }
        size_t total = 1;
        for (int k = 0; k < np; k++)
            total += len[k] + 1;
        m->segbuf = malloc(total);
        if (!m->segbuf)
            return ROUTER_NOMEM;
        char *o = m->segbuf;
        for (int k = 0; k < np; k++) {
            m->param[k] = o;
            o += decode_segment(seg[k], len[k], o) + 1;
        }
        m->nparam = np;
        m->route = i;
        m->iiif = rt->iiif;
        m->allow[0] = '\0';
        return ROUTER_MATCH;
    }
    return found ? ROUTER_BAD_METHOD : ROUTER_NOT_FOUND;
}

void router_match_free(struct router_match *m)
{
    free(m->segbuf);
    m->segbuf = NULL;
    m->nparam = 0;
}

size_t router_unescape(char *s)
{
    return decode_segment(s, strlen(s), s);
}
