/*
 * access_token.c - signed access tokens (see access_token.h).
 *
 * Verification does the cheap, content-blind checks first (length, one
 * '.', the alphabet), then the MAC over the decoded payload, compared in
 * constant time, and parses the JSON only under a good MAC: a forger
 * never reaches jansson.  The parse is strict all the same, since the
 * fuzz target reaches it directly.
 */
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "access_token.h"
#include "base/sha256.h"

static const char alphabet[] =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";

const char *access_token_status_name(enum access_token_status s)
{
    switch (s) {
    case ACCESS_TOKEN_OK: return "ok";
    case ACCESS_TOKEN_MALFORMED: return "malformed";
    case ACCESS_TOKEN_FORGED: return "forged";
    case ACCESS_TOKEN_EXPIRED: return "expired";
    case ACCESS_TOKEN_REVOKED: return "revoked";
    }
    return "unknown";
}

/* Same shape as gv_image_id_valid_n in lib/base/ids.c: deliberately
 * separate, group names and image ids are two vocabularies with their own
 * rules (an image id also refuses a leading dot and ".."). */
int access_group_valid(const char *s, size_t n)
{
    if (n < 1 || n > ACCESS_GROUP_MAX)
        return 0;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
              (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-'))
            return 0;
    }
    return 1;
}

size_t access_b64url_encode(const void *in, size_t n, char *out, size_t size)
{
    const uint8_t *p = in;
    size_t len = n / 3 * 4 + (n % 3 ? n % 3 + 1 : 0);
    if (n > (SIZE_MAX - 8) / 2 || len + 1 > size)
        return 0;
    size_t o = 0, i = 0;
    for (; i + 3 <= n; i += 3) {
        uint32_t v = (uint32_t)p[i] << 16 | (uint32_t)p[i + 1] << 8 | p[i + 2];
        out[o++] = alphabet[v >> 18];
        out[o++] = alphabet[(v >> 12) & 63];
        out[o++] = alphabet[(v >> 6) & 63];
        out[o++] = alphabet[v & 63];
    }
    if (n - i == 1) {
        uint32_t v = (uint32_t)p[i] << 16;
        out[o++] = alphabet[v >> 18];
        out[o++] = alphabet[(v >> 12) & 63];
    } else if (n - i == 2) {
        uint32_t v = (uint32_t)p[i] << 16 | (uint32_t)p[i + 1] << 8;
        out[o++] = alphabet[v >> 18];
        out[o++] = alphabet[(v >> 12) & 63];
        out[o++] = alphabet[(v >> 6) & 63];
    }
    out[o] = '\0';
    return o;
}

/* Same shape as hexval in router.c: deliberately separate, base64url digits
 * here, hex there. */
static int b64val(char c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '-')
        return 62;
    if (c == '_')
        return 63;
    return -1;
}

int access_b64url_decode(const char *in, size_t n, uint8_t *out, size_t size,
                         size_t *len)
{
    if (n % 4 == 1)
        return -1;
    size_t want = n / 4 * 3 + (n % 4 ? n % 4 - 1 : 0);
    if (want > size)
        return -1;
    uint32_t acc = 0;
    int bits = 0;
    size_t o = 0;
    for (size_t i = 0; i < n; i++) {
        int v = b64val(in[i]);
        if (v < 0)
            return -1;
        acc = acc << 6 | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out[o++] = (uint8_t)(acc >> bits);
            acc &= (1u << bits) - 1;
        }
    }
    if (acc != 0) /* stray bits: not the canonical encoding */
        return -1;
    *len = o;
    return 0;
}

int access_claims_has_group(const struct access_claims *c, const char *g)
{
    for (int i = 0; i < c->ngroups; i++)
        if (!strcmp(c->group[i], g))
            return 1;
    return 0;
}

/* 1 if s holds no control character (C0 or DEL). */
static int printable(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)s[i] < 0x20 || s[i] == 0x7f)
            return 0;
    return 1;
}

static int parse_claims(json_t *j, struct access_claims *c)
{
    if (!json_is_object(j))
        return -1;
    json_t *exp = json_object_get(j, "exp");
    json_t *groups = json_object_get(j, "groups");
    json_t *sub = json_object_get(j, "sub");
    if (!json_is_integer(exp) || json_integer_value(exp) < 1 ||
        json_integer_value(exp) > ACCESS_EXP_MAX)
        return -1;
    c->exp = (int64_t)json_integer_value(exp);
    json_t *iat = json_object_get(j, "iat");
    if (iat && (!json_is_integer(iat) || json_integer_value(iat) < 1 ||
                json_integer_value(iat) > ACCESS_EXP_MAX))
        return -1;
    c->iat = iat ? (int64_t)json_integer_value(iat) : 0;
    if (!json_is_array(groups) || json_array_size(groups) > ACCESS_GROUPS_MAX)
        return -1;
    for (size_t i = 0; i < json_array_size(groups); i++) {
        json_t *g = json_array_get(groups, i);
        if (!json_is_string(g) ||
            !access_group_valid(json_string_value(g), json_string_length(g)))
            return -1;
        memcpy(c->group[c->ngroups++], json_string_value(g),
               json_string_length(g) + 1);
    }
    if (sub) {
        if (!json_is_string(sub) || json_string_length(sub) > ACCESS_SUB_MAX ||
            !printable(json_string_value(sub), json_string_length(sub)))
            return -1;
        memcpy(c->sub, json_string_value(sub), json_string_length(sub) + 1);
    }
    return 0;
}

int access_payload_parse(const char *json, size_t n, struct access_claims *c)
{
    memset(c, 0, sizeof *c);
    if (n == 0 || n > ACCESS_PAYLOAD_MAX)
        return -1;
    json_error_t jerr;
    json_t *j = json_loadb(json, n, JSON_REJECT_DUPLICATES, &jerr);
    int rc = j ? parse_claims(j, c) : -1;
    json_decref(j);
    if (rc < 0)
        memset(c, 0, sizeof *c);
    return rc;
}

enum access_token_status access_token_verify(const char *token,
                                             const uint8_t *secret,
                                             size_t secret_len, int64_t now,
                                             struct access_claims *c)
{
    memset(c, 0, sizeof *c);
    size_t n = strnlen(token, ACCESS_TOKEN_MAX + 1);
    const char *dot = memchr(token, '.', n);
    if (n > ACCESS_TOKEN_MAX || !dot || memchr(dot + 1, '.', n - (size_t)(dot + 1 - token)))
        return ACCESS_TOKEN_MALFORMED;
    uint8_t payload[ACCESS_PAYLOAD_MAX], mac[GV_SHA256_BYTES + 3],
        want[GV_SHA256_BYTES];
    size_t plen, mlen;
    if (access_b64url_decode(token, (size_t)(dot - token), payload,
                             sizeof payload, &plen) < 0 || plen == 0 ||
        access_b64url_decode(dot + 1, n - (size_t)(dot + 1 - token), mac,
                             sizeof mac, &mlen) < 0 ||
        mlen != GV_SHA256_BYTES)
        return ACCESS_TOKEN_MALFORMED;
    gv_hmac_sha256(secret, secret_len, payload, plen, want);
    if (!gv_equal_ct(mac, want, GV_SHA256_BYTES))
        return ACCESS_TOKEN_FORGED;
    if (access_payload_parse((const char *)payload, plen, c) < 0)
        return ACCESS_TOKEN_MALFORMED;
    if (c->exp <= now) {
        memset(c, 0, sizeof *c);
        return ACCESS_TOKEN_EXPIRED;
    }
    return ACCESS_TOKEN_OK;
}

int access_token_sign(const uint8_t *secret, size_t secret_len,
                      const struct access_claims *c, char *out, size_t size)
{
    if (c->ngroups < 0 || c->ngroups > ACCESS_GROUPS_MAX || c->exp < 1 ||
        c->exp > ACCESS_EXP_MAX || strnlen(c->sub, sizeof c->sub) > ACCESS_SUB_MAX ||
        !printable(c->sub, strlen(c->sub)) || c->iat < 0 || c->iat > ACCESS_EXP_MAX)
        return -1;
    json_t *groups = json_array();
    for (int i = 0; groups && i < c->ngroups; i++) {
        size_t gl = strnlen(c->group[i], sizeof c->group[i]);
        if (!access_group_valid(c->group[i], gl) ||
            json_array_append_new(groups, json_string(c->group[i])) < 0) {
            json_decref(groups);
            return -1;
        }
    }
    json_t *j = json_pack("{s:s,s:o,s:I}", "sub", c->sub, "groups", groups,
                          "exp", (json_int_t)c->exp);
    if (j && c->iat && json_object_set_new(j, "iat", json_integer((json_int_t)c->iat)) < 0) {
        json_decref(j);
        j = NULL;
    }
    char *s = j ? json_dumps(j, JSON_COMPACT | JSON_PRESERVE_ORDER) : NULL;
    json_decref(j);
    if (!s)
        return -1;
    size_t plen = strlen(s);
    int rc = -1;
    if (plen <= ACCESS_PAYLOAD_MAX) {
        uint8_t mac[GV_SHA256_BYTES];
        gv_hmac_sha256(secret, secret_len, s, plen, mac);
        size_t a = access_b64url_encode(s, plen, out, size);
        if (a && a + 1 < size &&
            access_b64url_encode(mac, sizeof mac, out + a + 1, size - a - 1)) {
            out[a] = '.';
            rc = 0;
        }
    }
    free(s);
    return rc;
}
