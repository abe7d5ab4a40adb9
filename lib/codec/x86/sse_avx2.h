/*
 * sse_avx2.h - the AVX2 kernel of gv_sse_u8 (codec/sse.h), for sse.c's
 * table only.
 */
#ifndef GV_SSE_AVX2_H
#define GV_SSE_AVX2_H

#include <stddef.h>
#include <stdint.h>

/* gv_sse_u8, the same result; only where gv_cpu_flags() has
 * GV_CPU_AVX2. */
uint64_t gv_sse_u8_avx2(const uint8_t *a, const uint8_t *b, uint32_t n,
                        uint32_t rows, size_t stride);

#endif
