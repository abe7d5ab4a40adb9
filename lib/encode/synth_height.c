/*
 * synth_height.c - the synthetic terrain of synth-height: (see
 * synth_height.h): integer value-noise fBm, 11 octaves from 2048-sample
 * cells down to 2, amplitude falling by 5/9 an octave (fractal dimension
 * about 2.5), ridged a little by folding.  Integer arithmetic only, so
 * every machine computes the same codes.
 */
#include <stdio.h>

#include "encode/synth_height.h"
#include "store/geometry.h"

/* Same shape as mix32 in encode/source.c and id_final in store/store_read.c:
 * deliberately separate, other constants, and each output is part of what a
 * store holds. */
static uint32_t hash2(uint32_t x, uint32_t y, uint32_t o)
{
    uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ o * 0xcb1ab31fu;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h *= 0x297a2d39u;
    h ^= h >> 15;
    return h;
}

/* Smoothstep in 16-bit fixed point: t in 0..65536. */
static int64_t smooth(int64_t t)
{
    return (t * t * (3 * 65536 - 2 * t)) >> 32;
}

/* One octave of cell size 2^shift at (x, y): -32768..32767. */
static int64_t octave(uint32_t x, uint32_t y, int shift, uint32_t o)
{
    uint32_t cx = x >> shift, cy = y >> shift;
    int64_t fx = smooth((int64_t)(x & ((1u << shift) - 1)) << (16 - shift));
    int64_t fy = smooth((int64_t)(y & ((1u << shift) - 1)) << (16 - shift));
    int64_t a = (int64_t)(hash2(cx, cy, o) >> 16) - 32768;
    int64_t b = (int64_t)(hash2(cx + 1, cy, o) >> 16) - 32768;
    int64_t c = (int64_t)(hash2(cx, cy + 1, o) >> 16) - 32768;
    int64_t d = (int64_t)(hash2(cx + 1, cy + 1, o) >> 16) - 32768;
    int64_t top = a + (((b - a) * fx) >> 16), bot = c + (((d - c) * fx) >> 16);
    return top + (((bot - top) * fy) >> 16);
}

/* Terrain code at (x, y), in metres, about 0 .. 7000. */
static uint16_t synth_height(uint32_t x, uint32_t y)
{
    int64_t s = 0;
    for (int k = 11, amp = 1024; k >= 1; k--, amp = amp * 5 / 9)
        s += octave(x, y, k, (uint32_t)k) * amp;
    s >>= 11;                       /* about -6000 .. 6000 */
    int64_t v = s < 0 ? -s / 4 : s; /* shallow "sea floor" below 0 */
    v += 1000;
    return (uint16_t)(v < 0 ? 0 : (v > 65535 ? 65535 : v));
}

int gv_synth_height_parse(const char *spec, uint32_t *w, uint32_t *h)
{
    unsigned long long a, b;
    char tail;
    if (sscanf(spec, "synth-height:%llux%llu%c", &a, &b, &tail) != 2 || !a ||
        !b || a > GV_MAX_DIM || b > GV_MAX_DIM)
        return -1;
    *w = (uint32_t)a;
    *h = (uint32_t)b;
    return 0;
}

void gv_synth_height_row(uint32_t y, uint32_t x0, uint32_t w, uint16_t *out)
{
    for (uint32_t x = 0; x < w; x++)
        out[x] = synth_height(x0 + x, y);
}
