/*
 * route_auth.c - IIIF Authorization Flow 2.0 (https://iiif.io/api/auth/2.0/)
 * over gigaviewd's access tokens (access.h):
 *
 *   GET /iiif/auth/probe/{id}   AuthProbeService2: an AuthProbeResult2
 *                               whose status (200, 401, 404) says what the
 *                               caller's token (Bearer) would get
 *   GET /iiif/auth/login        AuthAccessService2 (profile active): sets
 *                               the gigaview_access cookie from the trusted
 *                               proxy header or from ?token=, and answers
 *                               a page that closes its window
 *   GET /iiif/auth/token        AuthAccessTokenService2: in the client's
 *                               iframe (?messageId=&origin=), a page that
 *                               posts the cookie's token (AuthAccessToken2)
 *                               or an AuthAccessTokenError2 to the origin
 *   GET /iiif/auth/logout       AuthLogoutService2: clears the cookie
 *
 * info.json of a protected image (route_iiif.c) and the 401 of its
 * info.json (http.c) carry auth_services_json.  Every answer here is
 * per caller: Cache-Control no-store.  Strings put into a page's script
 * are JSON with <, > and & escaped, so no client string can close the
 * script.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "log.h"
#include "routes.h"

#define AUTH_CONTEXT "http://iiif.io/api/auth/2/context.json"
#define HTML "text/html; charset=utf-8"
#define MESSAGE_ID_MAX 512 /* bytes of a client's messageId */

/* {"en": [s]}: the language map of every text (IIIF Presentation 3). */
static json_t *lang(const char *s)
{
    return json_pack("{s:[s]}", "en", s);
}

/* The texts of the policy in force, or the built-in ones. */
static const char *message(struct req *r, enum access_message m)
{
    const struct access_policy *p = http_policy(r);
    if (p)
        return p->message[m];
    static const char *const def[ACCESS_MSG_COUNT] = {
        "Log in to see this image", "This image is restricted",
        "Log in with your institution's account to see it.", "Log in",
        "Access denied", "Your account does not give access to this image."};
    return def[m];
}

json_t *auth_services_json(struct req *r, const char *id)
{
    char base[300], probe[600], login[400], token[400], logout[400];
    http_base_url(r, base, sizeof base);
    snprintf(probe, sizeof probe, "%s/iiif/auth/probe/%s", base, id);
    snprintf(login, sizeof login, "%s/iiif/auth/login", base);
    snprintf(token, sizeof token, "%s/iiif/auth/token", base);
    snprintf(logout, sizeof logout, "%s/iiif/auth/logout", base);
    return json_pack(
        "[{s:s,s:s,s:[{s:s,s:s,s:s,s:o,s:o,s:o,s:o,s:[{s:s,s:s},{s:s,s:s,s:o}]}]}]",
        "id", probe, "type", "AuthProbeService2", "service",
        "id", login, "type", "AuthAccessService2", "profile", "active",
        "label", lang(message(r, ACCESS_MSG_LABEL)),
        "heading", lang(message(r, ACCESS_MSG_HEADING)),
        "note", lang(message(r, ACCESS_MSG_NOTE)),
        "confirmLabel", lang(message(r, ACCESS_MSG_CONFIRM)),
        "service", "id", token, "type", "AuthAccessTokenService2",
        "id", logout, "type", "AuthLogoutService2",
        "label", lang("Log out"));
}

/* ---------------------------------------------------------------- probe */

enum MHD_Result route_auth_probe(struct req *r)
{
    const char *id = r->param[0];
    enum access_verdict v = http_access(r, id);
    r->private_answer = 1;
    unsigned status = 200;
    if (v == ACCESS_HIDDEN) {
        status = 404;
    } else if (v == ACCESS_PUBLIC) {
        struct image *img = catalog_get(r->srv->catalog, id);
        status = img ? 200 : 404;
        image_put(img);
    } else if (v == ACCESS_DENIED) {
        status = 401;
    }
    char base[300], self[600];
    http_base_url(r, base, sizeof base);
    snprintf(self, sizeof self, "%s/iiif/auth/probe/%s", base, id);
    json_t *j = json_pack("{s:s,s:s,s:s,s:i}", "@context", AUTH_CONTEXT,
                          "id", self, "type", "AuthProbeResult2", "status",
                          (int)status);
    if (j && status == 401) {
        int valid = http_caller(r, NULL) != NULL;
        json_object_set_new(j, "heading", lang(message(
            r, valid ? ACCESS_MSG_DENIED_HEADING : ACCESS_MSG_HEADING)));
        json_object_set_new(j, "note", lang(message(
            r, valid ? ACCESS_MSG_DENIED_NOTE : ACCESS_MSG_NOTE)));
    }
    if (!j)
        return http_send_errorf(r, GV_ENOMEM, "probe: out of memory");
    return http_send_json_header(r, 200, j, MHD_HTTP_HEADER_CACHE_CONTROL,
                                 "no-store");
}

/* ------------------------------------------------------- login, logout */

/* 1 if the client reaches us over https (public_url, or the proxy's
 * X-Forwarded-Proto): the cookie is then Secure. */
static int over_https(struct req *r)
{
    const char *xf = http_header(r, "X-Forwarded-Proto");
    return !strncmp(r->srv->cfg->public_url, "https://", 8) ||
           (xf && !strcmp(xf, "https"));
}

/* An HTML page (no-store) with one more header (name NULL: none). */
static enum MHD_Result send_page(struct req *r, unsigned status,
                                 const char *page, const char *name,
                                 const char *value)
{
    struct MHD_Response *resp = http_response_copy(page, strlen(page), HTML);
    if (resp) {
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
        if (name)
            MHD_add_response_header(resp, name, value);
    }
    return http_send(r, status, resp, strlen(page));
}

/* Set the cookie to token for max_age seconds (0: clear it). */
static enum MHD_Result send_cookie(struct req *r, const char *token,
                                   long long max_age, const char *page)
{
    /* Browsers drop a SameSite=None cookie that is not Secure, and a
     * Secure one is not set over http: over http the cookie serves this
     * site's own pages (SameSite=Lax), as other sites' viewers could not
     * use it there anyway. */
    char cookie[ACCESS_TOKEN_MAX + 160];
    snprintf(cookie, sizeof cookie, "%s=%s; Path=/; Max-Age=%lld; HttpOnly; "
             "%s", HTTP_ACCESS_COOKIE, token, max_age,
             over_https(r) ? "SameSite=None; Secure" : "SameSite=Lax");
    return send_page(r, 200, page, MHD_HTTP_HEADER_SET_COOKIE, cookie);
}

static const char closing_page[] =
    "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Logged "
    "in</title></head>\n<body><p>You are logged in. This window closes "
    "itself; if it does not, close it.</p>\n<script>window.close();</script>"
    "</body></html>\n";

enum MHD_Result route_auth_login(struct req *r)
{
    struct access *a = r->srv->access;
    if (!access_has_secret(a))
        return http_send_errorf(r, GV_ENOTFOUND, "login: access control has "
                                "no login (set access_trusted_header or "
                                "access_token_secret_file)");
    const char *hname = access_trusted_header(a);
    const char *groups = hname ? http_header(r, hname) : NULL;
    const char *given = http_query(r, "token");
    char token[ACCESS_TOKEN_MAX + 1];
    struct access_claims c;
    memset(&c, 0, sizeof c);
    long long max_age;
    if (groups) {
        /* The proxy authenticated the user and says their groups. */
        access_groups_from_header(groups, &c);
        const char *user = http_header(r, "X-Remote-User");
        if (user && strlen(user) <= ACCESS_SUB_MAX)
            for (size_t i = 0; user[i]; i++)
                c.sub[i] = (user[i] >= 0x20 && user[i] < 0x7f) ? user[i] : '?';
        if (access_mint(a, &c, token, sizeof token) < 0)
            return http_send_errorf(r, GV_ENOMEM, "login: cannot mint a token");
        max_age = (long long)r->srv->cfg->access_token_ttl;
        char esc[200];
        log_msg(LOG_INFO, "access", "login through %s: %d groups, sub '%s'",
                hname, c.ngroups, log_escape(esc, sizeof esc, c.sub));
    } else if (given) {
        enum access_token_status st = access_verify(a, given, &c);
        if (st != ACCESS_TOKEN_OK)
            return http_send_fail(r, GV_EAUTH, st == ACCESS_TOKEN_EXPIRED
                                  ? "login: the token has expired"
                                  : "login: the token is not valid",
                                  "WWW-Authenticate", "Bearer realm=\"gigaview\", "
                                  "error=\"invalid_token\"");
        snprintf(token, sizeof token, "%s", given);
        max_age = (long long)(c.exp - (int64_t)time(NULL));
    } else {
        return http_send_fail(r, GV_EAUTH, hname
                              ? "login: no user: the proxy in front must "
                                "authenticate this route and set the groups "
                                "header"
                              : "login: no token (?token= from the "
                                "institution's login)",
                              "WWW-Authenticate", "Bearer realm=\"gigaview\"");
    }
    return send_cookie(r, token, max_age, closing_page);
}

enum MHD_Result route_auth_logout(struct req *r)
{
    return send_cookie(r, "", 0,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Logged "
        "out</title></head>\n<body><p>You are logged out.</p></body></html>\n");
}

/* ---------------------------------------------------------------- token */

/* j (stolen) as JSON safe inside a <script>: ASCII only, with <, > and &
 * escaped as \u003c, \u003e, \u0026 (they only occur inside strings).
 * malloc'ed, or NULL. */
static char *script_json(json_t *j)
{
    char *s = j ? json_dumps(j, JSON_COMPACT | JSON_ENSURE_ASCII |
                                    JSON_PRESERVE_ORDER | JSON_ENCODE_ANY)
                : NULL;
    json_decref(j);
    if (!s)
        return NULL;
    size_t n = 0;
    for (const char *p = s; *p; p++)
        n += strchr("<>&", *p) ? 6 : 1;
    char *o = malloc(n + 1), *q = o;
    if (o)
        for (const char *p = s; *p; p++) {
            if (strchr("<>&", *p))
                q += sprintf(q, "\\u%04x", (unsigned)(unsigned char)*p);
            else
                *q++ = *p;
        }
    if (o)
        *q = '\0';
    free(s);
    return o;
}

/* 1 if `origin` is this server's own (scheme://host[:port] of its base
 * URL): the viewer gigaviewd serves itself may always have the token. */
static int own_origin(struct req *r, const char *origin)
{
    char base[300];
    http_base_url(r, base, sizeof base);
    const char *host = strstr(base, "://");
    if (!host)
        return 0;
    size_t n = strcspn(host + 3, "/") + (size_t)(host + 3 - base);
    return strlen(origin) == n && !memcmp(origin, base, n);
}

/* The AuthAccessTokenError2 of `profile`. */
static json_t *token_error(const char *profile, const char *note,
                           const char *message_id)
{
    return json_pack("{s:s,s:s,s:s,s:o,s:o,s:s}", "@context", AUTH_CONTEXT,
                     "type", "AuthAccessTokenError2", "profile", profile,
                     "heading", lang("No access token"), "note", lang(note),
                     "messageId", message_id);
}

enum MHD_Result route_auth_token(struct req *r)
{
    struct access *a = r->srv->access;
    const char *mid = http_query(r, "messageId"), *origin = http_query(r, "origin");
    if (!mid || !origin || !mid[0] || strlen(mid) > MESSAGE_ID_MAX)
        return http_send_errorf(r, GV_EINVAL, "token: messageId (at most %d "
                                "bytes) and origin are required: the token "
                                "service is opened in an iframe (IIIF "
                                "Authorization Flow 2.0)", MESSAGE_ID_MAX);
    if (!access_origin_valid(origin))
        return http_send_errorf(r, GV_EINVAL, "token: origin must be "
                                "scheme://host[:port]");
    json_t *msg;
    struct access_claims c;
    const char *cookie = MHD_lookup_connection_value(r->conn, MHD_COOKIE_KIND,
                                                     HTTP_ACCESS_COOKIE);
    if (!access_origin_allowed(a, origin) && !own_origin(r, origin)) {
        msg = token_error("invalidOrigin", "This site may not use these "
                          "images' access tokens.", mid);
    } else if (!access_has_secret(a)) {
        msg = token_error("unavailable", "Access control has no login here.",
                          mid);
    } else if (!cookie || !cookie[0]) {
        msg = token_error("missingAspect", "You are not logged in.", mid);
    } else {
        enum access_token_status st = access_verify(a, cookie, &c);
        if (st == ACCESS_TOKEN_OK)
            msg = json_pack("{s:s,s:s,s:s,s:I,s:s}", "@context", AUTH_CONTEXT,
                            "type", "AuthAccessToken2", "accessToken", cookie,
                            "expiresIn", (json_int_t)(c.exp - (int64_t)time(NULL)),
                            "messageId", mid);
        else if (st == ACCESS_TOKEN_EXPIRED)
            msg = token_error("expiredAspect", "Your login has expired: log "
                              "in again.", mid);
        else
            msg = token_error("invalidAspect", "Your login is not valid: log "
                              "in again.", mid);
    }
    char *m = script_json(msg), *o = script_json(json_string(origin));
    char *page = NULL;
    if (m && o && asprintf(&page, "<!DOCTYPE html>\n<html><head><meta charset="
                           "\"utf-8\"><title>gigaview token</title></head>\n"
                           "<body><script>window.parent.postMessage(%s, %s);"
                           "</script></body></html>\n", m, o) < 0)
        page = NULL;
    free(m);
    free(o);
    if (!page)
        return http_send_errorf(r, GV_ENOMEM, "token: out of memory");
    /* Only the origin the message is for may frame the page. */
    char csp[400];
    snprintf(csp, sizeof csp, "default-src 'none'; script-src 'unsafe-inline'; "
             "frame-ancestors %s", origin);
    enum MHD_Result ret = send_page(r, 200, page, "Content-Security-Policy", csp);
    free(page);
    return ret;
}
