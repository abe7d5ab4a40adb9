/*
 * edt_avx512.c - the distance transform's line kernels in AVX-512
 * (filters/edt_kernel.h instantiated for both state layouts; edt_int.h
 * declares the two tables).
 *
 * Compiled with -mavx512f (Makefile.am, filters/x86/libgvfilter_avx512.a):
 * nothing here may run before edt_cpu.c has checked GV_CPU_AVX512.
 */
#include "base/cpu.h"
#include "edt_int.h"

#if GV_HAVE_X86_SIMD
#include <string.h>

#include <immintrin.h>

#define EDT_ISA 3
#define EDT_PACKED 0
#define EDT_SUFFIX avx512_w
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#define EDT_PACKED 1
#define EDT_SUFFIX avx512_p
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#undef EDT_ISA

const struct edt_kernels gv_edt_avx512_wide = {
    edt_line_avx512_w, edt_dist_avx512_w, edt_load_avx512_w, edt_store_avx512_w};
const struct edt_kernels gv_edt_avx512_packed = {
    edt_line_avx512_p, edt_dist_avx512_p, edt_load_avx512_p, edt_store_avx512_p};
#endif
