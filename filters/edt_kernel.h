/*
 * edt_kernel.h - the inner loops of edt_cpu.c, compiled once per
 * instruction set and state layout.  Not a normal header: edt_cpu.c
 * (the portable C) and x86/edt_*.c (each compiled with its instruction
 * set's flags) include it once per layout with these defined:
 *
 *   EDT_SUFFIX   name suffix of the functions
 *   EDT_ISA      3 AVX-512, 2 AVX2, 1 SSE2, 0 plain C (no vectors)
 *   EDT_PACKED   1: one plane of packed sites, x | y << 16 (both below
 *                65535; 0xffffffff is none); 0: two uint32 planes, the
 *                "a" plane and the "b" plane (the b pointers are unused
 *                when packed)
 *
 * A line's "a" coordinate runs along the line (x in rows, y in columns)
 * and "b" across it.  Packed column lines (the x-sweeps' slots) hold the
 * halves swapped, y | x << 16, so that "a" is always the low half; the
 * strip transposes swap them.
 *
 * The code is written once with GCC vector extensions over 16 lanes of
 * uint32 (one AVX-512 register, two AVX2 or four SSE2 registers); the
 * compiler lowers it for each target.  Vectors never cross a function
 * boundary (no vector arguments or returns), so the ABI of the default
 * target is never involved.
 *
 * Needs, from edt_int.h: EDT_VL, edt_vu32, edt_vf32, EDT_NONE_U and the
 * scalar helpers edt_pixel(), edt_pixel_dist(), edt_load_scalar() and
 * edt_store_scalar().
 */
#define EDT_CAT2(a, b) a##_##b
#define EDT_CAT(a, b) EDT_CAT2(a, b)
#define EDT_FN(name) EDT_CAT(name, EDT_SUFFIX)

#if EDT_ISA > 0
/* Candidate at offset OFF of the previous line: its key d_ replaces the
 * best (bd; ba, bb or bv) when strictly smaller. */
#if EDT_PACKED
#define EDT_CAND(OFF)                                                    \
    do {                                                                 \
        edt_vu32 v_, da_, db_, d_, m_;                                   \
        memcpy(&v_, pa + (OFF), sizeof v_);                              \
        da_ = (v_ & 0xffffu) - pos;                                      \
        db_ = (v_ >> 16) - kk;                                           \
        d_ = da_ * da_ + db_ * db_;                                      \
        d_ |= (edt_vu32)(v_ == none);                                    \
        m_ = (edt_vu32)(d_ < bd);                                        \
        bd = (d_ & m_) | (bd & ~m_);                                     \
        bv = (v_ & m_) | (bv & ~m_);                                     \
    } while (0)
#else
#define EDT_CAND(OFF)                                                    \
    do {                                                                 \
        edt_vu32 ca_, cb_, da_, db_, d_, m_;                             \
        memcpy(&ca_, pa + (OFF), sizeof ca_);                            \
        memcpy(&cb_, pb + (OFF), sizeof cb_);                            \
        da_ = ca_ - pos;                                                 \
        db_ = cb_ - kk;                                                  \
        d_ = da_ * da_ + db_ * db_;                                      \
        d_ |= (edt_vu32)(ca_ == none);                                   \
        m_ = (edt_vu32)(d_ < bd);                                        \
        bd = (d_ & m_) | (bd & ~m_);                                     \
        ba = (ca_ & m_) | (ba & ~m_);                                    \
        bb = (cb_ & m_) | (bb & ~m_);                                    \
    } while (0)
#endif
#endif

/*
 * Update positions [lo, hi) of one line of n positions: (oa, ob) is the
 * line being written (in place: its old value is "own"), (pa, pb) the
 * previous line, already updated.  The arrays hold positions from `base`
 * on (element 0 is position base).  The pixel at position i has
 * coordinates (a, b) = (i, k).  Candidates: own, prev[i], prev[i-1],
 * prev[i+1].
 */
static void EDT_FN(edt_line)(uint32_t *restrict oa,
                                      uint32_t *restrict ob,
                                      const uint32_t *restrict pa,
                                      const uint32_t *restrict pb,
                                      uint32_t base, uint32_t n, uint32_t lo,
                                      uint32_t hi, uint32_t k)
{
    uint32_t i = lo;
    if (i >= hi)
        return;
    if (i == 0) {
        edt_pixel(oa, ob, pa, pb, 0 - (size_t)base, n, 0, k, EDT_PACKED);
        i = 1;
    }
#if EDT_ISA > 0
    /* The vector body reads prev[i-1 .. i+VL]: i >= 1, i + VL < n. */
    uint32_t vlim = hi < n - 1 ? hi : n - 1;
    const edt_vu32 none = (edt_vu32){0} + EDT_NONE_U;
    const edt_vu32 kk = (edt_vu32){0} + k;
    const edt_vu32 iota = {0, 1, 2, 3, 4, 5, 6, 7,
                           8, 9, 10, 11, 12, 13, 14, 15};
    for (; i + EDT_VL <= vlim; i += EDT_VL) {
        size_t x = i - base;
        edt_vu32 pos = iota + i, bd, da, db;
#if EDT_PACKED
        edt_vu32 bv;
        (void)ob;
        (void)pb;
        memcpy(&bv, oa + x, sizeof bv);
        da = (bv & 0xffffu) - pos;
        db = (bv >> 16) - kk;
        bd = da * da + db * db;
        bd |= (edt_vu32)(bv == none);
#else
        edt_vu32 ba, bb;
        memcpy(&ba, oa + x, sizeof ba);
        memcpy(&bb, ob + x, sizeof bb);
        da = ba - pos;
        db = bb - kk;
        bd = da * da + db * db;
        bd |= (edt_vu32)(ba == none);
#endif
        EDT_CAND(x);
        EDT_CAND(x - 1);
        EDT_CAND(x + 1);
#if EDT_PACKED
        memcpy(oa + x, &bv, sizeof bv);
#else
        memcpy(oa + x, &ba, sizeof ba);
        memcpy(ob + x, &bb, sizeof bb);
#endif
    }
#endif
    for (; i < hi; i++)
        edt_pixel(oa, ob, pa, pb, i - (size_t)base, n, i, k, EDT_PACKED);
}

/*
 * Distances of row y, columns [x0, x1): dist[x] = sqrtf((float)d2) of the
 * site in (sx[x], sy[x]) (packed: sx[x] alone), +INFINITY where there is
 * none.  sx, sy and dist point at the row's column 0.
 */
static void EDT_FN(edt_dist)(const uint32_t *restrict sx,
                                      const uint32_t *restrict sy,
                                      uint32_t x0, uint32_t x1, uint32_t y,
                                      float *restrict dist)
{
    uint32_t x = x0;
#if EDT_ISA > 0
    const edt_vu32 none = (edt_vu32){0} + EDT_NONE_U;
    const edt_vu32 yy = (edt_vu32){0} + y;
    const edt_vu32 inf = (edt_vu32){0} + 0x7f800000u;  /* +INFINITY */
    const edt_vu32 iota = {0, 1, 2, 3, 4, 5, 6, 7,
                           8, 9, 10, 11, 12, 13, 14, 15};
    for (; x + EDT_VL <= x1; x += EDT_VL) {
        edt_vu32 a, b, da, db, d2, m, r;
        edt_vf32 f;
#if EDT_PACKED
        (void)sy;
        memcpy(&a, sx + x, sizeof a);
        m = (edt_vu32)(a == none);
        b = a >> 16;
        a &= 0xffffu;
#else
        memcpy(&a, sx + x, sizeof a);
        memcpy(&b, sy + x, sizeof b);
        m = (edt_vu32)(a == none);
#endif
        da = a - (iota + x);
        db = b - yy;
        d2 = da * da + db * db;
        f = __builtin_convertvector(d2, edt_vf32);
/* One square root per ISA: the AVX-512, AVX2 and SSE2 branches repeat
 * the same shape deliberately (one 512-bit, two 256-bit or four 128-bit
 * halves), because each must use only its own ISA's instruction. */
#if EDT_ISA == 3
        {
            __m512 v;
            memcpy(&v, &f, sizeof v);
            v = _mm512_sqrt_ps(v);
            memcpy(&f, &v, sizeof v);
        }
#elif EDT_ISA == 2
        for (int j = 0; j < 2; j++) {
            __m256 v;
            memcpy(&v, (char *)&f + 32 * j, sizeof v);
            v = _mm256_sqrt_ps(v);
            memcpy((char *)&f + 32 * j, &v, sizeof v);
        }
#else
        for (int j = 0; j < 4; j++) {
            __m128 v;
            memcpy(&v, (char *)&f + 16 * j, sizeof v);
            v = _mm_sqrt_ps(v);
            memcpy((char *)&f + 16 * j, &v, sizeof v);
        }
#endif
        memcpy(&r, &f, sizeof r);
        r = (inf & m) | (r & ~m);
        memcpy(dist + x, &r, sizeof r);
    }
#endif
    for (; x < x1; x++)
        dist[x] = edt_pixel_dist(sx, sy, x, y, EDT_PACKED);
}

/*
 * Strip transposes of the x-sweeps (edt_cpu.c): rows [ya, yb) of the
 * strip's nc columns x0 .. x0+nc-1 between the row-major planes (px, py;
 * packed: px) and the column lines sa[j] (y coordinates, "a") and sb[j]
 * (x coordinates; packed: sa[j] alone, y | x << 16), j = c + 1 for +x
 * (dir > 0) and nc - c for -x.  Element 0 of a column line is row `base`.
 * Blocks of 16 x 16 go through registers (four rounds of two-input
 * shuffles); the ragged edges take the scalar loop.
 */
#if EDT_ISA > 0
#define EDT_T16(B, ...)                                                  \
    for (int i_ = 0; i_ < 16; i_++)                                      \
        if (!(i_ & (B))) {                                               \
            edt_vu32 a_ = m[i_], b_ = m[i_ + (B)];                       \
            m[i_] = __builtin_shufflevector(a_, b_, __VA_ARGS__);        \
            m[i_ + (B)] = __builtin_shufflevector(                       \
                a_, b_, EDT_T16_HI_##B);                                 \
        }
#define EDT_T16_HI_8 8, 9, 10, 11, 12, 13, 14, 15, 24, 25, 26, 27, 28, 29, 30, 31
#define EDT_T16_HI_4 4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31
#define EDT_T16_HI_2 2, 3, 18, 19, 6, 7, 22, 23, 10, 11, 26, 27, 14, 15, 30, 31
#define EDT_T16_HI_1 1, 17, 3, 19, 5, 21, 7, 23, 9, 25, 11, 27, 13, 29, 15, 31
#define EDT_TRANSPOSE16()                                                \
    do {                                                                 \
        EDT_T16(8, 0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19, 20, 21, 22, 23) \
        EDT_T16(4, 0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27) \
        EDT_T16(2, 0, 1, 16, 17, 4, 5, 20, 21, 8, 9, 24, 25, 12, 13, 28, 29) \
        EDT_T16(1, 0, 16, 2, 18, 4, 20, 6, 22, 8, 24, 10, 26, 12, 28, 14, 30) \
    } while (0)
#endif

/* ids != NULL: build the initial state from the ids (+x only). */
static void EDT_FN(edt_load)(const uint32_t *restrict ids,
                                      const uint32_t *restrict px,
                                      const uint32_t *restrict py, size_t w,
                                      uint32_t x0, uint32_t nc, int dir,
                                      uint32_t ya, uint32_t yb,
                                      uint32_t base, uint32_t *const *sa,
                                      uint32_t *const *sb)
{
    uint32_t y = ya;
#if EDT_ISA > 0
    const edt_vu32 none = (edt_vu32){0} + EDT_NONE_U;
    const edt_vu32 iota = {0, 1, 2, 3, 4, 5, 6, 7,
                           8, 9, 10, 11, 12, 13, 14, 15};
    for (; y + 16 <= yb; y += 16) {
        uint32_t c0 = 0;
        for (; c0 + 16 <= nc; c0 += 16) {
            edt_vu32 m[16];
#if EDT_PACKED
            (void)py;
            (void)sb;
            for (int r = 0; r < 16; r++) {
                size_t p = (size_t)(y + (uint32_t)r) * w + x0 + c0;
                if (ids) {
                    edt_vu32 id, site;
                    memcpy(&id, ids + p, sizeof id);
                    site = (edt_vu32)(id != (edt_vu32){0});
                    m[r] = (site & ((y + (uint32_t)r) |
                                    (iota + x0 + c0) << 16)) |
                           (~site & none);
                } else {
                    memcpy(&m[r], px + p, sizeof m[r]);
                    m[r] = m[r] >> 16 | m[r] << 16;
                }
            }
            EDT_TRANSPOSE16();
            for (int c = 0; c < 16; c++) {
                uint32_t j = dir > 0 ? c0 + (uint32_t)c + 1
                                     : nc - c0 - (uint32_t)c;
                memcpy(sa[j] + (y - base), &m[c], sizeof m[c]);
            }
#else
            edt_vu32 mb[16];
            for (int r = 0; r < 16; r++) {
                size_t p = (size_t)(y + (uint32_t)r) * w + x0 + c0;
                if (ids) {
                    edt_vu32 id, site;
                    memcpy(&id, ids + p, sizeof id);
                    site = (edt_vu32)(id != (edt_vu32){0});
                    m[r] = (site & (y + (uint32_t)r)) | (~site & none);
                    mb[r] = (site & (iota + x0 + c0)) | (~site & none);
                } else {
                    memcpy(&m[r], py + p, sizeof m[r]);
                    memcpy(&mb[r], px + p, sizeof mb[r]);
                }
            }
            EDT_TRANSPOSE16();
            for (int c = 0; c < 16; c++) {
                uint32_t j = dir > 0 ? c0 + (uint32_t)c + 1
                                     : nc - c0 - (uint32_t)c;
                memcpy(sa[j] + (y - base), &m[c], sizeof m[c]);
                m[c] = mb[c];
            }
            EDT_TRANSPOSE16();
            for (int c = 0; c < 16; c++) {
                uint32_t j = dir > 0 ? c0 + (uint32_t)c + 1
                                     : nc - c0 - (uint32_t)c;
                memcpy(sb[j] + (y - base), &m[c], sizeof m[c]);
            }
#endif
        }
        if (c0 < nc)
            edt_load_scalar(ids, px, py, w, x0, nc, dir, y, y + 16, c0, base,
                            sa, sb, EDT_PACKED);
    }
#endif
    if (y < yb)
        edt_load_scalar(ids, px, py, w, x0, nc, dir, y, yb, 0, base, sa, sb,
                        EDT_PACKED);
}

static void EDT_FN(edt_store)(uint32_t *restrict px,
                                       uint32_t *restrict py, size_t w,
                                       uint32_t x0, uint32_t nc, int dir,
                                       uint32_t ya, uint32_t yb,
                                       uint32_t base, uint32_t *const *sa,
                                       uint32_t *const *sb)
{
    uint32_t y = ya;
#if EDT_ISA > 0
    for (; y + 16 <= yb; y += 16) {
        uint32_t c0 = 0;
        for (; c0 + 16 <= nc; c0 += 16) {
            edt_vu32 m[16];
            for (int k = 0; k < 2 - EDT_PACKED; k++) {
                uint32_t *const *s = k ? sb : sa;
                uint32_t *dst = k ? px : EDT_PACKED ? px : py;
                for (int c = 0; c < 16; c++) {
                    uint32_t j = dir > 0 ? c0 + (uint32_t)c + 1
                                         : nc - c0 - (uint32_t)c;
                    memcpy(&m[c], s[j] + (y - base), sizeof m[c]);
                }
                EDT_TRANSPOSE16();
                for (int r = 0; r < 16; r++) {
#if EDT_PACKED
                    m[r] = m[r] >> 16 | m[r] << 16;
#endif
                    memcpy(dst + (size_t)(y + (uint32_t)r) * w + x0 + c0,
                           &m[r], sizeof m[r]);
                }
            }
        }
        if (c0 < nc)
            edt_store_scalar(px, py, w, x0, nc, dir, y, y + 16, c0, base, sa,
                             sb, EDT_PACKED);
    }
#endif
    if (y < yb)
        edt_store_scalar(px, py, w, x0, nc, dir, y, yb, 0, base, sa, sb,
                         EDT_PACKED);
}

#undef EDT_CAND
#undef EDT_FN
#undef EDT_CAT
#undef EDT_CAT2
