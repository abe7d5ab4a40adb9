/*
 * router.h - gigaviewd's route matching and path decoding: pure string
 * functions, no libmicrohttpd types, so that tests/fuzz/fuzz_router.c can
 * drive them directly.
 *
 * The table router_routes[] holds {method, pattern, name, iiif, image}
 * for every route, indexed by enum route_id; routes.c pairs each id with
 * its handler.  `image` says whether the route shows an image (its first
 * '*' segment is the image's id), so that http.c checks the access policy
 * (access_policy.h) before any such handler runs; it has no default, and
 * gigaviewd refuses to start when a row leaves it out.  A pattern is a path whose '*' segments match any one
 * non-empty segment and are captured in order; literal segments match
 * exactly; "/" matches only "/".  An empty segment ("//", a trailing '/')
 * never matches.  The first route whose pattern and method both match
 * wins.  A path that some pattern matches under other methods only is
 * "method not allowed", with the methods it does accept (GET counting for
 * HEAD too) listed for an Allow header.
 */
#ifndef GV_SERVER_ROUTER_H
#define GV_SERVER_ROUTER_H

#include <stddef.h>

#define ROUTER_MAX_PARAMS 8

enum route_id {
    ROUTE_HOME,
    ROUTE_HEALTHZ,
    ROUTE_METRICS,
    ROUTE_IMAGES,
    ROUTE_IMAGE,
    ROUTE_ROOT,
    ROUTE_TILE,
    ROUTE_BATCH_GET,
    ROUTE_BATCH_POST,
    ROUTE_REGION,
    ROUTE_IIIF_BASE,
    ROUTE_IIIF_INFO,
    ROUTE_IIIF_IMAGE,
    ROUTE_FILTERS,
    ROUTE_FILTERS_POST,
    ROUTE_FILTER,
    ROUTE_FILTER_DELETE,
    ROUTE_IMAGE_FILTER,
    ROUTE_MESH,
    ROUTE_TERRAIN_LAYER, /* route_terrain.c */
    ROUTE_TERRAIN_TILE,
    ROUTE_MESH_SIMPLIFY,   /* mesh simplification */
    ROUTE_WEB,
    ROUTE_AUTH_PROBE,    /* route_auth.c: IIIF Authorization Flow 2.0 */
    ROUTE_AUTH_LOGIN,
    ROUTE_AUTH_TOKEN,
    ROUTE_AUTH_LOGOUT,
    ROUTE_COUNT
};

/* What a route says about images (router_route.image). */
enum router_image {
    ROUTER_IMAGE_UNSET = 0, /* the row forgot to say: refused at start */
    ROUTER_NO_IMAGE,        /* the route shows no image */
    ROUTER_IMAGE,           /* param[0] is an image id: http.c answers 401
                               or 404 for it before the handler runs when
                               the caller may not see it */
    ROUTER_IMAGE_OWN,       /* param[0] is an image id whose access the
                               handler reports itself (the IIIF probe) */
};

struct router_route {
    const char *method;
    const char *pattern;
    const char *name;       /* the label in /metrics */
    int iiif;               /* errors and CORS as the IIIF spec wants */
    enum router_image image;
};

extern const struct router_route router_routes[ROUTE_COUNT];

enum router_result {
    ROUTER_MATCH = 0,       /* m->route is the route to run */
    ROUTER_NOT_FOUND,       /* no pattern matches the path */
    ROUTER_BAD_METHOD,      /* patterns match, not with this method: m->allow */
    ROUTER_NOMEM,           /* the parameters could not be stored */
};

struct router_match {
    int route;              /* enum route_id; -1 unless ROUTER_MATCH */
    int iiif;               /* the route's flag, or (no match) that of any
                               route whose pattern matched the path */
    int nparam;
    char *param[ROUTER_MAX_PARAMS]; /* the '*' segments, NUL-terminated */
    char *segbuf;           /* storage of param[]: router_match_free */
    char allow[64];         /* "GET, HEAD, POST" style; "" if none */
};

/* Match `path` (as sent: not percent-decoded, no query) with `method`
 * ("GET" for a HEAD request) against router_routes[].  The path is split
 * at its '/' before any decoding, so "%2F" stays inside its segment
 * ("/v1/images/a%2Froot" names image "a/root", not its root); literal
 * segments compare decoded, and the captured ones are decoded as
 * router_unescape does.  Always fills *m (route -1, no parameters, unless
 * ROUTER_MATCH); call router_match_free after. */
enum router_result router_find(const char *method, const char *path,
                               struct router_match *m);

void router_match_free(struct router_match *m);

/* Match one pattern against a raw path: the number of '*' segments
 * captured (pointers into path and their raw lengths in seg[]/len[], at
 * most max), or -1. */
int router_match_pattern(const char *pattern, const char *path,
                         const char **seg, size_t *len, int max);

/* Percent-decode s in place (the path and every query argument): "%XY"
 * with two hex digits becomes that byte, except "%00", which stays as it
 * is (a NUL would silently cut the string short, so "x%00.gv" would name
 * image "x"); invalid escapes stay as they are.  Returns the new length,
 * which is also strlen(s). */
size_t router_unescape(char *s);

#endif
