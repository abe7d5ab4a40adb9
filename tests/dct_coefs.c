/*
 * dct_coefs.c - a test helper: the coefficient planes that the CPU
 * reference decoder unpacks (gv_dct_unpack, lib/codec/tile_dct.h) from
 * layout-D tile buffers (docs/FORMAT.md section 4.3), for
 * tests/browser/dct_unpack.mjs, which checks the browser's port
 * (client/web/tile_dct.js) against them, intact buffers and damaged ones.
 *
 *   dct_coefs < RECORDS > LINES
 *   dct_coefs --fixtures > RECORDS
 *   dct_coefs --fixture-tiles CHANNELS > TILES
 *
 * RECORDS: any number of [u32 length, little-endian][u8 channels][length
 * bytes of buffer].  LINES: one per record, "ok HASH NONZERO" (HASH the
 * 32-bit FNV-1a, 8 hex digits, of the 520 x 520 x 4 int16 plane as
 * little-endian bytes; NONZERO its count of nonzero coefficients) or
 * "corrupt MESSAGE" when gv_dct_unpack refuses the buffer.  --fixtures
 * writes the buffers an encoder rarely makes, from tests/dct_fixture.h
 * (written from the format's text, not from lib/codec), for gray and RGB:
 * escapes over their whole range, steps of 4095 whose products clamp to
 * 16 bits, every coefficient of every block coded, none at all.
 * --fixture-tiles writes, for the fixtures of CHANNELS (1 or 3), what a
 * decoder of whole tiles is checked with (tests/browser/viewer.mjs, in
 * WebGL2): [u32 length][u8 channels][u8 qx][u8 qy][u8 0][buffer][parent:
 * 513 x 513 x CHANNELS bytes][gv_tile_decode's tile of that parent and
 * quadrant].  Exit 0, or 1 with a message on stderr on a malformed record
 * stream.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/error.h"
#include "codec/tile.h"
#include "codec/tile_dct.h"
#include "codec/tile_layout.h"
#include "dct_fixture.h"

#define PLANE (520u * 520u * 4u)
#define MAX_RECORD (16u << 20)

/* The fixtures as records (only = 0: gray and RGB), or as whole tiles of
 * `only` channels with a parent and their CPU decoding (--fixture-tiles). */
static int write_fixtures(int only)
{
    int rc = 1;
    int *q = malloc(sizeof *q * 3 * 520 * 520);
    uint8_t *buf = malloc(2u << 20);
    uint8_t *parent = malloc(gv_tile_bytes(3)), *out = malloc(gv_tile_bytes(3));
    uint64_t seed = 0x9e3779b97f4a7c15u, pseed = 0x2545f4914f6cdd1du;
    if (!q || !buf || !parent || !out) {
        fprintf(stderr, "dct_coefs: out of memory\n");
        goto done;
    }
    for (int channels = 1; channels <= 3; channels += 2)
        for (int k = 0; k < DCT_FIXTURE_CASES; k++) {
            int S[3];
            dct_fixture_case(k, channels, &seed, q, S);
            if (only && channels != only)
                continue;
            const size_t len = dct_fixture_write(q, S, channels, buf);
            const int qx = k & 1, qy = k >> 1 & 1;
            const uint8_t head[5] = {(uint8_t)len, (uint8_t)(len >> 8), (uint8_t)(len >> 16),
                                     (uint8_t)(len >> 24), (uint8_t)channels};
            const uint8_t quad[4] = {(uint8_t)qx, (uint8_t)qy, 0, 0};
            fwrite(head, 1, sizeof head, stdout);
            if (only)
                fwrite(quad, 1, sizeof quad, stdout);
            fwrite(buf, 1, len, stdout);
            if (!only)
                continue;
            /* A parent with gradients, noise and distinct channels. */
            const size_t tb = gv_tile_bytes(channels);
            for (size_t i = 0; i < tb; i++) {
                const size_t p = i / (size_t)channels;
                parent[i] = (uint8_t)(p % 513 / 3 + p / 513 / 4 + test_rand(&pseed) % 8 +
                                      40 * (i % (size_t)channels));
            }
            struct gv_error err = {0};
            if (gv_tile_decode(buf, len, channels, parent, qx, qy, out, &err) < 0) {
                fprintf(stderr, "dct_coefs: fixture %d: %s\n", k, err.text);
                goto done;
            }
            fwrite(parent, 1, tb, stdout);
            fwrite(out, 1, tb, stdout);
        }
    rc = fflush(stdout) == 0 ? 0 : 1;
done:
    free(q);
    free(buf);
    free(parent);
    free(out);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--fixtures") == 0)
        return write_fixtures(0);
    if (argc == 3 && strcmp(argv[1], "--fixture-tiles") == 0 &&
        (strcmp(argv[2], "1") == 0 || strcmp(argv[2], "3") == 0))
        return write_fixtures(argv[2][0] - '0');
    if (argc != 1) {
        fprintf(stderr, "usage: dct_coefs [--fixtures | --fixture-tiles 1|3]\n");
        return 1;
    }
    int rc = 1;
    int16_t *coefs = malloc(PLANE * sizeof *coefs);
    uint8_t *buf = malloc(MAX_RECORD);
    if (!coefs || !buf) {
        fprintf(stderr, "dct_coefs: out of memory\n");
        goto out;
    }
    for (;;) {
        uint8_t head[5];
        size_t got = fread(head, 1, sizeof head, stdin);
        if (got == 0 && feof(stdin))
            break;
        if (got != sizeof head) {
            fprintf(stderr, "dct_coefs: a record header is cut short\n");
            goto out;
        }
        uint32_t len = (uint32_t)head[0] | (uint32_t)head[1] << 8 |
                       (uint32_t)head[2] << 16 | (uint32_t)head[3] << 24;
        if (len > MAX_RECORD || fread(buf, 1, len, stdin) != len) {
            fprintf(stderr, "dct_coefs: a record of %u bytes is cut short or too long\n", len);
            goto out;
        }
        struct gv_error err = { 0 };
        if (gv_dct_unpack(buf, len, head[4], coefs, &err) < 0) {
            printf("corrupt %s\n", err.text);
            continue;
        }
        uint32_t h = 0x811c9dc5u, nonzero = 0;
        for (uint32_t i = 0; i < PLANE; i++) {
            uint16_t v = (uint16_t)coefs[i];
            h = (h ^ (v & 0xffu)) * 16777619u;
            h = (h ^ (uint32_t)(v >> 8)) * 16777619u;
            nonzero += coefs[i] != 0;
        }
        printf("ok %08x %u\n", h, nonzero);
    }
    rc = 0;
out:
    free(coefs);
    free(buf);
    return rc;
}
