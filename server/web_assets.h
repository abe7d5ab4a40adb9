/*
 * web_assets.h - the browser viewer's files (client/web/ and the shared
 * decode shader from shaders/), embedded in gigaviewd at build time by
 * client/web/embed.sh, so a deployment is one binary and the browser
 * always gets the decode shader this server was built with.
 * route_static.c serves them under /web/NAME and route_home.c builds /
 * from index.html.
 */
#ifndef GV_SERVER_WEB_ASSETS_H
#define GV_SERVER_WEB_ASSETS_H

#include <stddef.h>

struct web_asset {
    const char *name;               /* base name: "viewer.js" */
    const char *type;               /* Content-Type */
    const unsigned char *data;      /* the file's bytes (NUL after them) */
    size_t len;
    const char *etag;               /* "\"CRC-LEN\"" */
};

/* Generated (web_assets.c): every embedded file, in build order. */
extern const struct web_asset web_assets[];
extern const size_t web_assets_count;

/* The asset called `name`, or NULL.  Thread-safe (read-only data). */
const struct web_asset *web_asset_find(const char *name);

/* Content-Security-Policy of the viewer's page: its own scripts, styles,
 * workers and API only. */
#define WEB_CSP "default-src 'self'; script-src 'self'; worker-src 'self'; " \
    "style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; " \
    "object-src 'none'; base-uri 'self'; frame-ancestors 'self'"

#endif
