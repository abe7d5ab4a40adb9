/*
 * sse.h - the squared error between two 8-bit images, the measure every
 * encoder decision and the store's PSNR are made of.
 */
#ifndef GV_SSE_H
#define GV_SSE_H

#include <stddef.h>
#include <stdint.h>

/* Sum over `rows` rows of (a[i] - b[i])^2 for the first n samples of each
 * row, rows `stride` bytes apart in both.  Exact (integers), and the same
 * on every CPU; AVX2 where the CPU has it.  n at most 2^15. */
uint64_t gv_sse_u8(const uint8_t *a, const uint8_t *b, uint32_t n,
                   uint32_t rows, size_t stride);

#endif
