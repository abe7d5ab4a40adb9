/*
 * sse.c - the squared error between two 8-bit images (sse.h).
 *
 * The encoders measure every tile they code, some twice (the prediction
 * alone, then what they chose), and a plain loop over the 789,507 samples
 * of an RGB tile was 2 to 3 % of an encode.  Where gv_cpu_flags()
 * (base/cpu.h) has AVX2 the one-entry table holds x86/sse_avx2.c's kernel
 * (16 samples a step), else the plain loop here.
 */
#include "base/cpu.h"
#include "codec/sse.h"
#include "codec/x86/sse_avx2.h"

static uint64_t sse_plain(const uint8_t *a, const uint8_t *b, uint32_t n,
                          uint32_t rows, size_t stride)
{
    uint64_t e = 0;
    for (uint32_t y = 0; y < rows; y++) {
        const uint8_t *ra = a + (size_t)y * stride, *rb = b + (size_t)y * stride;
        for (uint32_t i = 0; i < n; i++) {
            const int d = (int)ra[i] - rb[i];
            e += (uint64_t)(d * d);
        }
    }
    return e;
}

typedef uint64_t sse_fn(const uint8_t *, const uint8_t *, uint32_t, uint32_t,
                       size_t);

static sse_fn *sse_kernel = sse_plain;
static struct gv_cpu_once sse_once = GV_CPU_ONCE_INIT;

static void sse_dsp_init(unsigned flags)
{
    sse_kernel = sse_plain;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_AVX2)
        sse_kernel = gv_sse_u8_avx2;
#else
    (void)flags;
#endif
}

uint64_t gv_sse_u8(const uint8_t *a, const uint8_t *b, uint32_t n,
                   uint32_t rows, size_t stride)
{
    gv_cpu_once(&sse_once, sse_dsp_init);
    return sse_kernel(a, b, n, rows, stride);
}
