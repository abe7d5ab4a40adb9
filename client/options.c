/*
 * options.c - strict number parsing for command-line options (options.h).
 * strtoull alone would accept "-5" (as a huge number) and leading spaces.
 */
#include <limits.h>

#include "options.h"

int parse_count(const char *s, unsigned long long *out)
{
    unsigned long long v = 0;
    if (!*s)
        return -1;
    for (; *s; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        unsigned d = (unsigned)(*s - '0');
        if (v > (ULLONG_MAX - d) / 10)
            return -1;
        v = v * 10 + d;
    }
    if (v == 0)
        return -1;
    *out = v;
    return 0;
}
