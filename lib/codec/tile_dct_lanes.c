/*
 * tile_dct_lanes.c - layout D's rANS streams (docs/FORMAT.md section 4.3)
 * decoded sixteen rows of blocks at a time, one row per 32-bit lane of
 * AVX-512 registers (Duda, "Asymmetric numeral systems", 2013, section
 * 3: the decoder's state x, one table look-up per symbol; the interleaved
 * states of Giesen, "Interleaved entropy coders", 2014, here sixteen
 * independent streams stepped together).
 *
 * The scalar decoder (tile_dct.c, decode_row) runs one dependent chain
 * per row: load the model entry, multiply, renormalize, pick the next
 * model; about 27 instructions and 6 cycles a symbol.  Here each lane is
 * that decoder as a small state machine, and one step advances every
 * lane by one rANS step:
 *   phase 0  the block's eob symbol (model 3 cc + pe[c]);
 *   phase 1  token k (model of band(k), channel class and the previous
 *            value's class p);
 *   phase 2, 3  the two uniform 6-bit steps after an escape;
 *   phase 4  done (the row's 65 x C blocks are decoded).
 * A step gathers every lane's model entry (VPGATHERDD on the 32-bit slot
 * table of load_models) and updates x; a renormalization takes its word
 * from the two words cached per lane, which one gather tops up whenever
 * some lane has none left (about a step in four).  The per-channel
 * contexts pe[3] and dcp[3] sit in one register each, two bits a channel;
 * the zigzag place and the band of coefficient k are VPERMT2B look-ups.
 *
 * The writes (coded nonzero coefficients, nonzero eobs) of a step go to
 * two logs, the int16 offset in the thread's arena and the value, each
 * compacted by VPCOMPRESSD in registers (VPCOMPRESSD to memory is slow on
 * Zen 4) and replayed by a scalar loop whenever the logs fill and at the
 * end.  Zero tokens are not written: the rows start all zero.
 *
 * Damage: the lanes check what decode_row checks (a zero frequency, a
 * renormalization past the stream's words, a start below 2^16, the end
 * state and position, every cached word used); on any of it the whole
 * group is abandoned, its rows zeroed, and the caller decodes them again
 * by decode_row, which gives the message of the first damaged row.  Lanes that finish early
 * idle until the group's longest row ends.
 *
 * The lanes themselves are x86/tile_dct_lanes_avx512.c (compiled with
 * AVX-512 VBMI); this file keeps the choice (gv_cpu_flags(), base/cpu.h),
 * the threads' arenas and the bookkeeping around a group.
 */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/tile_dct_lanes.h"
#include "codec/x86/tile_dct_lanes_avx512.h"

/* The lanes need AVX-512 F, BW and VBMI, and POPCNT (base/cpu.h); the
 * choice is made once per mask, as every kernel's is. */
#define LANES_FLAGS (GV_CPU_AVX512 | GV_CPU_AVX512VBMI | GV_CPU_POPCNT)

static int lanes_on;
static struct gv_cpu_once lanes_once = GV_CPU_ONCE_INIT;

static void lanes_dsp_init(unsigned flags)
{
    lanes_on = GV_HAVE_X86_SIMD && (flags & LANES_FLAGS) == LANES_FLAGS;
}

int gv_dct_lanes_usable(void)
{
    gv_cpu_once(&lanes_once, lanes_dsp_init);
    return lanes_on;
}

static _Thread_local unsigned long groups_tried, groups_refused;

void gv_dct_lanes_counts(unsigned long *tried, unsigned long *refused)
{
    *tried = groups_tried;
    *refused = groups_refused;
}

/* Each thread's rows, made on its first use and freed when it ends. */
static pthread_key_t arena_key;
static pthread_once_t arena_once = PTHREAD_ONCE_INIT;
static int arena_key_ok;

static void arena_key_make(void)
{
    arena_key_ok = pthread_key_create(&arena_key, free) == 0;
}

struct gv_dct_lanes_arena *gv_dct_lanes_arena(void)
{
    pthread_once(&arena_once, arena_key_make);
    if (!arena_key_ok)
        return NULL;
    struct gv_dct_lanes_arena *rows = pthread_getspecific(arena_key);
    if (!rows) {
        rows = calloc(1, sizeof *rows);
        if (rows && pthread_setspecific(arena_key, rows) != 0) {
            free(rows);
            rows = NULL;
        }
    }
    return rows;
}

int gv_dct_lanes_rows(const uint8_t *buf, const uint32_t at[GV_DCT_LANES],
                      const uint32_t end[GV_DCT_LANES], int n, int channels,
                      const uint32_t *slot, int last, const int32_t steps[3],
                      struct gv_dct_lanes_arena *a,
                      uint8_t eobs[][3][GV_DCT_BLOCKS])
{
#if GV_HAVE_X86_SIMD
    int16_t *base = &a->rows[0][0][0][0];
    groups_tried++;
    const int rc = gv_dct_lanes_run_avx512(buf, at, end, n, channels, slot,
                                           last, steps, base);
    if (rc < 0) {
        groups_refused++;
        memset(a->rows, 0, sizeof a->rows[0] * (size_t)n);
    } else {
        for (int i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                for (int bx = 0; bx < GV_DCT_BLOCKS; bx++)
                    eobs[i][c][bx] = (uint8_t)a->eobs[i][c * GV_DCT_BLOCKS + bx];
    }
    memset(a->eobs, 0, sizeof a->eobs);
    return rc;
#else
    (void)buf, (void)at, (void)end, (void)n, (void)channels, (void)slot,
        (void)last, (void)steps, (void)a, (void)eobs;
    return -1;
#endif
}

