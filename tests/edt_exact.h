/*
 * edt_exact.h - exact Euclidean distance transforms, the yardsticks of
 * tests/test_edt_cpu.c and bench/edt_bench.c: Felzenszwalb-Huttenlocher
 * ("Distance Transforms of Sampled Functions", 2012) in exact integer
 * arithmetic, and brute force for tiny images to check it.
 *
 * Input: a w x h id image, rows packed; a pixel is a site when its id is
 * not 0.  Output: the squared distance to the nearest site per pixel, or
 * EDT_EXACT_NONE when the image has no site.
 */
#ifndef GV_TESTS_EDT_EXACT_H
#define GV_TESTS_EDT_EXACT_H

#include <stdint.h>

#define EDT_EXACT_NONE UINT64_MAX

/* Largest w and h edt_exact_d2 accepts: keeps every product of its
 * rational comparisons inside int64. */
#define EDT_EXACT_MAX_DIM (1u << 20)

/* Felzenszwalb-Huttenlocher, O(w*h).  Returns 0, or -1 when w or h is 0
 * or too large, or memory runs out. */
int edt_exact_d2(const uint32_t *ids, uint32_t w, uint32_t h, uint64_t *d2);

/* Every pixel against every site, O(w*h*sites). */
void edt_brute_d2(const uint32_t *ids, uint32_t w, uint32_t h, uint64_t *d2);

#endif
