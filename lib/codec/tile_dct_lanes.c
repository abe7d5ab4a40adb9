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
 * table of load_models), updates x, and renormalizes from a word gathered
 * before the step (it does not depend on x, only on the lane's position),
 * so that the chain from one step to the next holds one gather.  The
 * per-channel contexts pe[3] and dcp[3] sit in one register each, two
 * bits a channel; band(k) and the zigzag place of k are VPERMB look-ups.
 *
 * The writes (coded nonzero coefficients, nonzero eobs) of a step are
 * 64-bit log entries, the int16 destination's address and the value,
 * compacted by VPCOMPRESSQ in registers (VPCOMPRESSQ to memory is slow on
 * Zen 4) and replayed by a scalar loop whenever the log fills and at the
 * end.  Zero tokens are not written: the rows start all zero.
 *
 * Damage: the lanes check what decode_row checks (a zero frequency, a
 * renormalization past the stream's words, a start below 2^16, the end
 * state and position); on any of it the whole group is abandoned, its
 * rows zeroed, and the caller decodes them again by decode_row, which
 * gives the message of the first damaged row.  Lanes that finish early
 * idle until the group's longest row ends.
 */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "codec/tile_dct_lanes.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define HAVE_LANES 1
#else
#define HAVE_LANES 0
#endif

static int lanes_allowed = 1;

static int cpu_has_lanes(void)
{
#if HAVE_LANES
    return __builtin_cpu_supports("avx512f") &&
           __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vbmi") &&
           __builtin_cpu_supports("bmi2") &&
           __builtin_cpu_supports("popcnt");
#else
    return 0;
#endif
}

int gv_dct_lanes(int on)
{
    lanes_allowed = on;
    return gv_dct_lanes_usable();
}

int gv_dct_lanes_usable(void)
{
    return lanes_allowed && cpu_has_lanes();
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

gv_dct_row *gv_dct_lanes_arena(void)
{
    pthread_once(&arena_once, arena_key_make);
    if (!arena_key_ok)
        return NULL;
    gv_dct_row *rows = pthread_getspecific(arena_key);
    if (!rows) {
        rows = calloc(GV_DCT_LANES, sizeof *rows);
        if (rows && pthread_setspecific(arena_key, rows) != 0) {
            free(rows);
            rows = NULL;
        }
    }
    return rows;
}

#if HAVE_LANES

#define ROW16 (3 * 8 * GV_DCT_PLANE)  /* int16 in a gv_dct_row */
#define PLANE8 (8 * GV_DCT_PLANE)     /* int16 in a channel's row */
#define EOBS16 (3 * GV_DCT_BLOCKS)    /* eobs of a row */
#define LOG_CAP 2048                  /* log entries */
#define ADDR_MASK 0xffffffffffffull

#define LANES_TARGET __attribute__((target("avx512f,avx512bw,avx512vbmi,bmi2,popcnt")))

/* band(k) * 3 (the models' band offset in models) and the zigzag place
 * 8 v + u of coefficient k, as VPERMB tables. */
static const uint8_t band3_table[64] = {
    0, 3, 3, 6, 6, 6, 6, 6, 6, 6, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
    9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9,
};

/* Replay log entries: *(int16_t *)address = value. */
static void replay(const uint64_t *log, int n)
{
    for (int i = 0; i < n; i++)
        *(int16_t *)(uintptr_t)(log[i] & ADDR_MASK) = (int16_t)(log[i] >> 48);
}

LANES_TARGET static int lanes_run(const uint8_t *buf,
                                  const uint32_t at[GV_DCT_LANES],
                                  const uint32_t end_[GV_DCT_LANES], int n,
                                  int channels, const uint32_t *slot,
                                  const int32_t steps[3], int16_t *rows16,
                                  int16_t *eob16)
{
    uint64_t log[LOG_CAP];
    int nlog = 0;
    const __m512i zero = _mm512_setzero_si512(), one = _mm512_set1_epi32(1);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10,
                                           11, 12, 13, 14, 15);
    const __m512i band3 = _mm512_loadu_si512(band3_table);
    const __m512i zigzag = _mm512_loadu_si512(gv_dct_zigzag);
    const __m512i stepv = _mm512_setr_epi32(steps[0], steps[1], steps[2], 0,
                                            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    const __m512i chans = _mm512_set1_epi32(channels);
    const __m512i rowbase = _mm512_mullo_epi32(lane, _mm512_set1_epi32(ROW16));
    const __m512i eobbase = _mm512_mullo_epi32(lane, _mm512_set1_epi32(EOBS16));
    const __m512i rows_addr = _mm512_set1_epi64((long long)(uintptr_t)rows16);
    const __m512i eobs_addr = _mm512_set1_epi64((long long)(uintptr_t)eob16);

    const __mmask16 used = (__mmask16)((1u << n) - 1);
    __m512i pos = _mm512_maskz_loadu_epi32(used, at);
    __m512i end = _mm512_maskz_loadu_epi32(used, end_);
    __m512i x = _mm512_mask_i32gather_epi32(_mm512_set1_epi32(1 << 16), used,
                                            pos, buf, 1);
    pos = _mm512_mask_add_epi32(pos, used, pos, _mm512_set1_epi32(4));
    __mmask16 bad = _mm512_cmplt_epu32_mask(x, _mm512_set1_epi32(1 << 16));
    __m512i phase = _mm512_mask_mov_epi32(_mm512_set1_epi32(4), used, zero);
    __m512i k = zero, neob = zero, bx = zero, c = zero, p = zero, pe = zero,
            dcp = zero, h = zero;
    __mmask16 live = used;

    while (live && !bad) {
        /* The model entries and the words a renormalization would take. */
        const __m512i xl = _mm512_and_si512(x, _mm512_set1_epi32(255));
        const __mmask16 cc = _mm512_cmpgt_epi32_mask(c, zero);
        const __m512i sh = _mm512_add_epi32(c, c);
        const __mmask16 m_eob = _mm512_mask_cmpeq_epi32_mask(live, phase, zero);
        const __mmask16 m_model =
            _mm512_mask_cmple_epu32_mask(live, phase, one);
        const __m512i pe_c = _mm512_and_si512(_mm512_srlv_epi32(pe, sh),
                                              _mm512_set1_epi32(3));
        const __m512i idx_e = _mm512_add_epi32(
            _mm512_add_epi32(_mm512_maskz_mov_epi32(cc, _mm512_set1_epi32(768)),
                             _mm512_slli_epi32(pe_c, 8)), xl);
        const __m512i b3 = _mm512_and_si512(_mm512_permutexvar_epi8(k, band3),
                                            _mm512_set1_epi32(255));
        const __m512i idx_t = _mm512_add_epi32(
            _mm512_add_epi32(
                _mm512_mask_mov_epi32(_mm512_set1_epi32(GV_DCT_EOB_MODELS * 256),
                                      cc, _mm512_set1_epi32((GV_DCT_EOB_MODELS + 12) * 256)),
                _mm512_slli_epi32(b3, 8)),
            _mm512_add_epi32(p, xl));
        const __m512i idx = _mm512_mask_mov_epi32(idx_t, m_eob, idx_e);
        const __m512i e = _mm512_mask_i32gather_epi32(zero, m_model, idx, slot, 4);
        const __m512i wat = _mm512_sub_epi32(
            _mm512_min_epu32(pos, _mm512_sub_epi32(end, _mm512_set1_epi32(2))),
            _mm512_set1_epi32(2));
        const __m512i word = _mm512_srli_epi32(
            _mm512_mask_i32gather_epi32(zero, live, wat, buf, 1), 16);

        /* The rANS step: a model's, or a uniform 6-bit one. */
        const __m512i freq = _mm512_and_si512(e, _mm512_set1_epi32(511));
        const __m512i off = _mm512_and_si512(_mm512_srli_epi32(e, 12),
                                             _mm512_set1_epi32(255));
        const __m512i sym = _mm512_srli_epi32(e, 20);
        bad |= _mm512_mask_cmpeq_epi32_mask(m_model, freq, zero);
        const __m512i xhi = _mm512_srli_epi32(x, 8);
        const __m512i xm = _mm512_add_epi32(_mm512_mullo_epi32(freq, xhi), off);
        const __m512i xu = _mm512_or_si512(
            _mm512_slli_epi32(xhi, 2), _mm512_and_si512(x, _mm512_set1_epi32(3)));
        const __m512i hv = _mm512_srli_epi32(xl, 2);
        x = _mm512_mask_mov_epi32(_mm512_mask_mov_epi32(x, live, xu), m_model, xm);
        const __mmask16 r = _mm512_mask_cmplt_epu32_mask(live, x, _mm512_set1_epi32(1 << 16));
        bad |= _mm512_mask_cmpge_epu32_mask(r, pos, end);
        x = _mm512_mask_or_epi32(x, r, _mm512_slli_epi32(x, 16), word);
        pos = _mm512_mask_add_epi32(pos, r, pos, _mm512_set1_epi32(2));

        /* Eob lanes: the block's count, its context, the DC context. */
        const __mmask16 m_tok = _mm512_mask_cmpeq_epi32_mask(live, phase, one);
        const __mmask16 m_hi = _mm512_mask_cmpeq_epi32_mask(live, phase, _mm512_set1_epi32(2));
        const __mmask16 m_lo = _mm512_mask_cmpeq_epi32_mask(live, phase, _mm512_set1_epi32(3));
        const __mmask16 sym_nz = _mm512_test_epi32_mask(sym, sym);
        const __m512i ch3 = _mm512_sllv_epi32(_mm512_set1_epi32(3), sh);
        {
            const __m512i pe_new = _mm512_add_epi32(
                _mm512_maskz_mov_epi32(sym_nz, one),
                _mm512_maskz_mov_epi32(_mm512_cmpgt_epi32_mask(sym, _mm512_set1_epi32(4)), one));
            pe = _mm512_mask_or_epi32(pe, m_eob, _mm512_andnot_si512(ch3, pe),
                                      _mm512_sllv_epi32(pe_new, sh));
            const __m512i dcp_c = _mm512_and_si512(_mm512_srlv_epi32(dcp, sh),
                                                   _mm512_set1_epi32(3));
            p = _mm512_mask_slli_epi32(p, m_eob, dcp_c, 8);
            dcp = _mm512_mask_andnot_epi32(dcp, m_eob, ch3, dcp);
            neob = _mm512_mask_mov_epi32(neob, m_eob, sym);
            k = _mm512_mask_mov_epi32(k, m_eob, zero);
        }

        /* Coefficient lanes: a token other than the escape, or an
         * escape's second step. */
        const __mmask16 esc = _mm512_mask_cmpeq_epi32_mask(m_tok, sym, _mm512_set1_epi32(GV_DCT_ESCAPE));
        const __mmask16 plain = m_tok & ~esc;
        const __mmask16 m_coef = plain | m_lo;
        const __m512i step_c = _mm512_permutexvar_epi32(c, stepv);
        /* token_value(t) = (t & 1) ? (t + 1) >> 1 : -(t >> 1); an escape's
         * q = 64 h + lo - 2048. */
        const __mmask16 odd = _mm512_test_epi32_mask(sym, one);
        const __m512i tv = _mm512_mask_srli_epi32(
            _mm512_sub_epi32(zero, _mm512_srli_epi32(sym, 1)), odd,
            _mm512_add_epi32(sym, one), 1);
        const __m512i qv = _mm512_sub_epi32(
            _mm512_add_epi32(_mm512_slli_epi32(h, 6), hv), _mm512_set1_epi32(2048));
        const __m512i q = _mm512_mask_mov_epi32(tv, m_lo, qv);
        const __m512i val = _mm512_max_epi32(
            _mm512_min_epi32(_mm512_mullo_epi32(q, step_c), _mm512_set1_epi32(32767)),
            _mm512_set1_epi32(-32768));
        const __m512i cls = _mm512_min_epi32(_mm512_abs_epi32(q), _mm512_set1_epi32(2));
        p = _mm512_mask_slli_epi32(p, m_coef, cls, 8);
        const __mmask16 first = _mm512_mask_cmpeq_epi32_mask(m_coef, k, zero);
        dcp = _mm512_mask_or_epi32(dcp, first, dcp, _mm512_sllv_epi32(cls, sh));
        h = _mm512_mask_mov_epi32(h, m_hi, hv);

        /* The writes: coded nonzero values and nonzero eobs. */
        {
            const __m512i zz = _mm512_and_si512(_mm512_permutexvar_epi8(k, zigzag),
                                                _mm512_set1_epi32(255));
            /* v * 520 + u = zz + 512 v */
            const __m512i coff = _mm512_add_epi32(
                _mm512_add_epi32(rowbase, _mm512_mullo_epi32(c, _mm512_set1_epi32(PLANE8))),
                _mm512_add_epi32(_mm512_slli_epi32(bx, 3),
                                 _mm512_add_epi32(zz, _mm512_slli_epi32(_mm512_srli_epi32(zz, 3), 9))));
            const __m512i eoff = _mm512_add_epi32(
                eobbase, _mm512_add_epi32(_mm512_mullo_epi32(c, _mm512_set1_epi32(GV_DCT_BLOCKS)), bx));
            const __m512i woff = _mm512_mask_mov_epi32(coff, m_eob, eoff);
            const __m512i wval = _mm512_mask_mov_epi32(val, m_eob, sym);
            const __mmask16 wm = (m_eob & sym_nz) |
                                 _mm512_mask_test_epi32_mask(m_coef, val, val);
            if (wm) {
                for (int half = 0; half < 2; half++) {
                    const __mmask8 hm = (__mmask8)(wm >> (8 * half));
                    const __mmask8 he = (__mmask8)(m_eob >> (8 * half));
                    const __m256i o = half ? _mm512_extracti64x4_epi64(woff, 1)
                                           : _mm512_castsi512_si256(woff);
                    const __m256i v = half ? _mm512_extracti64x4_epi64(wval, 1)
                                           : _mm512_castsi512_si256(wval);
                    const __m512i base = _mm512_mask_mov_epi64(rows_addr, he, eobs_addr);
                    const __m512i ent = _mm512_or_si512(
                        _mm512_add_epi64(base, _mm512_slli_epi64(_mm512_cvtepu32_epi64(o), 1)),
                        _mm512_slli_epi64(_mm512_cvtepi32_epi64(v), 48));
                    _mm512_storeu_si512(log + nlog, _mm512_maskz_compress_epi64(hm, ent));
                    nlog += __builtin_popcount(hm);
                }
                if (nlog > LOG_CAP - 16) {
                    replay(log, nlog);
                    nlog = 0;
                }
            }
        }

        /* The phases: an escape goes to its steps; a finished block to
         * the next channel, block or the end. */
        k = _mm512_mask_add_epi32(k, m_coef, k, one);
        const __mmask16 fin = _mm512_mask_cmpeq_epi32_mask(m_coef, k, neob);
        const __mmask16 adv = (m_eob & ~sym_nz) | fin;
        phase = _mm512_mask_mov_epi32(phase, (m_eob & sym_nz) | (m_coef & ~fin), one);
        phase = _mm512_mask_mov_epi32(phase, esc, _mm512_set1_epi32(2));
        phase = _mm512_mask_mov_epi32(phase, m_hi, _mm512_set1_epi32(3));
        c = _mm512_mask_add_epi32(c, adv, c, one);
        const __mmask16 wrap = _mm512_mask_cmpeq_epi32_mask(adv, c, chans);
        c = _mm512_mask_mov_epi32(c, wrap, zero);
        bx = _mm512_mask_add_epi32(bx, wrap, bx, one);
        const __mmask16 done = _mm512_mask_cmpeq_epi32_mask(wrap, bx, _mm512_set1_epi32(GV_DCT_BLOCKS));
        phase = _mm512_mask_mov_epi32(phase, adv, zero);
        phase = _mm512_mask_mov_epi32(phase, done, _mm512_set1_epi32(4));
        live &= ~done;
    }
    replay(log, nlog);
    if (bad)
        return -1;
    /* Every lane back at its start state with every word read. */
    bad = _mm512_mask_cmpneq_epi32_mask(used, x, _mm512_set1_epi32(1 << 16)) |
          _mm512_mask_cmpneq_epi32_mask(used, pos, end);
    return bad ? -1 : 0;
}

int gv_dct_lanes_rows(const uint8_t *buf, const uint32_t at[GV_DCT_LANES],
                      const uint32_t end[GV_DCT_LANES], int n, int channels,
                      const uint32_t *slot, const int32_t steps[3],
                      gv_dct_row *rows, uint8_t eobs[][3][GV_DCT_BLOCKS])
{
    int16_t eob16[GV_DCT_LANES * EOBS16];
    memset(eob16, 0, sizeof eob16);
    groups_tried++;
    if (lanes_run(buf, at, end, n, channels, slot, steps, &rows[0][0][0][0],
                  eob16) < 0) {
        groups_refused++;
        memset(rows, 0, sizeof *rows * (size_t)n);
        return -1;
    }
    for (int i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            for (int bx = 0; bx < GV_DCT_BLOCKS; bx++)
                eobs[i][c][bx] = (uint8_t)eob16[i * EOBS16 + c * GV_DCT_BLOCKS + bx];
    return 0;
}

#else

int gv_dct_lanes_rows(const uint8_t *buf, const uint32_t at[GV_DCT_LANES],
                      const uint32_t end[GV_DCT_LANES], int n, int channels,
                      const uint32_t *slot, const int32_t steps[3],
                      gv_dct_row *rows, uint8_t eobs[][3][GV_DCT_BLOCKS])
{
    (void)buf, (void)at, (void)end, (void)n, (void)channels, (void)slot,
        (void)steps, (void)rows, (void)eobs;
    return -1;
}

#endif
