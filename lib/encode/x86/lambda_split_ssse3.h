/*
 * lambda_split_ssse3.h - the SSSE3 kernel of the lambda model's row
 * split (encode/lambda_model.c), for its table only.
 */
#ifndef GV_LAMBDA_SPLIT_SSSE3_H
#define GV_LAMBDA_SPLIT_SSSE3_H

#include <stdint.h>

/* Blocks [0, 4 * (bw / 4)) of an RGB row (6 bytes a 2x1 block) split
 * into 3 even and 3 odd bytes each, at even + 3 bx and odd + 3 bx;
 * writes up to 4 bytes past them.  Returns the blocks done.  Only where
 * gv_cpu_flags() has GV_CPU_SSSE3. */
uint32_t gv_lambda_split_rgb_ssse3(const uint8_t *row, uint32_t bw,
                                   uint8_t *even, uint8_t *odd);

#endif
