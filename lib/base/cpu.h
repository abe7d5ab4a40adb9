/*
 * cpu.h - what the CPU can run, found once, and the one switch that
 * narrows it (GIGAVIEW_SIMD).
 *
 * Every SIMD kernel of gigaview is chosen from these flags and nothing
 * else, in the manner of dav1d's and libjpeg-turbo's CPU dispatch: each
 * kernel group keeps a table of function pointers that its *_dsp_init
 * fills from gv_cpu_flags(), on first use (gv_cpu_once).  Every path of a
 * kernel gives the same bytes; the flags choose only the speed.
 *
 * GIGAVIEW_SIMD in the environment caps the flags by level:
 *   c       none: the portable C kernels everywhere
 *   avx2    GV_CPU_SSE2, SSSE3, POPCNT, AVX2 and FMA (x86-64-v3's SIMD)
 *   avx512  also GV_CPU_AVX512 (AVX-512 F and BW, the subsets every
 *           AVX-512 kernel uses) and, within it, the finer VBMI and VNNI
 *           flags that only some kernels need (the prediction's level 3,
 *           layout D's rANS lanes)
 *   max     (the default) everything the CPU has
 * A level grants only what the CPU also has: avx512 on an AVX2 machine is
 * avx2.  An unknown value is reported on stderr once and read as max.
 *
 * GV_HAVE_X86_SIMD is the one compile-time guard of the x86 kernels: 1
 * where the compiler can build them (x86-64, GCC or Clang), else 0, and
 * every flag is then 0.
 */
#ifndef GV_CPU_H
#define GV_CPU_H

#include <pthread.h>
#include <stdatomic.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define GV_HAVE_X86_SIMD 1
#else
#define GV_HAVE_X86_SIMD 0
#endif

enum {
    GV_CPU_SSE2 = 1u << 0,
    GV_CPU_SSSE3 = 1u << 1,
    GV_CPU_POPCNT = 1u << 2,
    GV_CPU_AVX2 = 1u << 3,
    GV_CPU_FMA = 1u << 4,
    GV_CPU_AVX512 = 1u << 5,       /* AVX-512 F and BW */
    GV_CPU_AVX512VBMI = 1u << 6,   /* only with GV_CPU_AVX512 */
    GV_CPU_AVX512VNNI = 1u << 7,   /* only with GV_CPU_AVX512 */
};

/* The masks of the levels of GIGAVIEW_SIMD. */
#define GV_CPU_LEVEL_C 0u
#define GV_CPU_LEVEL_AVX2 \
    (GV_CPU_SSE2 | GV_CPU_SSSE3 | GV_CPU_POPCNT | GV_CPU_AVX2 | GV_CPU_FMA)
#define GV_CPU_LEVEL_AVX512 \
    (GV_CPU_LEVEL_AVX2 | GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_AVX512VNNI)
#define GV_CPU_LEVEL_MAX (~0u)

/*
 * The flags the kernels may use: the CPU's, masked by GIGAVIEW_SIMD (read
 * once) and by gv_cpu_set_mask.  Thread-safe; the first call finds them.
 */
unsigned gv_cpu_flags(void);

/* The CPU's own flags, unmasked (what a test could force). */
unsigned gv_cpu_flags_raw(void);

/*
 * For tests and benchmarks: replace the mask (GIGAVIEW_SIMD's, or an
 * earlier call's) by `mask` (a GV_CPU_LEVEL_* or any set of flags; only
 * what the CPU has is granted).  Every kernel table is filled again on its
 * next use.  Returns the flags now in effect.  Call it while no codec
 * function runs on another thread.
 */
unsigned gv_cpu_set_mask(unsigned mask);

/* The mask of a GIGAVIEW_SIMD level name ("c", "avx2", "avx512", "max"),
 * or 0 with *ok = 0 for anything else. */
unsigned gv_cpu_level_mask(const char *name, int *ok);

/*
 * A kernel group's table, filled by init(gv_cpu_flags()) on its first use
 * and again after each gv_cpu_set_mask.  Thread-safe: callers wait for a
 * fill in progress.  Use one static struct gv_cpu_once per table,
 * initialized with GV_CPU_ONCE_INIT.
 */
struct gv_cpu_once {
    pthread_mutex_t lock;
    atomic_uint filled;   /* the mask generation it was filled for; 0: never */
};
#define GV_CPU_ONCE_INIT {PTHREAD_MUTEX_INITIALIZER, 0}

extern atomic_uint gv_cpu_generation_;   /* private to cpu.c and gv_cpu_once */
void gv_cpu_once_fill_(struct gv_cpu_once *o, void (*init)(unsigned flags));

static inline void gv_cpu_once(struct gv_cpu_once *o, void (*init)(unsigned flags))
{
    if (atomic_load_explicit(&o->filled, memory_order_acquire) !=
        atomic_load_explicit(&gv_cpu_generation_, memory_order_relaxed))
        gv_cpu_once_fill_(o, init);
}

#endif
