/*
 * route_static.c - GET /web/{name}: the browser viewer's embedded files
 * (web_assets.h).  Each carries a strong ETag (CRC and length of the
 * bytes, fixed at build time) and "Cache-Control: no-cache", so a browser
 * revalidates with If-None-Match and gets a bodiless 304 until gigaviewd
 * is rebuilt with other files.  The bytes are static: the response points
 * at them without a copy.
 */
#include <string.h>

#include "log.h"
#include "routes.h"
#include "web_assets.h"

const struct web_asset *web_asset_find(const char *name)
{
    for (size_t i = 0; i < web_assets_count; i++)
        if (!strcmp(web_assets[i].name, name))
            return &web_assets[i];
    return NULL;
}

enum MHD_Result route_static(struct req *r)
{
    const struct web_asset *a = web_asset_find(r->param[0]);
    if (!a) {
        char esc[160];
        log_escape(esc, sizeof esc, r->param[0]);
        return http_send_errorf(r, GV_ENOTFOUND, "no file '%s' in the viewer",
                                esc);
    }
    if (http_etag_listed(http_header(r, "If-None-Match"), a->etag))
        return http_send_empty(r, 304, "ETag", a->etag);
    struct MHD_Response *resp = MHD_create_response_from_buffer(
        a->len, (void *)a->data, MHD_RESPMEM_PERSISTENT);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, a->type);
        MHD_add_response_header(resp, "ETag", a->etag);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-cache");
    }
    return http_send(r, 200, resp, a->len);
}
