/*
 * sha256.c - SHA-256 and HMAC-SHA256 (see sha256.h).
 *
 * The compression function follows FIPS 180-4 section 6.2.2 word for
 * word; the message is fed block by block, so memory is constant.
 */
#include <string.h>

#include "base/sha256.h"

/* FIPS 180-4 section 4.2.2: the first 32 bits of the fractional parts of
 * the cube roots of the first 64 primes. */
static const uint32_t K[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1,
    0x923f82a4, 0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3,
    0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786,
    0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147,
    0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13,
    0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
    0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a,
    0x5b9cca4f, 0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208,
    0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

static uint32_t ror(uint32_t x, int n)
{
    return (x >> n) | (x << (32 - n));
}

static void compress(uint32_t h[8], const uint8_t *p)
{
    uint32_t w[64];
    for (int t = 0; t < 16; t++)
        w[t] = (uint32_t)p[4 * t] << 24 | (uint32_t)p[4 * t + 1] << 16 |
               (uint32_t)p[4 * t + 2] << 8 | (uint32_t)p[4 * t + 3];
    for (int t = 16; t < 64; t++) {
        uint32_t s0 = ror(w[t - 15], 7) ^ ror(w[t - 15], 18) ^ (w[t - 15] >> 3);
        uint32_t s1 = ror(w[t - 2], 17) ^ ror(w[t - 2], 19) ^ (w[t - 2] >> 10);
        w[t] = w[t - 16] + s0 + w[t - 7] + s1;
    }
    uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5],
             g = h[6], k = h[7];
    for (int t = 0; t < 64; t++) {
        uint32_t t1 = k + (ror(e, 6) ^ ror(e, 11) ^ ror(e, 25)) +
                      ((e & f) ^ (~e & g)) + K[t] + w[t];
        uint32_t t2 = (ror(a, 2) ^ ror(a, 13) ^ ror(a, 22)) +
                      ((a & b) ^ (a & c) ^ (b & c));
        k = g;
        g = f;
        f = e;
        e = d + t1;
        d = c;
        c = b;
        b = a;
        a = t1 + t2;
    }
    h[0] += a;
    h[1] += b;
    h[2] += c;
    h[3] += d;
    h[4] += e;
    h[5] += f;
    h[6] += g;
    h[7] += k;
}

void gv_sha256_init(struct gv_sha256 *s)
{
    /* FIPS 180-4 section 5.3.3 */
    static const uint32_t h0[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372,
                                   0xa54ff53a, 0x510e527f, 0x9b05688c,
                                   0x1f83d9ab, 0x5be0cd19};
    memcpy(s->h, h0, sizeof h0);
    s->len = 0;
    s->nbuf = 0;
}

void gv_sha256_update(struct gv_sha256 *s, const void *data, size_t len)
{
    const uint8_t *p = data;
    s->len += len;
    if (s->nbuf) {
        size_t n = GV_SHA256_BLOCK - s->nbuf;
        if (n > len)
            n = len;
        memcpy(s->buf + s->nbuf, p, n);
        s->nbuf += n;
        p += n;
        len -= n;
        if (s->nbuf < GV_SHA256_BLOCK)
            return;
        compress(s->h, s->buf);
        s->nbuf = 0;
    }
    for (; len >= GV_SHA256_BLOCK; p += GV_SHA256_BLOCK, len -= GV_SHA256_BLOCK)
        compress(s->h, p);
    memcpy(s->buf, p, len);
    s->nbuf = len;
}

void gv_sha256_final(struct gv_sha256 *s, uint8_t out[GV_SHA256_BYTES])
{
    uint64_t bits = s->len * 8;
    /* Padding (section 5.1.1): 0x80, zeros to 56 mod 64, the length. */
    s->buf[s->nbuf++] = 0x80;
    if (s->nbuf > 56) {
        memset(s->buf + s->nbuf, 0, GV_SHA256_BLOCK - s->nbuf);
        compress(s->h, s->buf);
        s->nbuf = 0;
    }
    memset(s->buf + s->nbuf, 0, 56 - s->nbuf);
    for (int i = 0; i < 8; i++)
        s->buf[56 + i] = (uint8_t)(bits >> (56 - 8 * i));
    compress(s->h, s->buf);
    for (int i = 0; i < 8; i++) {
        out[4 * i] = (uint8_t)(s->h[i] >> 24);
        out[4 * i + 1] = (uint8_t)(s->h[i] >> 16);
        out[4 * i + 2] = (uint8_t)(s->h[i] >> 8);
        out[4 * i + 3] = (uint8_t)s->h[i];
    }
    memset(s->buf, 0, sizeof s->buf);
}

void gv_sha256(const void *data, size_t len, uint8_t out[GV_SHA256_BYTES])
{
    struct gv_sha256 s;
    gv_sha256_init(&s);
    gv_sha256_update(&s, data, len);
    gv_sha256_final(&s, out);
}

void gv_hmac_sha256(const void *key, size_t key_len, const void *msg,
                    size_t msg_len, uint8_t out[GV_SHA256_BYTES])
{
    uint8_t k[GV_SHA256_BLOCK] = {0}, pad[GV_SHA256_BLOCK],
            inner[GV_SHA256_BYTES];
    if (key_len > GV_SHA256_BLOCK)
        gv_sha256(key, key_len, k);
    else if (key_len)
        memcpy(k, key, key_len);
    struct gv_sha256 s;
    for (int i = 0; i < GV_SHA256_BLOCK; i++)
        pad[i] = k[i] ^ 0x36;
    gv_sha256_init(&s);
    gv_sha256_update(&s, pad, sizeof pad);
    gv_sha256_update(&s, msg, msg_len);
    gv_sha256_final(&s, inner);
    for (int i = 0; i < GV_SHA256_BLOCK; i++)
        pad[i] = k[i] ^ 0x5c;
    gv_sha256_init(&s);
    gv_sha256_update(&s, pad, sizeof pad);
    gv_sha256_update(&s, inner, sizeof inner);
    gv_sha256_final(&s, out);
    memset(k, 0, sizeof k);
    memset(pad, 0, sizeof pad);
}

int gv_equal_ct(const void *a, const void *b, size_t n)
{
    const volatile uint8_t *x = a, *y = b;
    uint8_t d = 0;
    for (size_t i = 0; i < n; i++)
        d |= (uint8_t)(x[i] ^ y[i]);
    return d == 0;
}
