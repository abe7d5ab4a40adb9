/*
 * vq_avx512.h - the AVX-512 kernel of vq_nearest and vq_nearest_warm
 * (codec/vq.h), for vq.c's table only.
 */
#ifndef GV_VQ_AVX512_H
#define GV_VQ_AVX512_H

#include <stddef.h>
#include <stdint.h>

#include "codec/vq.h"

/* vq_nearest (warm 0) or vq_nearest_warm (warm 1), the same answers;
 * only where gv_cpu_flags() has GV_CPU_AVX512. */
void gv_vq_nearest_avx512(const struct vq_search *s, const int16_t *vecs,
                          size_t n, uint16_t *idx, uint32_t *dist, int warm);

#endif
