/*
 * test_access_token.c - SHA-256 and HMAC-SHA256 (lib/base/sha256.c)
 * against the FIPS 180-4 examples and the RFC 4231 test vectors, base64url
 * against RFC 4648 section 10, and the signed access tokens
 * (server/access_token.c): a round trip, and every refusal (expired,
 * forged MAC, payload altered under a good MAC, wrong secret, malformed
 * encodings, and payloads that are not the token's JSON under a good MAC).
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "access_token.h"
#include "base/sha256.h"
#include "util.h"

#define NOW 1800000000LL /* a fixed "now": 2027-01-15 */

static const uint8_t SECRET[] = "0123456789abcdef0123456789abcdef-test";
#define SECRET_LEN (sizeof SECRET - 1)

static void hex(const uint8_t *d, size_t n, char *out)
{
    for (size_t i = 0; i < n; i++)
        sprintf(out + 2 * i, "%02x", d[i]);
}

static void sha_is(const void *data, size_t len, const char *want,
                   const char *name)
{
    uint8_t d[32];
    char s[65];
    gv_sha256(data, len, d);
    hex(d, 32, s);
    check_str(s, want, "SHA-256 %s", name);
}

static void hmac_is(const uint8_t *key, size_t kl, const void *msg, size_t ml,
                    const char *want, const char *name)
{
    uint8_t d[32];
    char s[65];
    gv_hmac_sha256(key, kl, msg, ml, d);
    hex(d, 32, s);
    s[strlen(want)] = '\0'; /* test case 5 compares 128 bits */
    check_str(s, want, "HMAC-SHA256 RFC 4231 %s", name);
}

static void test_sha256(void)
{
    sha_is("", 0, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855", "empty");
    sha_is("abc", 3, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad", "abc");
    const char *two = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
    sha_is(two, strlen(two), "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1",
           "two blocks (448 bits)");
    const char *four = "abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmn"
                       "hijklmnoijklmnopjklmnopqklmnopqrlmnopqrsmnopqrstnopqrstu";
    sha_is(four, strlen(four), "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1",
           "896 bits");
    /* A million 'a', fed in pieces of every size 1..97 in turn: the
     * buffering must not matter. */
    static char a[1000000];
    memset(a, 'a', sizeof a);
    sha_is(a, sizeof a, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0",
           "one million a");
    struct gv_sha256 s;
    gv_sha256_init(&s);
    size_t at = 0, step = 1;
    while (at < sizeof a) {
        size_t n = step < sizeof a - at ? step : sizeof a - at;
        gv_sha256_update(&s, a + at, n);
        at += n;
        step = step % 97 + 1;
    }
    uint8_t d[32];
    char h[65];
    gv_sha256_final(&s, d);
    hex(d, 32, h);
    check_str(h, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0",
              "SHA-256 one million a in uneven pieces");
    /* Every length across the padding boundaries against one-shot. */
    int same = 1;
    for (size_t n = 50; n <= 130; n++) {
        uint8_t x[32], y[32];
        gv_sha256(a, n, x);
        gv_sha256_init(&s);
        gv_sha256_update(&s, a, n / 2);
        gv_sha256_update(&s, a + n / 2, n - n / 2);
        gv_sha256_final(&s, y);
        same &= !memcmp(x, y, 32);
    }
    check(same, "SHA-256 split updates agree across 50..130 bytes");
}

static void test_hmac(void)
{
    uint8_t k[131];
    memset(k, 0x0b, 20);
    hmac_is(k, 20, "Hi There", 8,
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7", "case 1");
    hmac_is((const uint8_t *)"Jefe", 4, "what do ya want for nothing?", 28,
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843", "case 2");
    uint8_t dd[50];
    memset(k, 0xaa, 20);
    memset(dd, 0xdd, 50);
    hmac_is(k, 20, dd, 50,
            "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe", "case 3");
    for (int i = 0; i < 25; i++)
        k[i] = (uint8_t)(i + 1);
    memset(dd, 0xcd, 50);
    hmac_is(k, 25, dd, 50,
            "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b", "case 4");
    memset(k, 0x0c, 20);
    hmac_is(k, 20, "Test With Truncation", 20, "a3b6167473100ee06e0c796c2955552b",
            "case 5 (128 bits)");
    memset(k, 0xaa, 131);
    const char *m6 = "Test Using Larger Than Block-Size Key - Hash Key First";
    hmac_is(k, 131, m6, strlen(m6),
            "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54", "case 6");
    const char *m7 = "This is a test using a larger than block-size key and a "
                     "larger than block-size data. The key needs to be hashed "
                     "before being used by the HMAC algorithm.";
    hmac_is(k, 131, m7, strlen(m7),
            "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2", "case 7");
    check(gv_equal_ct("abcd", "abcd", 4) && !gv_equal_ct("abcd", "abce", 4) &&
          gv_equal_ct("", "x", 0), "gv_equal_ct");
}

static void test_base64url(void)
{
    static const char *const v[][2] = {{"", ""}, {"f", "Zg"}, {"fo", "Zm8"},
        {"foo", "Zm9v"}, {"foob", "Zm9vYg"}, {"fooba", "Zm9vYmE"},
        {"foobar", "Zm9vYmFy"}, {"\xfb\xff\xfe", "-__-"}};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
        char out[32];
        uint8_t back[32];
        size_t n;
        access_b64url_encode(v[i][0], strlen(v[i][0]), out, sizeof out);
        check_str(out, v[i][1], "base64url of \"%s\"", v[i][1]);
        check(access_b64url_decode(v[i][1], strlen(v[i][1]), back, sizeof back, &n) == 0 &&
              n == strlen(v[i][0]) && !memcmp(back, v[i][0], n),
              "base64url decode \"%s\"", v[i][1]);
    }
    static const char *const bad[] = {"Z", "Zh", "Zm9=", "Zm9v=", "Zm+v", "Zm/v",
                                      "Zm9vY", "Zm 9", "Zm9\t"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        uint8_t back[32];
        size_t n;
        check(access_b64url_decode(bad[i], strlen(bad[i]), back, sizeof back, &n) < 0,
              "base64url refuses \"%s\"", bad[i]);
    }
    char small[4];
    check(access_b64url_encode("foo", 3, small, sizeof small) == 0,
          "base64url encode: no room is 0");
    uint8_t tiny[2];
    size_t n;
    check(access_b64url_decode("Zm9v", 4, tiny, sizeof tiny, &n) < 0,
          "base64url decode: no room is -1");
}

/* A token whose payload is `json` under a good MAC. */
static void signed_raw(const char *json, char *out, size_t size)
{
    uint8_t mac[32];
    gv_hmac_sha256(SECRET, SECRET_LEN, json, strlen(json), mac);
    size_t a = access_b64url_encode(json, strlen(json), out, size);
    out[a] = '.';
    access_b64url_encode(mac, 32, out + a + 1, size - a - 1);
}

static enum access_token_status verify(const char *t, struct access_claims *c)
{
    return access_token_verify(t, SECRET, SECRET_LEN, NOW, c);
}

static int parse_text(const char *json, struct access_claims *c)
{
    return access_payload_parse(json, strlen(json), c);
}

static void test_tokens(void)
{
    struct access_claims c, got;
    memset(&c, 0, sizeof c);
    strcpy(c.sub, "ann@example.org");
    c.ngroups = 2;
    strcpy(c.group[0], "staff");
    strcpy(c.group[1], "board-2026");
    c.exp = NOW + 60;
    char tok[ACCESS_TOKEN_MAX + 1];
    check(access_token_sign(SECRET, SECRET_LEN, &c, tok, sizeof tok) == 0, "sign");
    check(verify(tok, &got) == ACCESS_TOKEN_OK, "round trip verifies");
    check(!strcmp(got.sub, c.sub) && got.ngroups == 2 && got.exp == c.exp &&
          !strcmp(got.group[0], "staff") && !strcmp(got.group[1], "board-2026"),
          "round trip keeps sub, groups, exp");
    check(access_claims_has_group(&got, "board-2026") &&
          !access_claims_has_group(&got, "board"), "has_group is exact");
    /* The payload is the compact JSON of the format. */
    uint8_t pl[ACCESS_PAYLOAD_MAX];
    size_t pn;
    const char *dot = strchr(tok, '.');
    access_b64url_decode(tok, (size_t)(dot - tok), pl, sizeof pl, &pn);
    char want[200];
    snprintf(want, sizeof want, "{\"sub\":\"ann@example.org\",\"groups\":"
             "[\"staff\",\"board-2026\"],\"exp\":%lld}", NOW + 60);
    check(pn == strlen(want) && !memcmp(pl, want, pn), "payload: %.*s", (int)pn, pl);
    /* iat: written when set, read back; absent reads 0; not an integer
     * (or 0) is malformed. */
    c.iat = NOW - 5;
    access_token_sign(SECRET, SECRET_LEN, &c, tok, sizeof tok);
    dot = strchr(tok, '.');
    access_b64url_decode(tok, (size_t)(dot - tok), pl, sizeof pl, &pn);
    snprintf(want, sizeof want, "{\"sub\":\"ann@example.org\",\"groups\":"
             "[\"staff\",\"board-2026\"],\"exp\":%lld,\"iat\":%lld}", NOW + 60, NOW - 5);
    check(pn == strlen(want) && !memcmp(pl, want, pn), "payload with iat: %.*s", (int)pn, pl);
    check(verify(tok, &got) == ACCESS_TOKEN_OK && got.iat == NOW - 5, "iat round trip");
    check(parse_text("{\"groups\":[],\"exp\":5}", &got) == 0 && got.iat == 0,
          "no iat: 0");
    check(parse_text("{\"groups\":[],\"exp\":5,\"iat\":0}", &got) < 0,
          "iat 0: malformed");
    check(parse_text("{\"groups\":[],\"exp\":5,\"iat\":\"1\"}", &got) < 0,
          "iat a string: malformed");
    c.iat = 0;

    /* Expiry: exp == now is expired, exp == now + 1 is not. */
    c.exp = NOW;
    access_token_sign(SECRET, SECRET_LEN, &c, tok, sizeof tok);
    check(verify(tok, &got) == ACCESS_TOKEN_EXPIRED && got.ngroups == 0,
          "exp == now: expired, claims zeroed");
    c.exp = NOW + 1;
    access_token_sign(SECRET, SECRET_LEN, &c, tok, sizeof tok);
    check(verify(tok, &got) == ACCESS_TOKEN_OK, "exp == now + 1: valid");

    /* Forgeries. */
    char t2[sizeof tok];
    strcpy(t2, tok);
    char *m = strchr(t2, '.') + 1;
    m[0] = m[0] == 'A' ? 'B' : 'A';
    check(verify(t2, &got) == ACCESS_TOKEN_FORGED, "a changed MAC: forged");
    strcpy(t2, tok);
    t2[5] = t2[5] == 'A' ? 'B' : 'A';
    enum access_token_status st = verify(t2, &got);
    check(st == ACCESS_TOKEN_FORGED || st == ACCESS_TOKEN_MALFORMED,
          "a changed payload byte: refused (%s)", access_token_status_name(st));
    struct access_claims c2 = c;
    c2.ngroups = 3;
    strcpy(c2.group[2], "admin");
    char other[sizeof tok];
    access_token_sign(SECRET, SECRET_LEN, &c2, other, sizeof other);
    snprintf(t2, sizeof t2, "%.*s%s", (int)(strchr(other, '.') - other), other,
             strchr(tok, '.'));
    check(verify(t2, &got) == ACCESS_TOKEN_FORGED,
          "another payload under the same MAC: forged");
    check(access_token_verify(tok, (const uint8_t *)"another secret of 32 bytes or so!",
                              33, NOW, &got) == ACCESS_TOKEN_FORGED,
          "another secret: forged");

    /* Malformed encodings. */
    static const char *const bad[] = {"", ".", "abc", "a.b.c", "..", "Zm9v.",
        ".Zm9v", "Zm9v.Zm9v", "Zm9v.Zm9v.Zm9v", "eyJ9.!!!!", "Zm9v=.AAAA"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        check(verify(bad[i], &got) == ACCESS_TOKEN_MALFORMED,
              "malformed: \"%s\"", bad[i]);
    static char huge[ACCESS_TOKEN_MAX + 100];
    memset(huge, 'A', sizeof huge - 1);
    huge[100] = '.';
    check(verify(huge, &got) == ACCESS_TOKEN_MALFORMED, "longer than %d: malformed",
          ACCESS_TOKEN_MAX);
    strcpy(t2, tok);
    t2[strlen(t2) - 1] = '\0'; /* a MAC one character short: 31.x bytes */
    check(verify(t2, &got) == ACCESS_TOKEN_MALFORMED, "a truncated MAC: malformed");

    /* Payloads under a good MAC that are not a token's JSON. */
    static const char *const payloads[] = {
        "not json", "[]", "\"str\"", "{}", "{\"groups\":[]}",
        "{\"exp\":\"1900000000\",\"groups\":[]}",
        "{\"exp\":1900000000.5,\"groups\":[]}",
        "{\"exp\":0,\"groups\":[]}", "{\"exp\":-5,\"groups\":[]}",
        "{\"exp\":9007199254740992,\"groups\":[]}",
        "{\"exp\":99999999999999999999999,\"groups\":[]}",
        "{\"exp\":1e400,\"groups\":[]}",
        "{\"exp\":1900000000}",
        "{\"exp\":1900000000,\"groups\":\"staff\"}",
        "{\"exp\":1900000000,\"groups\":[1]}",
        "{\"exp\":1900000000,\"groups\":[\"\"]}",
        "{\"exp\":1900000000,\"groups\":[\"a b\"]}",
        "{\"exp\":1900000000,\"groups\":[\"a\\u0000b\"]}",
        "{\"exp\":1900000000,\"groups\":[\"x\"],\"sub\":7}",
        "{\"exp\":1900000000,\"groups\":[\"x\"],\"sub\":\"a\\nb\"}",
        "{\"exp\":1900000000,\"groups\":[\"x\"],\"exp\":1900000001}",
        "{\"exp\":1900000000,\"groups\":[[[[[[[[[[[[]]]]]]]]]]]]}",
        "{\"exp\":1900000000,\"groups\":[\"x\"]} trailing",
    };
    for (size_t i = 0; i < sizeof payloads / sizeof payloads[0]; i++) {
        signed_raw(payloads[i], t2, sizeof t2);
        check(verify(t2, &got) == ACCESS_TOKEN_MALFORMED && got.exp == 0,
              "signed but refused: %s", payloads[i]);
    }
    char p[ACCESS_PAYLOAD_MAX + 200];
    int n = snprintf(p, sizeof p, "{\"exp\":1900000000,\"groups\":[");
    for (int i = 0; i <= ACCESS_GROUPS_MAX; i++)
        n += snprintf(p + n, sizeof p - (size_t)n, "%s\"g%d\"", i ? "," : "", i);
    snprintf(p + n, sizeof p - (size_t)n, "]}");
    signed_raw(p, t2, sizeof t2);
    check(verify(t2, &got) == ACCESS_TOKEN_MALFORMED, "%d groups: refused",
          ACCESS_GROUPS_MAX + 1);
    n = snprintf(p, sizeof p, "{\"exp\":1900000000,\"groups\":[\"");
    memset(p + n, 'g', ACCESS_GROUP_MAX + 1);
    snprintf(p + n + ACCESS_GROUP_MAX + 1, sizeof p - (size_t)n - ACCESS_GROUP_MAX - 1, "\"]}");
    signed_raw(p, t2, sizeof t2);
    check(verify(t2, &got) == ACCESS_TOKEN_MALFORMED, "a group of %d bytes: refused",
          ACCESS_GROUP_MAX + 1);
    n = snprintf(p, sizeof p, "{\"exp\":1900000000,\"groups\":[],\"sub\":\"");
    memset(p + n, 's', ACCESS_SUB_MAX + 1);
    snprintf(p + n + ACCESS_SUB_MAX + 1, sizeof p - (size_t)n - ACCESS_SUB_MAX - 1, "\"}");
    signed_raw(p, t2, sizeof t2);
    check(verify(t2, &got) == ACCESS_TOKEN_MALFORMED, "a sub of %d bytes: refused",
          ACCESS_SUB_MAX + 1);
    signed_raw("{\"exp\":1900000000,\"groups\":[\"x\"],\"iat\":1,\"aud\":\"y\"}", t2, sizeof t2);
    check(verify(t2, &got) == ACCESS_TOKEN_OK && got.sub[0] == '\0',
          "unknown members are ignored; sub defaults to \"\"");

    /* Signing refuses what verifying would refuse. */
    c2 = c;
    strcpy(c2.group[0], "bad group");
    check(access_token_sign(SECRET, SECRET_LEN, &c2, tok, sizeof tok) < 0,
          "sign refuses a bad group name");
    c2 = c;
    c2.exp = 0;
    check(access_token_sign(SECRET, SECRET_LEN, &c2, tok, sizeof tok) < 0,
          "sign refuses exp 0");
    c2 = c;
    check(access_token_sign(SECRET, SECRET_LEN, &c2, tok, 20) < 0,
          "sign refuses a buffer too small");
}

int main(void)
{
    test_sha256();
    test_hmac();
    test_base64url();
    test_tokens();
    return tap_done();
}
