/*
 * tile_dct_lanes_avx512.c - the kernel of tile_dct_lanes.c: sixteen of
 * layout D's rANS rows stepped together, one per 32-bit lane
 * (tile_dct_lanes.c has the design: the phases, the gathers, the logs and
 * what a damaged group does).
 *
 * Compiled with -mavx512f -mavx512bw -mavx512vbmi -mpopcnt (Makefile.am,
 * lib/codec/x86/libgvcodec_avx512vbmi.a): nothing here may run before
 * gv_dct_lanes_usable() has checked the flags.
 */
#include <stdint.h>
#include <string.h>

#include "base/cpu.h"
#include "codec/tile_dct.h"
#include "codec/tile_dct_pixels.h"
#include "codec/x86/tile_dct_lanes_avx512.h"

#if GV_HAVE_X86_SIMD
#include <immintrin.h>

#define ROW16 (3 * 8 * GV_DCT_PLANE)  /* int16 in a gv_dct_row */
#define PLANE8 (8 * GV_DCT_PLANE)     /* int16 in a channel's row */
#define EOBS16 (3 * GV_DCT_BLOCKS)    /* eobs of a row */
#define EOB_AT (GV_DCT_LANES * ROW16) /* the eobs' place in the arena */
#define LOG_CAP 1024                  /* log entries */
#define K0 0x4000                     /* kk of k = 0 (see lanes_run) */

/* The look-up tables of a group, as VPERMB/VPERMT2B operands. */
struct lane_tables {
    uint8_t zz_lo[64], zz_hi[64];  /* v * 520 + u of coefficient k */
    uint8_t band_hi[64];           /* (6 + 3 band(k)): its models' first, / 256 */
    uint8_t pe_lo[64], pe_hi[64];  /* the eob context of an eob 0..64 */
    int32_t value[16];             /* token_value(t), 0 for the escape */
};

static void tables_make(struct lane_tables *t)
{
    for (int k = 0; k < 64; k++) {
        const int z = gv_dct_zigzag[k], o = (z >> 3) * GV_DCT_PLANE + (z & 7);
        t->zz_lo[k] = (uint8_t)o;
        t->zz_hi[k] = (uint8_t)(o >> 8);
        t->band_hi[k] = (uint8_t)(GV_DCT_EOB_MODELS + gv_dct_band_model[k]);
        t->pe_lo[k] = (uint8_t)gv_dct_eob_class(k);
        t->pe_hi[k] = 2;
    }
    for (int s = 0; s < 16; s++)
        t->value[s] = s == GV_DCT_ESCAPE ? 0 : ((s & 1) ? (s + 1) >> 1 : -(s >> 1));
}

/* Replay the log: base[off[i]] = val[i]. */
static void replay(int16_t *base, const uint32_t *off, const int32_t *val, int n)
{
    for (int i = 0; i < n; i++)
        base[off[i]] = (int16_t)val[i];
}

/*
 * The lanes.  Per lane: x; the words in wc (wn of them, the next in the
 * low half) and the stream's next uncached word at rpos, its end at end;
 * the phase; kk = 257 k + K0 for token k (byte 0 is k, byte 1 is k + 64:
 * one VPERMT2B reads a 16-bit table entry, and bytes 2-3, 0, read entry
 * 0, which is 0 in both tables' low halves), neobk the same of the eob;
 * c; p = the previous value's class * 256 (a model is 256 entries; in
 * layout D2 (last) a block's last token takes model 30 + cc instead); pe
 * and dcp, two bits per channel; h, an escape's first step; bb, the
 * block's first coefficient in the arena (int16), eb its eob's.
 *
 * One function of about 200 lines, past the house's 120, on purpose: the
 * lanes' state lives in vector registers across the whole loop, and a
 * call between its phases would spill all of them to memory.
 */
int gv_dct_lanes_run_avx512(const uint8_t *buf,
                            const uint32_t at[GV_DCT_LANES],
                            const uint32_t end_[GV_DCT_LANES], int n,
                            int channels, const uint32_t *slot, int last,
                            const int32_t steps[3], int16_t *base16)
{
    uint32_t logo[LOG_CAP];
    int32_t logv[LOG_CAP];
    int nlog = 0;
    struct lane_tables tb;
    tables_make(&tb);
#define V(c) _mm512_set1_epi32(c)
    const __m512i zero = _mm512_setzero_si512();
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10,
                                           11, 12, 13, 14, 15);
    const __m512i zz_lo = _mm512_loadu_si512(tb.zz_lo),
                  zz_hi = _mm512_loadu_si512(tb.zz_hi),
                  band_hi = _mm512_loadu_si512(tb.band_hi),
                  pe_lo = _mm512_loadu_si512(tb.pe_lo),
                  pe_hi = _mm512_loadu_si512(tb.pe_hi),
                  value = _mm512_loadu_si512(tb.value);
    const __m512i stepv = _mm512_setr_epi32(steps[0], steps[1], steps[2], 0,
                                            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    const __m512i chans = V(channels);
    const __m512i eb0 = _mm512_add_epi32(V(EOB_AT), _mm512_mullo_epi32(lane, V(EOBS16)));
    const __m512i ebend = _mm512_add_epi32(eb0, V(GV_DCT_BLOCKS));

    const __mmask16 used = (__mmask16)((1u << n) - 1);
    __m512i rpos = _mm512_maskz_loadu_epi32(used, at);
    const __m512i end = _mm512_maskz_loadu_epi32(used, end_);
    __m512i x = _mm512_mask_i32gather_epi32(V(1 << 16), used, rpos, buf, 1);
    rpos = _mm512_mask_add_epi32(rpos, used, rpos, V(4));
    __mmask16 bad = _mm512_cmplt_epu32_mask(x, V(1 << 16));
    __m512i phase = _mm512_mask_mov_epi32(V(4), used, zero);
    __m512i wc = zero, wn = zero, kk = V(K0), neobk = V(K0), c = zero,
            p = zero, pe = zero, dcp = zero, h = zero, eb = eb0,
            bb = _mm512_mullo_epi32(lane, V(ROW16));
    __mmask16 live = used;

    struct {
        __m512i blocks, c2048, c255, c256, c257, c3072, c511, c65535, c768, escape, four, k0, l16, lastm, one, plane8, smax, smin, three, two, wrapbb, wrapeb, zero;
    } kc, *K = &kc;
    kc.blocks = V(GV_DCT_BLOCKS);
    kc.c2048 = V(2048);
    kc.c255 = V(255);
    kc.c256 = V(256);
    kc.c257 = V(257);
    kc.c3072 = V(12 * 256);
    kc.c511 = V(511);
    kc.c65535 = V(0xffff);
    kc.c768 = V(3 * 256);
    kc.escape = V(GV_DCT_ESCAPE);
    kc.four = V(4);
    kc.k0 = V(K0);
    kc.l16 = V(1 << 16);
    kc.lastm = V(GV_DCT_LAST_MODEL * 256);
    kc.one = V(1);
    kc.plane8 = V(PLANE8);
    kc.smax = V(32767);
    kc.smin = V(-32768);
    kc.three = V(3);
    kc.two = V(2);
    kc.wrapbb = V(8 - channels * PLANE8);
    kc.wrapeb = V(1 - channels * GV_DCT_BLOCKS);
    kc.zero = V(0);
    /* The constants stay in memory: folded into the instructions that
     * use them instead of rebuilt from general registers each step. */
    __asm__("" : "+r"(K));
    while (live && !bad) {
        /* Words: where a lane has none, every lane tops its K->two up. */
        if (_mm512_mask_cmpeq_epi32_mask(live, wn, K->zero)) {
            const __mmask16 fill = _mm512_mask_cmplt_epu32_mask(live, wn, K->two);
            const __m512i endm4 = _mm512_sub_epi32(end, K->four);
            __m512i g = _mm512_mask_i32gather_epi32(
                K->zero, fill, _mm512_min_epu32(rpos, endm4), buf, 1);
            g = _mm512_mask_srli_epi32(g, _mm512_cmpgt_epu32_mask(rpos, endm4), g, 16);
            const __m512i take = _mm512_min_epu32(
                _mm512_srli_epi32(_mm512_sub_epi32(end, rpos), 1),
                _mm512_sub_epi32(K->two, wn));
            wc = _mm512_mask_or_epi32(wc, fill, wc,
                                      _mm512_sllv_epi32(g, _mm512_slli_epi32(wn, 4)));
            rpos = _mm512_mask_add_epi32(rpos, fill, rpos, _mm512_add_epi32(take, take));
            wn = _mm512_mask_add_epi32(wn, fill, wn, take);
        }

        /* The model entries: eob model 3 cc + pe[c], or token model
         * 6 + 12 cc + 3 band(k) + p. */
        const __m512i xl = _mm512_and_si512(x, K->c255);
        const __mmask16 cc = _mm512_cmpgt_epi32_mask(c, K->zero);
        const __m512i sh = _mm512_add_epi32(c, c);
        const __mmask16 m_eob = _mm512_mask_cmpeq_epi32_mask(live, phase, K->zero);
        const __mmask16 m_tok = _mm512_mask_cmpeq_epi32_mask(live, phase, K->one);
        const __mmask16 m_model = m_eob | m_tok;
        const __m512i pe_c = _mm512_and_si512(_mm512_srlv_epi32(pe, sh), K->three);
        const __m512i idx_e = _mm512_add_epi32(
            _mm512_maskz_mov_epi32(cc, K->c768),
            _mm512_add_epi32(_mm512_slli_epi32(pe_c, 8), xl));
        __m512i idx_t = _mm512_add_epi32(_mm512_permutex2var_epi8(K->zero, kk, band_hi),
                                         _mm512_add_epi32(p, xl));
        idx_t = _mm512_mask_add_epi32(idx_t, cc, idx_t, K->c3072);
        if (last) {
            /* Layout D2: token k = eob - 1 (kk + 257 = neobk) in the last
             * value's model, 30 + cc. */
            const __mmask16 m_last = _mm512_mask_cmpeq_epi32_mask(
                m_tok, _mm512_add_epi32(kk, K->c257), neobk);
            __m512i idx_l = _mm512_add_epi32(K->lastm, xl);
            idx_l = _mm512_mask_add_epi32(idx_l, cc, idx_l, K->c256);
            idx_t = _mm512_mask_mov_epi32(idx_t, m_last, idx_l);
        }
        const __m512i e = _mm512_mask_i32gather_epi32(
            K->zero, m_model, _mm512_mask_mov_epi32(idx_t, m_eob, idx_e), slot, 4);

        /* The rANS step. */
        const __m512i freq = _mm512_and_si512(e, K->c511);
        const __m512i off = _mm512_and_si512(_mm512_srli_epi32(e, 12), K->c255);
        const __m512i sym = _mm512_srli_epi32(e, 20);
        bad |= _mm512_mask_cmpeq_epi32_mask(m_model, freq, K->zero);
        const __m512i xhi = _mm512_srli_epi32(x, 8);
        const __m512i step_c = _mm512_permutexvar_epi32(c, stepv);
        __m512i val = _mm512_mullo_epi32(_mm512_permutexvar_epi32(sym, value), step_c);
        __m512i cls = _mm512_and_si512(_mm512_srli_epi32(e, 10), K->three);
        const __mmask16 m_unif = live & ~m_model;
        __mmask16 m_lo = 0;
        if (m_unif) {
            /* An escape's uniform 6-bit steps (rare). */
            const __mmask16 m_hi = _mm512_mask_cmpeq_epi32_mask(m_unif, phase, K->two);
            m_lo = m_unif & ~m_hi;
            const __m512i hv = _mm512_srli_epi32(xl, 2);
            const __m512i q = _mm512_sub_epi32(
                _mm512_add_epi32(_mm512_slli_epi32(h, 6), hv), K->c2048);
            val = _mm512_mask_mov_epi32(val, m_lo, _mm512_max_epi32(
                _mm512_min_epi32(_mm512_mullo_epi32(q, step_c), K->smax), K->smin));
            cls = _mm512_mask_min_epi32(cls, m_lo, _mm512_abs_epi32(q), K->two);
            h = _mm512_mask_mov_epi32(h, m_hi, hv);
            phase = _mm512_mask_mov_epi32(phase, m_hi, K->three);
            x = _mm512_mask_or_epi32(x, m_unif, _mm512_slli_epi32(xhi, 2),
                                     _mm512_and_si512(x, K->three));
        }
        x = _mm512_mask_add_epi32(x, m_model, _mm512_mullo_epi32(freq, xhi), off);
        const __mmask16 r = _mm512_mask_cmplt_epu32_mask(live, x, K->l16);
        bad |= _mm512_mask_cmpeq_epi32_mask(r, wn, K->zero);
        x = _mm512_mask_or_epi32(x, r, _mm512_slli_epi32(x, 16),
                                 _mm512_and_si512(wc, K->c65535));
        wc = _mm512_mask_srli_epi32(wc, r, wc, 16);
        wn = _mm512_mask_sub_epi32(wn, r, wn, K->one);

        /* Eob lanes: the block's count, its context, the DC context. */
        const __mmask16 eob_nz = _mm512_mask_test_epi32_mask(m_eob, sym, sym);
        const __m512i ch3 = _mm512_sllv_epi32(K->three, sh);
        {
            const __m512i pe_new = _mm512_permutex2var_epi8(pe_lo, sym, pe_hi);
            pe = _mm512_mask_or_epi32(pe, m_eob, _mm512_andnot_si512(ch3, pe),
                                      _mm512_sllv_epi32(pe_new, sh));
            p = _mm512_mask_slli_epi32(p, m_eob, _mm512_and_si512(_mm512_srlv_epi32(dcp, sh), K->three), 8);
            dcp = _mm512_mask_andnot_epi32(dcp, m_eob, ch3, dcp);
            neobk = _mm512_mask_add_epi32(neobk, m_eob, _mm512_mullo_epi32(sym, K->c257), K->k0);
            kk = _mm512_mask_mov_epi32(kk, m_eob, K->k0);
        }

        /* Coefficient lanes: a token other than the escape, or an
         * escape's second step. */
        const __mmask16 esc = _mm512_mask_cmpeq_epi32_mask(m_tok, sym, K->escape);
        const __mmask16 m_coef = (m_tok & ~esc) | m_lo;
        p = _mm512_mask_slli_epi32(p, m_coef, cls, 8);
        const __mmask16 first = _mm512_mask_cmpeq_epi32_mask(m_coef, kk, K->k0);
        dcp = _mm512_mask_or_epi32(dcp, first, dcp, _mm512_sllv_epi32(cls, sh));

        /* The writes: coded nonzero values and nonzero eobs. */
        const __mmask16 wm = eob_nz | _mm512_mask_test_epi32_mask(m_coef, val, val);
        if (wm) {
            const __m512i woff = _mm512_mask_mov_epi32(
                _mm512_add_epi32(bb, _mm512_permutex2var_epi8(zz_lo, kk, zz_hi)), m_eob, eb);
            const __m512i wval = _mm512_mask_mov_epi32(val, m_eob, sym);
            _mm512_storeu_si512(logo + nlog, _mm512_maskz_compress_epi32(wm, woff));
            _mm512_storeu_si512(logv + nlog, _mm512_maskz_compress_epi32(wm, wval));
            nlog += __builtin_popcount(wm);
            if (nlog > LOG_CAP - 16) {
                replay(base16, logo, logv, nlog);
                nlog = 0;
            }
        }

        /* The phases: an escape goes to its steps; a finished block to
         * the next channel, block or the end. */
        kk = _mm512_mask_add_epi32(kk, m_coef, kk, K->c257);
        const __mmask16 fin = _mm512_mask_cmpeq_epi32_mask(m_coef, kk, neobk);
        const __mmask16 adv = (m_eob & ~eob_nz) | fin;
        phase = _mm512_mask_mov_epi32(phase, eob_nz | (m_coef & ~fin), K->one);
        phase = _mm512_mask_mov_epi32(phase, esc, K->two);
        phase = _mm512_mask_mov_epi32(phase, adv, K->zero);
        c = _mm512_mask_add_epi32(c, adv, c, K->one);
        bb = _mm512_mask_add_epi32(bb, adv, bb, K->plane8);
        eb = _mm512_mask_add_epi32(eb, adv, eb, K->blocks);
        const __mmask16 wrap = _mm512_mask_cmpeq_epi32_mask(adv, c, chans);
        c = _mm512_mask_mov_epi32(c, wrap, K->zero);
        bb = _mm512_mask_add_epi32(bb, wrap, bb, K->wrapbb);
        eb = _mm512_mask_add_epi32(eb, wrap, eb, K->wrapeb);
        const __mmask16 done = _mm512_mask_cmpeq_epi32_mask(wrap, eb, ebend);
        phase = _mm512_mask_mov_epi32(phase, done, K->four);
        live &= ~done;
    }
    replay(base16, logo, logv, nlog);
    if (bad)
        return -1;
    /* Every lane back at its start state with every word read. */
    bad = _mm512_mask_cmpneq_epi32_mask(used, x, V(1 << 16)) |
          _mm512_mask_cmpneq_epi32_mask(used, rpos, end) |
          _mm512_mask_test_epi32_mask(used, wn, wn);
    return bad ? -1 : 0;
#undef V
}
#endif
