/*
 * dct_coefs.c - a test helper: the coefficient planes that the CPU
 * reference decoder unpacks (gv_dct_unpack, lib/codec/tile_dct.h) from
 * layout-D tile buffers (docs/FORMAT.md section 4.3), for
 * tests/browser/dct_unpack.mjs, which checks the browser's port
 * (client/web/tile_dct.js) against them, intact buffers and damaged ones.
 *
 *   dct_coefs < RECORDS > LINES
 *
 * RECORDS: any number of [u32 length, little-endian][u8 channels][length
 * bytes of buffer].  LINES: one per record, "ok HASH NONZERO" (HASH the
 * 32-bit FNV-1a, 8 hex digits, of the 520 x 520 x 4 int16 plane as
 * little-endian bytes; NONZERO its count of nonzero coefficients) or
 * "corrupt MESSAGE" when gv_dct_unpack refuses the buffer.  Exit 0, or 1
 * with a message on stderr on a malformed record stream.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "base/error.h"
#include "codec/tile_dct.h"

#define PLANE (520u * 520u * 4u)
#define MAX_RECORD (16u << 20)

int main(void)
{
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
