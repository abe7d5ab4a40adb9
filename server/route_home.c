/*
 * route_home.c - GET /: the browser viewer (client/web/index.html,
 * embedded by client/web/embed.sh) with the list of images filled in on
 * the server, so the list shows even before (or without) JavaScript.
 * Each entry links the viewer (#image=ID), the metadata and the IIIF
 * info.json.  Ids are restricted to [A-Za-z0-9._-] (catalog.h), so they
 * need no HTML or URL escaping.  The page is built per request (the
 * catalog changes on SIGHUP) and sent with "Cache-Control: no-cache" and
 * the viewer's Content-Security-Policy.  Images hidden from the caller
 * by the access policy are left out.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "routes.h"
#include "web_assets.h"

#define MARK "<!--gv:images-->"   /* where index.html takes the list */

enum MHD_Result route_home(struct req *r)
{
    const struct web_asset *page = web_asset_find("index.html");
    if (!page)
        return http_send_errorf(r, GV_EIO, "home: the viewer was not built in");
    const char *text = (const char *)page->data;
    const char *mark = strstr(text, MARK);
    size_t head = mark ? (size_t)(mark - text) : page->len;
    size_t tail_at = mark ? head + strlen(MARK) : page->len;

    struct image **imgs;
    int n = catalog_list(r->srv->catalog, &imgs);
    if (n < 0)
        return http_send_errorf(r, GV_ENOMEM, "home: out of memory");
    /* One entry: four ids of at most 128 bytes, two numbers, markup;
     * 512 for the empty-list message. */
    size_t cap = page->len + 512 + (size_t)n * 1024, len = 0;
    char *s = malloc(cap);
    if (!s) {
        for (int i = 0; i < n; i++)
            image_put(imgs[i]);
        free(imgs);
        return http_send_errorf(r, GV_ENOMEM, "home: out of memory");
    }
    memcpy(s, text, head);
    len = head;
    if (n == 0)
        len += (size_t)snprintf(s + len, cap - len,
            "<li class=\"dim\">No images yet: encode one with <code>gigaview "
            "encode</code> into the store directory and send gigaviewd a "
            "SIGHUP.</li>");
    if (http_policy(r))
        r->private_answer = 1;
    for (int i = 0; i < n; i++) {
        const char *id = imgs[i]->id;
        if (http_access(r, id) == ACCESS_HIDDEN) { /* as if absent */
            image_put(imgs[i]);
            continue;
        }
        const struct gv_geometry *g = &imgs[i]->info->geometry;
        len += (size_t)snprintf(s + len, cap - len,
            "<li><a href=\"#image=%s\">%s</a> <span class=\"dim\">%u &times; "
            "%u</span> &middot; <a href=\"/v1/images/%s\">metadata</a> &middot; "
            "<a href=\"/iiif/3/%s/info.json\">IIIF info.json</a></li>\n",
            id, id, g->width, g->height, id, id);
        image_put(imgs[i]);
    }
    free(imgs);
    memcpy(s + len, text + tail_at, page->len - tail_at);
    len += page->len - tail_at;
    struct MHD_Response *resp = http_response_owned(s, len, page->type);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-cache");
        MHD_add_response_header(resp, "Content-Security-Policy", WEB_CSP);
    }
    return http_send(r, 200, resp, len);
}
