/*
 * sha256.h - SHA-256 (FIPS 180-4) and HMAC-SHA256 (RFC 2104), for the
 * signed access tokens of gigaviewd (server/access_token.h).
 *
 * A plain, portable implementation: no table beyond the 64 round
 * constants, no assembly.  Checked against the FIPS 180-4 examples and
 * the RFC 4231 HMAC test vectors (tests/test_access_token.c).  Every
 * function is pure and thread-safe.
 */
#ifndef GV_SHA256_H
#define GV_SHA256_H

#include <stddef.h>
#include <stdint.h>

#define GV_SHA256_BYTES 32
#define GV_SHA256_BLOCK 64

struct gv_sha256 {
    uint32_t h[8];
    uint64_t len;                  /* bytes hashed so far */
    uint8_t buf[GV_SHA256_BLOCK];  /* a partial block */
    size_t nbuf;
};

/* Start, feed any number of bytes (len 0 is fine), finish into out.
 * After gv_sha256_final the context must be started again. */
void gv_sha256_init(struct gv_sha256 *s);
void gv_sha256_update(struct gv_sha256 *s, const void *data, size_t len);
void gv_sha256_final(struct gv_sha256 *s, uint8_t out[GV_SHA256_BYTES]);

/* SHA-256 of len bytes in one call. */
void gv_sha256(const void *data, size_t len, uint8_t out[GV_SHA256_BYTES]);

/* HMAC-SHA256 of msg under key (any length: a key longer than a block is
 * hashed first, as RFC 2104 says). */
void gv_hmac_sha256(const void *key, size_t key_len, const void *msg,
                    size_t msg_len, uint8_t out[GV_SHA256_BYTES]);

/* 1 if the n bytes at a and b are equal, else 0, in a time that depends
 * on n only (for MACs and secrets). */
int gv_equal_ct(const void *a, const void *b, size_t n);

#endif
