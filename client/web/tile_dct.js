// tile_dct.js - checking a layout-D or layout-D2 tile buffer (byte 0 =
// 0x20 or 0x21, the transform-coded residual of docs/FORMAT.md sections
// 4.3 and 4.4) and decoding its 65 rANS streams into the dequantized
// coefficient plane.
//
// A port of gv_dct_check / gv_dct_unpack (lib/codec/tile_dct.c), statement
// for statement, so that the browser refuses exactly the buffers the C
// decoder refuses and uploads the same coefficients: the WebGL2 variant of
// shaders/tile_decode.frag.glsl reads them from a 520 x 520 RGBA16I
// texture (channel c in component c, component 3 zero) and does the
// inverse transform, the colour transform and the prediction itself.
// Pure: no DOM, no GL, so it runs in a worker too.

export const DCT = 0x20;           // byte 0 of a layout-D buffer
export const DCT2 = 0x21;         // byte 0 of a layout-D2 buffer: D with
                                   // a model for each block's last value
/** Whether byte 0 of a tile buffer names layout D or D2. */
export const isDct = (b0) => b0 === DCT || b0 === DCT2;
export const DCT_SIDE = 520;       // coefficient plane edge: 65 blocks of 8
export const DCT_BLOCKS = 65;      // 8 x 8 blocks per plane edge = streams
export const DCT_PLANE = DCT_SIDE * DCT_SIDE * 4;   // Int16 elements

const MODELS = 30;                 // 6 eob models, 24 token models
const MODELS_D2 = 32;               // layout D2: and 2 last-value models
const LAST_MODEL = 30;             // layout D2: model 30 + cc
const EOB_SYMBOLS = 65;
const TOKEN_SYMBOLS = 16;
const ESCAPE = 15;
const RANS_L = 1 << 16;
const HEADER = 12;                 // 0x20, 0, S[0..2], mask
const MAX_STEP = 4095;

const u16 = (b, at) => b[at] | (b[at + 1] << 8);
const u32 = (b, at) => (b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (b[at + 3] << 24)) >>> 0;

/** JPEG's zigzag order: ZIGZAG[k] = 8 v + u of coefficient k (FORMAT.md 4.3). */
export const ZIGZAG = (() => {
    const z = new Uint8Array(64);
    let k = 0;
    for (let d = 0; d < 15; d++)
        for (let i = 0; i < 8; i++) {
            // odd d: v rising (top-right to bottom-left); even d: v falling.
            const v = d & 1 ? i : d - i, u = d - v;
            if (v >= 0 && v < 8 && u >= 0 && u < 8)
                z[k++] = 8 * v + u;
        }
    return z;
})();

function corrupt(msg) {
    const e = new Error(`tile: ${msg}`);
    e.code = 'corrupt';
    return e;
}

const symbolsOf = (m) => (m < 6 ? EOB_SYMBOLS : TOKEN_SYMBOLS);

/**
 * parse_layout: check a layout-D buffer for `channels` (1 or 3) and
 * return where its parts lie: {mask, at[m] (model m's offset, 0 when not
 * stored), lengths, streams}.  Throws an Error (code 'corrupt').
 */
function dctLayout(buf, channels) {
    const len = buf.length;
    if (len < HEADER || (len & 3) || !isDct(buf[0]) || buf[1])
        throw corrupt('bad layout D header');
    const last = buf[0] === DCT2, models = last ? MODELS_D2 : MODELS;
    for (let c = 0; c < 3; c++) {
        const s = u16(buf, 2 + 2 * c);
        if (c < channels ? s < 1 || s > MAX_STEP : s !== 0)
            throw corrupt(`bad quantizer step ${s} of channel ${c}`);
    }
    const l = { mask: u32(buf, 8), last, at: new Int32Array(MODELS_D2), lengths: 0, streams: 0 };
    if (!last && l.mask >>> MODELS)
        throw corrupt(`bad model mask 0x${l.mask.toString(16).padStart(8, '0')}`);
    let at = HEADER;
    for (let m = 0; m < models; m++) {
        l.at[m] = 0;
        if (!((l.mask >>> m) & 1))
            continue;
        const k = symbolsOf(m);
        if (at + k > len)
            throw corrupt('models pass the buffer');
        if (buf[at] !== 0)
            throw corrupt(`model ${m} starts at ${buf[at]}`);
        for (let s = 1; s < k; s++)
            if (buf[at + s] < buf[at + s - 1])
                throw corrupt(`model ${m} decreases`);
        l.at[m] = at;
        at += k;
    }
    l.lengths = (at + 1) & ~1;
    l.streams = l.lengths + 2 * DCT_BLOCKS;
    if (l.streams > len)
        throw corrupt('stream lengths pass the buffer');
    let words = 0;
    for (let i = 0; i < DCT_BLOCKS; i++) {
        const n = u16(buf, l.lengths + 2 * i);
        if (n < 2)
            throw corrupt(`stream ${i} has ${n} words`);
        words += n;
    }
    const end = l.streams + 2 * words;
    if (((end + 3) & ~3) !== len)
        throw corrupt(`${len} bytes where the streams end at ${end}`);
    for (let b = end; b < len; b++)
        if (buf[b])
            throw corrupt('nonzero padding');
    return l;
}

/**
 * gv_dct_check: throws an Error (code 'corrupt') unless buf (a
 * Uint8Array) is a well-formed layout-D buffer for `channels` (1 or 3):
 * header, steps, model mask, models and stream lengths.  The streams
 * themselves are checked as they are decoded (dctUnpack).
 */
export function dctCheck(buf, channels) {
    dctLayout(buf, channels);
}

/** slot -> symbol table of model m at `at` (k symbols, cum[k] = 256). */
function lookup(buf, at, k) {
    const sym = new Uint8Array(256);
    let s = 0;
    for (let slot = 0; slot < 256; slot++) {
        while (s + 1 < k && buf[at + s + 1] <= slot)
            s++;
        sym[slot] = s;
    }
    return sym;
}

const cls = (v) => (v === 0 ? 0 : v === 1 ? 1 : 2);

/**
 * gv_dct_unpack: check buf and decode its 65 streams into coefs (an
 * Int16Array of DCT_PLANE elements, zeroed here): texel (X, Y) of the
 * 520 x 520 plane at 4 (520 Y + X), channel c in element c, element 3
 * (and 1, 2 for gray) zero.  Each stream is validated (a model it needs
 * is stored, no read past its end, clean final state).  Throws on damage.
 * With `bounds`, element 3 of each block's first texel holds what
 * dct_decode.comp.glsl puts there: the rows (bits 0-3) and columns (bits
 * 4-7) that the block's nonzero coefficients reach, 1 to 8 each, so that
 * the decode shader reads no more of the block than it must (0, as
 * gv_dct_unpack leaves it, reads all 8 x 8: the same pixels either way).
 */
export function dctUnpack(buf, channels, coefs, bounds = false) {
    const l = dctLayout(buf, channels);
    const step = [u16(buf, 2), u16(buf, 4), u16(buf, 6)];
    // load_models: per model cum (k + 1 entries, cum[k] = 256) and the
    // symbol of every slot; a model whose bit is clear has every slot on
    // symbol 0 of frequency 0, which a step reports as damage.
    const cum = [], sym = [];
    for (let m = 0; m < MODELS_D2; m++) {
        if (!l.at[m]) {
            cum.push(new Uint16Array(2));
            sym.push(new Uint8Array(256));
            continue;
        }
        const k = symbolsOf(m), c = new Uint16Array(k + 1);
        for (let s = 0; s < k; s++)
            c[s] = buf[l.at[m] + s];
        c[k] = 256;
        cum.push(c);
        sym.push(lookup(buf, l.at[m], k));
    }
    coefs.fill(0);
    let at = l.streams;
    for (let by = 0; by < DCT_BLOCKS; by++) {
        const n = u16(buf, l.lengths + 2 * by);
        const w = at;
        // x < 2^32: f <= 256 and x >> 8 < 2^24, exact in a double; >>> 0
        // keeps it unsigned.
        let x = (u16(buf, w) | (u16(buf, w + 2) << 16)) >>> 0;
        let next = 2;
        // One step with model m (-1: the uniform 6-bit step); its symbol.
        const dec = (m) => {
            if (x < RANS_L)
                throw corrupt(`stream ${by} is corrupt`);
            const slot = x & 255;
            let s, c0, f;
            if (m < 0) {
                s = slot >> 2;
                c0 = 4 * s;
                f = 4;
            } else {
                s = sym[m][slot];
                c0 = cum[m][s];
                f = cum[m][s + 1] - c0;
                if (f === 0)
                    throw corrupt(`stream ${by} is corrupt`);
            }
            x = (f * (x >>> 8) + slot - c0) >>> 0;
            if (x < RANS_L) {
                if (next >= n)
                    throw corrupt(`stream ${by} is corrupt`);
                x = (x * 65536 + u16(buf, w + 2 * next++)) >>> 0;
            }
            return s;
        };
        const pe = [0, 0, 0], dcp = [0, 0, 0];
        for (let bx = 0; bx < DCT_BLOCKS; bx++) {
            const origin = 4 * (8 * by * DCT_SIDE + 8 * bx);
            let rows = 1, cols = 1;
            for (let c = 0; c < channels; c++) {
                const cc = c === 0 ? 0 : 1;
                const nc = dec(3 * cc + pe[c]);
                let prev = 0;
                for (let k = 0; k < nc; k++) {
                    const band = k === 0 ? 0 : k <= 2 ? 1 : k <= 9 ? 2 : 3;
                    const p = k === 0 ? dcp[c] : cls(prev < 0 ? -prev : prev);
                    const t = dec(l.last && k === nc - 1 ? LAST_MODEL + cc
                                                         : 6 + 3 * (4 * cc + band) + p);
                    let q;
                    if (t === 0)
                        q = 0;
                    else if (t < ESCAPE)
                        q = t & 1 ? (t + 1) >> 1 : -(t >> 1);
                    else {
                        const h = dec(-1), lo = dec(-1);
                        q = 64 * h + lo - 2048;
                    }
                    if (k === 0)
                        dcp[c] = cls(q < 0 ? -q : q);
                    prev = q;
                    const z = ZIGZAG[k];
                    const d = q * step[c], v = d < -32768 ? -32768 : d > 32767 ? 32767 : d;
                    coefs[origin + 4 * ((z >> 3) * DCT_SIDE + (z & 7)) + c] = v;
                    if (v !== 0) {
                        if ((z >> 3) >= rows)
                            rows = (z >> 3) + 1;
                        if ((z & 7) >= cols)
                            cols = (z & 7) + 1;
                    }
                }
                pe[c] = nc === 0 ? 0 : nc <= 4 ? 1 : 2;
                if (nc === 0)
                    dcp[c] = 0;
            }
            if (bounds)
                coefs[origin + 3] = rows | cols << 4;
        }
        if (x !== RANS_L || next !== n)
            throw corrupt(`stream ${by} does not end cleanly`);
        at += 2 * n;
    }
}
