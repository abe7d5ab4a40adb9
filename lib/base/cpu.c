/*
 * cpu.c - the CPU's flags, found once, and their mask (cpu.h).
 *
 * The flags come from GCC's and Clang's __builtin_cpu_supports (which
 * reads cpuid and, for AVX and AVX-512, checks with xgetbv that the
 * operating system saves the wide registers); elsewhere they are 0 and
 * every kernel is portable C.  The mask starts as GIGAVIEW_SIMD's level;
 * gv_cpu_set_mask replaces it and bumps a generation number, which every
 * kernel table (gv_cpu_once) compares with the one it was filled for.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"

atomic_uint gv_cpu_generation_ = 1;

static pthread_once_t found_once = PTHREAD_ONCE_INIT;
static unsigned raw_flags;
static atomic_uint mask = GV_CPU_LEVEL_MAX;

static unsigned find_flags(void)
{
    unsigned f = 0;
#if GV_HAVE_X86_SIMD
    __builtin_cpu_init();
    if (__builtin_cpu_supports("sse2"))
        f |= GV_CPU_SSE2;
    if (__builtin_cpu_supports("ssse3"))
        f |= GV_CPU_SSSE3;
    if (__builtin_cpu_supports("popcnt"))
        f |= GV_CPU_POPCNT;
    if (__builtin_cpu_supports("avx2"))
        f |= GV_CPU_AVX2;
    if (__builtin_cpu_supports("fma"))
        f |= GV_CPU_FMA;
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw")) {
        f |= GV_CPU_AVX512;
        if (__builtin_cpu_supports("avx512vbmi"))
            f |= GV_CPU_AVX512VBMI;
        if (__builtin_cpu_supports("avx512vnni"))
            f |= GV_CPU_AVX512VNNI;
    }
#endif
    return f;
}

unsigned gv_cpu_level_mask(const char *name, int *ok)
{
    static const struct {
        const char *name;
        unsigned mask;
    } levels[] = {
        {"c", GV_CPU_LEVEL_C},
        {"avx2", GV_CPU_LEVEL_AVX2},
        {"avx512", GV_CPU_LEVEL_AVX512},
        {"max", GV_CPU_LEVEL_MAX},
    };
    for (size_t i = 0; name && i < sizeof levels / sizeof levels[0]; i++)
        if (strcmp(name, levels[i].name) == 0) {
            *ok = 1;
            return levels[i].mask;
        }
    *ok = 0;
    return 0;
}

static void find(void)
{
    raw_flags = find_flags();
    const char *env = getenv("GIGAVIEW_SIMD");
    if (env && *env) {
        int ok;
        const unsigned m = gv_cpu_level_mask(env, &ok);
        if (ok)
            atomic_store(&mask, m);
        else
            fprintf(stderr, "gigaview: GIGAVIEW_SIMD=%s is not c, avx2, "
                    "avx512 or max; using max\n", env);
    }
}

unsigned gv_cpu_flags_raw(void)
{
    pthread_once(&found_once, find);
    return raw_flags;
}

unsigned gv_cpu_flags(void)
{
    pthread_once(&found_once, find);
    return raw_flags & atomic_load(&mask);
}

unsigned gv_cpu_set_mask(unsigned m)
{
    pthread_once(&found_once, find);
    atomic_store(&mask, m);
    atomic_fetch_add(&gv_cpu_generation_, 1);
    return gv_cpu_flags();
}

void gv_cpu_once_fill_(struct gv_cpu_once *o, void (*init)(unsigned flags))
{
    pthread_mutex_lock(&o->lock);
    const unsigned gen = atomic_load(&gv_cpu_generation_);
    if (atomic_load_explicit(&o->filled, memory_order_relaxed) != gen) {
        init(gv_cpu_flags());
        atomic_store_explicit(&o->filled, gen, memory_order_release);
    }
    pthread_mutex_unlock(&o->lock);
}
