// heighttile.js - checking a height tile buffer and entropy-decoding its
// residuals on the CPU (docs/FORMAT.md section 12), for the WebGL2 path of
// shaders/height_decode.frag.glsl (WebGL2 has no compute shaders).
//
// A port of gv_height_tile_check and gv_height_tile_residuals
// (lib/codec/height_tile.c), and of gv_samples_tile_split
// (lib/codec/samples_tile.c), statement for statement, so that the browser
// refuses the buffers the C decoder refuses and yields the same q.  Pure:
// no DOM, no GL, so it runs in a worker too.

export const SIDE = 513;
export const SAMPLES = SIDE * SIDE;
const TOKENS = 29, DIRECT = 16, ROWS = 8, STREAMS = 65, CONTEXTS = 12;
const MASK_AT = 4, LEN_AT = 6, CUM_AT = 136, MAX_E = 32767, CHUNK = 12;
const PROB_BITS = 15, PROB_SCALE = 1 << PROB_BITS, RANS_L = 65536;
const BUF_MAX = CUM_AT + CONTEXTS * 2 * TOKENS + 4 + 4 * SAMPLES + 4 * STREAMS + 4;

const u16 = (b, at) => b[at] | (b[at + 1] << 8);

function bitCount(m) {
    let n = 0;
    for (; m; m &= m - 1) n++;
    return n;
}

function bitlen(n) {
    return n === 0 ? 0 : 32 - Math.clz32(n);
}

function streamsAt(mask) {
    return (CUM_AT + bitCount(mask) * 2 * TOKENS + 3) & ~3;
}

/**
 * The channel buffers of a sample store's tile (docs/FORMAT.md section
 * 13): c height-tile buffers one after another, each saying its own
 * length, which must fill buf exactly (gv_samples_tile_split).  Returns c
 * subarrays of buf; throws on a malformed tile.
 */
export function splitSampleTile(buf, c) {
    const parts = [];
    let at = 0;
    for (let k = 0; k < c; k++) {
        const left = buf.length - at;
        let n = 0;
        if (left >= 4 && buf[at] === 0)
            n = 4;
        else if (left >= CUM_AT && buf[at] === 1) {
            const mask = u16(buf, at + MASK_AT);
            if (mask && !(mask >> CONTEXTS)) {
                let words = 0;
                for (let s = 0; s < STREAMS; s++) words += u16(buf, at + LEN_AT + 2 * s);
                n = (streamsAt(mask) + 2 * words + 3) & ~3;
            }
        }
        if (!n || n > left)
            throw new Error(`samples: channel ${k}'s buffer is malformed or runs past the tile`);
        parts.push(buf.subarray(at, at + n));
        at += n;
    }
    if (at !== buf.length)
        throw new Error(`samples: ${buf.length - at} bytes past the last channel`);
    return parts;
}

/** Throw unless buf (a Uint8Array) is a well-formed height tile buffer. */
export function checkHeightTile(buf) {
    const len = buf.length;
    if (len < 4 || (len & 3) || buf[1] !== 0 || buf[0] > 1 || u16(buf, 2) > MAX_E)
        throw new Error('height: bad tile header');
    if (buf[0] === 0) {
        if (len !== 4) throw new Error(`height: prediction-only tile of ${len} bytes`);
        return;
    }
    if (len < CUM_AT || len > BUF_MAX) throw new Error(`height: tile of ${len} bytes`);
    const mask = u16(buf, MASK_AT);
    if (!mask || mask >> CONTEXTS) throw new Error('height: bad context mask');
    const sa = streamsAt(mask);
    if (len < sa) throw new Error(`height: tile of ${len} bytes`);
    for (let at = CUM_AT; at + 2 * TOKENS <= sa; at += 2 * TOKENS) {
        let prev = 0;
        for (let t = 0; t < TOKENS; t++) {
            const c = u16(buf, at + 2 * t);
            if (c < prev || c > PROB_SCALE || (t === 0 && c !== 0))
                throw new Error('height: bad frequency table');
            prev = c;
        }
    }
    let words = 0;
    for (let s = 0; s < STREAMS; s++) {
        const n = u16(buf, LEN_AT + 2 * s);
        if (n < 2) throw new Error(`height: stream ${s} too short`);
        words += n;
    }
    if (((sa + 2 * words + 3) & ~3) !== len)
        throw new Error(`height: tile length ${len} does not match its streams`);
}

/**
 * The residuals q of a height tile buffer: {e, coded, q} with q an
 * Int32Array(513 * 513) (all 0 for a prediction-only tile).  Throws on a
 * damaged buffer.
 */
export function heightResiduals(buf) {
    checkHeightTile(buf);
    const e = u16(buf, 2), q = new Int32Array(SAMPLES);
    if (buf[0] === 0) return { e, coded: 0, q };
    const mask = u16(buf, MASK_AT);
    const cum = [];
    let at = CUM_AT;
    for (let c = 0; c < CONTEXTS; c++) {
        if (!((mask >> c) & 1)) { cum.push(null); continue; }
        const t = new Uint32Array(TOKENS + 1);
        for (let k = 0; k < TOKENS; k++) t[k] = u16(buf, at + 2 * k);
        t[TOKENS] = PROB_SCALE;
        cum.push(t);
        at += 2 * TOKENS;
    }
    let w = streamsAt(mask);
    for (let s = 0; s < STREAMS; s++) {
        const n = u16(buf, LEN_AT + 2 * s);
        let x = (u16(buf, w) + u16(buf, w + 2) * 65536) >>> 0;
        let next = w + 4, left = n - 2;
        w += 2 * n;
        const renorm = () => {
            if (x < RANS_L) {
                if (!left) throw new Error('height: damaged rANS stream');
                x = ((x * 65536) >>> 0) + u16(buf, next);
                next += 2;
                left--;
            }
        };
        const bits = (k) => {
            const slot = x & (PROB_SCALE - 1), sh = PROB_BITS - k;
            const v = slot >>> sh;
            x = ((1 << sh) * Math.floor(x / PROB_SCALE) + (slot & ((1 << sh) - 1))) >>> 0;
            renorm();
            return v;
        };
        const r0 = s * ROWS, r1 = Math.min(r0 + ROWS, SIDE);
        for (let v = r0; v < r1; v++)
            for (let u = 0; u < SIDE; u++) {
                const a = u ? Math.abs(q[v * SIDE + u - 1]) : 0;
                const b = v > r0 ? Math.abs(q[(v - 1) * SIDE + u]) : 0;
                const table = cum[Math.min(bitlen(a + b), CONTEXTS - 1)];
                if (!table) throw new Error('height: damaged rANS stream');
                const slot = x & (PROB_SCALE - 1);
                let t = TOKENS - 1;
                while (table[t] > slot) t--;
                x = ((table[t + 1] - table[t]) * Math.floor(x / PROB_SCALE) + slot - table[t]) >>> 0;
                renorm();
                let z = t;
                if (t >= DIRECT) {
                    const k = t - 12, lo = Math.min(k, CHUNK), hi = k - lo;
                    const vl = bits(lo), vh = hi > 0 ? bits(hi) : 0;
                    z = 2 ** k + vh * 2 ** lo + vl;
                }
                q[v * SIDE + u] = z & 1 ? -(z >>> 1) - 1 : z >>> 1;
            }
        if (x !== RANS_L || left) throw new Error('height: damaged rANS stream');
    }
    return { e, coded: 1, q };
}

/**
 * A sample store's tile made ready for the GPU (client/web/codes_decode.js):
 * every channel's buffer split off, checked and its residuals decoded.
 * Returns {q, e, coded}: q an Int32Array(c * 513 * 513), channel k's
 * residuals at k * 513 * 513; e and coded c entries each, as
 * heightResiduals gives them.  Throws on a malformed tile.
 */
export function prepareSampleTile(buf, c) {
    const q = new Int32Array(c * SAMPLES), e = new Int32Array(c), coded = new Uint8Array(c);
    splitSampleTile(buf, c).forEach((part, k) => {
        const r = heightResiduals(part);
        e[k] = r.e;
        coded[k] = r.coded;
        if (r.coded)
            q.set(r.q, k * SAMPLES);
    });
    return { q, e, coded };
}
