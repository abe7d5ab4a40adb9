/*
 * route_home.c - GET /: a small HTML page listing the images, with links
 * to their metadata, IIIF info.json and a root preview.  The WebGL2 viewer
 * (client/web/) replaces it in a later step.  Ids are restricted to
 * [A-Za-z0-9._-] (catalog.h), so they need no HTML escaping.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "routes.h"

enum MHD_Result route_home(struct req *r)
{
    struct image **imgs;
    int n = catalog_list(r->srv->catalog, &imgs);
    if (n < 0)
        return http_send_errorf(r, GV_ENOMEM, "home: out of memory");
    size_t cap = 2048 + (size_t)n * 1024, len = 0;
    char *s = malloc(cap);
    if (!s) {
        for (int i = 0; i < n; i++)
            image_put(imgs[i]);
        free(imgs);
        return http_send_errorf(r, GV_ENOMEM, "home: out of memory");
    }
    len += (size_t)snprintf(s + len, cap - len,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        "<title>gigaview</title>"
        "<style>body{font-family:sans-serif;margin:2em}td,th{padding:.3em 1em;"
        "text-align:left}img{max-width:128px;max-height:128px}</style></head>"
        "<body><h1>gigaview</h1>\n<p>%d image%s. The WebGL2 viewer arrives in a "
        "later release; until then, use any IIIF viewer (OpenSeadragon, "
        "Leaflet-IIIF, Mirador) with the info.json links below, or the "
        "<a href=\"/v1/images\">JSON API</a>.</p>\n<table><tr><th>preview</th>"
        "<th>image</th><th>size</th><th>links</th></tr>\n", n, n == 1 ? "" : "s");
    for (int i = 0; i < n; i++) {
        const char *id = imgs[i]->id;
        const struct gv_geometry *g = &imgs[i]->info->geometry;
        len += (size_t)snprintf(s + len, cap - len,
            "<tr><td><img src=\"/v1/images/%s/root\" alt=\"\"></td><td>%s</td>"
            "<td>%u &times; %u</td><td><a href=\"/v1/images/%s\">metadata</a> "
            "&middot; <a href=\"/iiif/3/%s/info.json\">IIIF info.json</a> "
            "&middot; <a href=\"/iiif/3/%s/full/max/0/default.jpg\">IIIF full</a>"
            "</td></tr>\n", id, id, g->width, g->height, id, id, id);
        image_put(imgs[i]);
    }
    free(imgs);
    len += (size_t)snprintf(s + len, cap - len,
        "</table>\n<p><a href=\"/healthz\">health</a> &middot; "
        "<a href=\"/metrics\">metrics</a></p></body></html>\n");
    return http_send_owned(r, 200, "text/html; charset=utf-8", s, len);
}
