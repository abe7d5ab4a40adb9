/*
 * access_token.h - gigaviewd's signed access tokens: what an
 * institution's login hands a reader so that gigaviewd lets them see
 * protected images (docs/OPERATIONS.md "Access control").
 *
 * A token is
 *
 *     base64url(payload) "." base64url(HMAC-SHA256(secret, payload))
 *
 * with the payload a compact JSON object {"sub": "...", "groups": [...],
 * "exp": UNIX_SECONDS, "iat": UNIX_SECONDS} ("iat", when it was issued,
 * is optional: tokens minted before it existed lack it) and base64url without padding (RFC 4648 section
 * 5).  The MAC covers the payload's bytes as decoded.  Verification
 * checks the lengths, the encoding (canonical: no padding, no stray
 * bits), the MAC (in constant time) and only then parses the JSON, with
 * limits on every part; unknown members are ignored.  Pure functions, no
 * libmicrohttpd: tests/fuzz/fuzz_access_token.c drives them directly.
 * Thread-safe.
 */
#ifndef GV_SERVER_ACCESS_TOKEN_H
#define GV_SERVER_ACCESS_TOKEN_H

#include <stddef.h>
#include <stdint.h>

#define ACCESS_TOKEN_MAX 4096   /* bytes of a token as sent */
#define ACCESS_PAYLOAD_MAX 2048 /* bytes of its decoded JSON */
#define ACCESS_GROUPS_MAX 16    /* groups in one token */
#define ACCESS_GROUP_MAX 64     /* bytes of a group name */
#define ACCESS_SUB_MAX 128      /* bytes of the subject */
#define ACCESS_SECRET_MIN 32    /* bytes of the secret: 256 bits */
#define ACCESS_SECRET_MAX 1024
/* The largest exp accepted: 2^53 - 1, the largest integer every JSON
 * reader (JavaScript, Python's float path) keeps exactly. */
#define ACCESS_EXP_MAX 9007199254740991LL

struct access_claims {
    char sub[ACCESS_SUB_MAX + 1];
    int ngroups;
    char group[ACCESS_GROUPS_MAX][ACCESS_GROUP_MAX + 1];
    int64_t exp;
    int64_t iat;            /* issued at; 0 when the token does not say */
};

enum access_token_status {
    ACCESS_TOKEN_OK = 0,
    ACCESS_TOKEN_MALFORMED, /* too long, not two base64url parts, a MAC
                               of the wrong size, or (under a good MAC)
                               a payload that is not the JSON above */
    ACCESS_TOKEN_FORGED,    /* the MAC does not match */
    ACCESS_TOKEN_EXPIRED,   /* exp <= now */
    ACCESS_TOKEN_REVOKED,   /* good, but the access policy revokes it
                               (access_policy_revoked; never returned by
                               access_token_verify) */
};

/* The status's name ("ok", "malformed", "forged", "expired", "revoked"). */
const char *access_token_status_name(enum access_token_status s);

/* 1 if s[0..n-1] is a group name: 1..ACCESS_GROUP_MAX bytes of
 * [A-Za-z0-9._-], else 0. */
int access_group_valid(const char *s, size_t n);

/* base64url of n bytes, no padding, NUL-terminated into out: its length,
 * or 0 when out (size bytes) is too small. */
size_t access_b64url_encode(const void *in, size_t n, char *out, size_t size);

/* Decode n characters of canonical base64url (no padding, the unused
 * bits of the last character zero) into out (size bytes): 0 with *len,
 * or -1 (bad character, impossible length, stray bits, no room). */
int access_b64url_decode(const char *in, size_t n, uint8_t *out, size_t size,
                         size_t *len);

/* Parse a payload (n bytes of JSON, at most ACCESS_PAYLOAD_MAX) into *c:
 * an object whose "exp" is an integer in 1..ACCESS_EXP_MAX, whose
 * "groups" (required) is an array of at most ACCESS_GROUPS_MAX group
 * names and whose "sub" (optional, "" when absent) is a string of at
 * most ACCESS_SUB_MAX bytes without control characters, and whose "iat"
 * (optional, 0 when absent) is an integer in 1..ACCESS_EXP_MAX.  0, or -1 with
 * *c zeroed. */
int access_payload_parse(const char *json, size_t n, struct access_claims *c);

/* Verify the NUL-terminated token under secret (secret_len bytes, at
 * least 1) at time now (UNIX seconds).  ACCESS_TOKEN_OK fills *c; any
 * other status leaves *c zeroed. */
enum access_token_status access_token_verify(const char *token,
                                             const uint8_t *secret,
                                             size_t secret_len, int64_t now,
                                             struct access_claims *c);

/* Mint a token for *c (its iat written when not 0) under secret into out
 * (size bytes, NUL-terminated;
 * ACCESS_TOKEN_MAX + 1 always suffices).  The claims must be valid as
 * access_payload_parse defines them.  0, or -1 (invalid claims, no
 * memory, no room). */
int access_token_sign(const uint8_t *secret, size_t secret_len,
                      const struct access_claims *c, char *out, size_t size);

/* 1 if c holds group g, else 0. */
int access_claims_has_group(const struct access_claims *c, const char *g);

#endif
