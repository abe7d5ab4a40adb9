/*
 * sse.c - the squared error between two 8-bit images (sse.h).
 *
 * The encoders measure every tile they code, some twice (the prediction
 * alone, then what they chose), and a plain loop over the 789,507 samples
 * of an RGB tile was 2 to 3 % of an encode.  With AVX2 the differences are
 * widened to 16 bits and squared and summed in pairs by VPMADDWD; a row's
 * sums stay in 32 bits (each lane adds at most n / 16 pairs of 2 x 255^2,
 * under 2^31 for n <= 2^15) and the rows' in 64.  The kernel is picked
 * from gv_cpu_flags() (base/cpu.h) into a one-entry table.
 */
#include "base/cpu.h"
#include "codec/sse.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>
#endif

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

#if GV_HAVE_X86_SIMD
__attribute__((target("avx2"))) static uint64_t
sse_avx2(const uint8_t *a, const uint8_t *b, uint32_t n, uint32_t rows,
         size_t stride)
{
    uint64_t e = 0;
    for (uint32_t y = 0; y < rows; y++) {
        const uint8_t *ra = a + (size_t)y * stride, *rb = b + (size_t)y * stride;
        __m256i acc = _mm256_setzero_si256();
        uint32_t i = 0;
        for (; i + 16 <= n; i += 16) {
            const __m256i d = _mm256_sub_epi16(
                _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(ra + i))),
                _mm256_cvtepu8_epi16(_mm_loadu_si128((const __m128i *)(rb + i))));
            acc = _mm256_add_epi32(acc, _mm256_madd_epi16(d, d));
        }
        uint32_t lanes[8];
        _mm256_storeu_si256((__m256i *)lanes, acc);
        uint64_t row = 0;
        for (int l = 0; l < 8; l++)
            row += lanes[l];
        for (; i < n; i++) {
            const int d = (int)ra[i] - rb[i];
            row += (uint64_t)(d * d);
        }
        e += row;
    }
    return e;
}
#endif

typedef uint64_t sse_fn(const uint8_t *, const uint8_t *, uint32_t, uint32_t,
                       size_t);

static sse_fn *sse_kernel = sse_plain;
static struct gv_cpu_once sse_once = GV_CPU_ONCE_INIT;

static void sse_dsp_init(unsigned flags)
{
    sse_kernel = sse_plain;
#if GV_HAVE_X86_SIMD
    if (flags & GV_CPU_AVX2)
        sse_kernel = sse_avx2;
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
