/*
 * parse_uint.h - the one grammar for unsigned numbers and sizes that
 * people write: gigaviewd.conf's values (server/settings.c) and the
 * command line's sizes (gigaview encode --max-decoder-memory).
 *
 * Digits only (no sign, no spaces); a size may end in K, M, G or T
 * (powers of 1024, either case), then "i" and "B" (either case), as
 * "64K", "1GiB", "16mb".  Header-only, so that anything may use it
 * without linking lib/base.
 */
#ifndef GV_PARSE_UINT_H
#define GV_PARSE_UINT_H

#include <errno.h>
#include <stdint.h>
#include <stdlib.h>

/* Parse s into *out: an unsigned number, or with sizes set a size as
 * above.  Returns 0, or -1 when s is not one or passes 64 bits (*out is
 * then left alone). */
static inline int gv_parse_uint(const char *s, int sizes, uint64_t *out)
{
    if (*s < '0' || *s > '9')
        return -1;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno == ERANGE)
        return -1;
    int shift = 0;
    if (sizes && *end) {
        switch (*end) {
        case 'k': case 'K': shift = 10; break;
        case 'm': case 'M': shift = 20; break;
        case 'g': case 'G': shift = 30; break;
        case 't': case 'T': shift = 40; break;
        default: return -1;
        }
        end++;
        if (*end == 'i' || *end == 'I')
            end++;
        if (*end == 'b' || *end == 'B')
            end++;
    }
    if (*end)
        return -1;
    if (shift && v > (UINT64_MAX >> shift))
        return -1;
    *out = (uint64_t)v << shift;
    return 0;
}

#endif
