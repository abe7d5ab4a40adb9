/*
 * fuzz_access_token.c - libFuzzer target for the signed access tokens
 * (server/access_token.c): the verifier, the payload parser and base64url.
 *
 * Byte 0 picks the part (mod 3); the rest is its input:
 *  0: a token (cut at the first NUL, as a header value would be),
 *     verified under FUZZ_SECRET at FUZZ_NOW.  ACCESS_TOKEN_OK: the claims
 *     hold valid groups, a printable sub and exp > now, and signing them
 *     again gives a token that verifies to the same claims; any other
 *     status: the claims are zeroed.
 *  1: a payload (as is), parsed; when it parses, signing the claims and
 *     the raw payload (its MAC computed here) both verify, to the same
 *     claims; when it does not, the raw payload under a good MAC is
 *     malformed (the verifier and the parser agree).
 *  2: base64url: when the input decodes, encoding it again gives the
 *     input back (only the canonical form is accepted).
 * Anything else aborts.  tests/fuzz/make_corpus_access.py writes the
 * seeds (with FUZZ_SECRET, for the tokens that verify).
 */
#include <stdlib.h>
#include <string.h>

#include "access_token.h"
#include "base/sha256.h"
#include "fuzz.h"

#define MAX_INPUT (16u << 10) /* four times the longest token accepted */
#define FUZZ_SECRET "fuzz-secret-fuzz-secret-fuzz-secret!"
#define FUZZ_NOW 1800000000LL

static const uint8_t *secret = (const uint8_t *)FUZZ_SECRET;
static const size_t secret_len = sizeof FUZZ_SECRET - 1;

static int same_claims(const struct access_claims *a, const struct access_claims *b)
{
    if (strcmp(a->sub, b->sub) || a->ngroups != b->ngroups || a->exp != b->exp ||
        a->iat != b->iat)
        return 0;
    for (int i = 0; i < a->ngroups; i++)
        if (strcmp(a->group[i], b->group[i]))
            return 0;
    return 1;
}

static int zeroed(const struct access_claims *c)
{
    static const struct access_claims zero;
    return !memcmp(c, &zero, sizeof zero);
}

static void check_claims(const struct access_claims *c, int64_t now)
{
    if (c->ngroups < 0 || c->ngroups > ACCESS_GROUPS_MAX || c->exp <= now ||
        c->exp > ACCESS_EXP_MAX || strlen(c->sub) > ACCESS_SUB_MAX)
        abort();
    for (int i = 0; i < c->ngroups; i++)
        if (!access_group_valid(c->group[i], strlen(c->group[i])))
            abort();
    for (const char *p = c->sub; *p; p++)
        if ((unsigned char)*p < 0x20 || *p == 0x7f)
            abort();
}

/* Sign c again and verify: the same claims. */
static void resign(const struct access_claims *c, int64_t now)
{
    char tok[ACCESS_TOKEN_MAX + 1];
    struct access_claims back;
    if (access_token_sign(secret, secret_len, c, tok, sizeof tok) < 0 ||
        access_token_verify(tok, secret, secret_len, now, &back) != ACCESS_TOKEN_OK ||
        !same_claims(c, &back))
        abort();
}

static void fuzz_token(const char *in)
{
    struct access_claims c;
    enum access_token_status st = access_token_verify(in, secret, secret_len,
                                                      FUZZ_NOW, &c);
    if (st != ACCESS_TOKEN_OK) {
        if (!zeroed(&c) || (st != ACCESS_TOKEN_MALFORMED &&
                            st != ACCESS_TOKEN_FORGED && st != ACCESS_TOKEN_EXPIRED))
            abort();
        return;
    }
    check_claims(&c, FUZZ_NOW);
    resign(&c, FUZZ_NOW);
}

static void fuzz_payload(const char *in, size_t n)
{
    struct access_claims c, v;
    int rc = access_payload_parse(in, n, &c);
    /* The raw payload under a good MAC, when it fits a token. */
    char tok[ACCESS_TOKEN_MAX + 64];
    int fits = n >= 1 && n <= ACCESS_PAYLOAD_MAX;
    if (fits) {
        uint8_t mac[GV_SHA256_BYTES];
        gv_hmac_sha256(secret, secret_len, in, n, mac);
        size_t a = access_b64url_encode(in, n, tok, sizeof tok);
        if (!a)
            abort();
        tok[a] = '.';
        access_b64url_encode(mac, sizeof mac, tok + a + 1, sizeof tok - a - 1);
    }
    if (rc < 0) {
        if (!zeroed(&c))
            abort();
        if (fits && access_token_verify(tok, secret, secret_len, 0, &v) !=
                        ACCESS_TOKEN_MALFORMED)
            abort();
        return;
    }
    check_claims(&c, 0);
    resign(&c, 0);
    if (!fits || access_token_verify(tok, secret, secret_len, 0, &v) != ACCESS_TOKEN_OK ||
        !same_claims(&c, &v))
        abort();
}

static void fuzz_base64(const char *in, size_t n)
{
    uint8_t *out = malloc(n + 1);
    char *again = malloc(2 * n + 8);
    size_t len;
    if (!out || !again)
        abort();
    if (access_b64url_decode(in, n, out, n + 1, &len) == 0) {
        size_t k = access_b64url_encode(out, len, again, 2 * n + 8);
        if (k != n || memcmp(again, in, n))
            abort();
    }
    free(out);
    free(again);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > MAX_INPUT)
        return 0;
    size_t n = size - 1;
    char *in = malloc(n + 1);
    if (!in)
        return 0;
    memcpy(in, data + 1, n);
    in[n] = '\0';
    switch (data[0] % 3) {
    case 0: fuzz_token(in); break;
    case 1: fuzz_payload(in, n); break;
    default: fuzz_base64(in, n); break;
    }
    free(in);
    return 0;
}
