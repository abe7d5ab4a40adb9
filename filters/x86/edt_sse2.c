/*
 * edt_sse2.c - the distance transform's line kernels in SSE2
 * (filters/edt_kernel.h instantiated for both state layouts; edt_int.h
 * declares the two tables).
 *
 * Compiled with the x86-64 baseline flags, which include SSE2
 * (Makefile.am, filters/libgvfilter.a); edt_cpu.c still picks it only
 * where gv_cpu_flags() has GV_CPU_SSE2.
 */
#include "base/cpu.h"
#include "edt_int.h"

#if GV_HAVE_X86_SIMD
#include <string.h>

#include <immintrin.h>

#define EDT_ISA 1
#define EDT_PACKED 0
#define EDT_SUFFIX sse2_w
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#define EDT_PACKED 1
#define EDT_SUFFIX sse2_p
#include "edt_kernel.h"
#undef EDT_SUFFIX
#undef EDT_PACKED
#undef EDT_ISA

const struct edt_kernels gv_edt_sse2_wide = {
    edt_line_sse2_w, edt_dist_sse2_w, edt_load_sse2_w, edt_store_sse2_w};
const struct edt_kernels gv_edt_sse2_packed = {
    edt_line_sse2_p, edt_dist_sse2_p, edt_load_sse2_p, edt_store_sse2_p};
#endif
