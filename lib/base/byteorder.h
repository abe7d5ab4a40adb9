/*
 * byteorder.h - little-endian loads and stores of 16, 32 and 64-bit
 * integers, byte by byte, so they are alignment- and host-independent.
 * Every file format of gigaview (stores, tiles, shards, the filter job
 * protocol) is little-endian and goes through these.
 */
#ifndef GV_BYTEORDER_H
#define GV_BYTEORDER_H

#include <stdint.h>

static inline void gv_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void gv_put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static inline void gv_put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static inline uint16_t gv_get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | p[1] << 8);
}
static inline uint32_t gv_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}
static inline uint64_t gv_get64(const uint8_t *p)
{
    return (uint64_t)gv_get32(p) | (uint64_t)gv_get32(p + 4) << 32;
}

#endif
