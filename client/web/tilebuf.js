// tilebuf.js - checking a compressed tile buffer and decoding its
// entropy-coded indices on the CPU (docs/FORMAT.md sections 4, 4.1, 4.2;
// layout D, section 4.3, in tile_dct.js).
//
// A port of gv_tilebuf_check (lib/codec/tile_decode.c) and gv_rans_check /
// gv_rans_unpack (lib/codec/tile_rans.c), statement for statement, so that the
// browser refuses exactly the buffers the C decoders refuse and produces
// the same indices.  WebGL2 has no compute shaders, so the rANS streams of
// an "E" tile are decoded here and uploaded as a 257x257 R16UI texture
// (the GV_GPU_PATH_WEBGL2 variant of shaders/tile_decode.frag.glsl); a
// layout-D tile's streams likewise, into a 520x520 RGBA16I texture of
// dequantized coefficients.
// Everything here is pure: no DOM, no GL, so it runs in a worker too.

import { DCT_PLANE, isDct, dctCheck, dctUnpack } from './tile_dct.js';

export const TILE = 513;          // tile edge in pixels
export const STEP = 512;          // distance between tile origins
export const BLOCKS = 257;        // 2x2 blocks per tile edge
export const NBLOCKS = BLOCKS * BLOCKS;
export const MAX_RATE = 12;
export const TILEBUF_MAX = 148228; // the largest buffer: fixed layout, r 12, RGB
export const ENTROPY = 0x80;      // byte 0 flag: rANS-coded indices
export const CONTEXT = 0x40;      // ... with context models (EX, with ENTROPY)

const PROB_BITS = 15;
const PROB_SCALE = 1 << PROB_BITS;
const RANS_L = 1 << 16;

/** Bytes of a fixed-layout buffer at index width `rate` (gv_tilebuf_size). */
export function tileBufferSize(rate, channels) {
    if (rate <= 0)
        return 4;
    const bits = 8 * (1 + 2 ** rate * 4 * channels) + NBLOCKS * rate;
    return Math.ceil(bits / 32) * 4;
}

/** Byte offset of the cumulative frequencies (gv_rans_tables_offset). */
export function ransTablesOffset(rate, channels) {
    const book = 1 + (1 << rate) * 4 * channels;
    return (book + 3) & ~3;
}

const u16 = (b, at) => b[at] | (b[at + 1] << 8);
const LENGTHS_BYTES = (2 * BLOCKS + 3) & ~3;
const SYMBOLS = 8;          // symbols of an EX context model: 0..6, escape
const ESCAPE = 7;
const CLASS = [0, 1, 1, 2, 2, 2, 2, 3];   // class of a context-model symbol

function corrupt(msg) {
    const e = new Error(`tile: ${msg}`);
    e.code = 'corrupt';
    return e;
}

/**
 * Where the parts of an entropy-coded buffer lie (FORMAT.md 4.1, 4.2):
 * k symbols of the model over all indices at `tables`; for EX also the
 * context map, the context models and their count.
 */
function ransLayout(buf, rate, channels) {
    if (buf[0] & CONTEXT) {
        const contexts = buf[1], n = u16(buf, 2);
        const tables = 4 + n * 4 * channels;
        const map = (tables + 2 * n + 3) & ~3;
        const models = map + 8;
        const lengths = models + 2 * SYMBOLS * contexts;
        return { ctx: true, k: n, contexts, tables, map, models, lengths, streams: lengths + LENGTHS_BYTES };
    }
    const k = 1 << rate;
    const tables = ransTablesOffset(rate, channels);
    const lengths = tables + 2 * k;
    return { ctx: false, k, tables, lengths, streams: lengths + LENGTHS_BYTES };
}

function checkCum(buf, tables, k, what) {
    if (u16(buf, tables) !== 0)
        throw corrupt(`first cumulative frequency${what} is not 0`);
    for (let s = 1; s < k; s++) {
        const c0 = u16(buf, tables + 2 * (s - 1)), c1 = u16(buf, tables + 2 * s);
        if (c1 < c0 || c1 > PROB_SCALE)
            throw corrupt(`cumulative frequencies${what} decrease at symbol ${s}`);
    }
}

function checkZero(buf, from, to) {
    for (let i = from; i < to; i++)
        if (buf[i])
            throw corrupt('nonzero padding');
}

function checkStreams(buf, lengths, maxWords) {
    const len = buf.length, streams = lengths + LENGTHS_BYTES;
    let words = 0;
    for (let row = 0; row < BLOCKS; row++) {
        const n = u16(buf, lengths + 2 * row);
        if (n < 2 || n > maxWords)
            throw corrupt(`stream ${row} has ${n} words`);
        words += n;
    }
    checkZero(buf, lengths + 2 * BLOCKS, streams);
    if (((streams + 2 * words + 3) & ~3) !== len)
        throw corrupt(`streams need ${2 * words} bytes, the buffer has ${len - streams}`);
}

/** gv_rans_check: tables and stream lengths of an entropy-coded buffer. */
export function ransCheck(buf, rate, channels) {
    const len = buf.length;
    // Never longer than the fixed layout (so never past TILEBUF_MAX).
    const checkLength = () => {
        const fixed = tileBufferSize(rate, channels);
        if (len > fixed)
            throw corrupt(`entropy-coded buffer of ${len} bytes, longer than the fixed layout's ${fixed}`);
    };
    if (!(buf[0] & CONTEXT)) {
        checkLength();
        const l = ransLayout(buf, rate, channels);
        if (len < l.streams || (len & 3))
            throw corrupt(`entropy-coded buffer of ${len} bytes is too short for rate ${rate}`);
        checkZero(buf, 1 + l.k * 4 * channels, l.tables);
        checkCum(buf, l.tables, l.k, '');
        checkStreams(buf, l.lengths, BLOCKS + 2);
        return;
    }
    if (rate < 3)
        throw corrupt(`context-coded indices at rate ${rate} (3 is the least)`);
    checkLength();
    if (len < 4 || (len & 3))
        throw corrupt(`context-coded buffer of ${len} bytes`);
    const l = ransLayout(buf, rate, channels);
    if (l.k < 8 || l.k > (1 << rate))
        throw corrupt(`${l.k} codevectors at rate ${rate}`);
    if (l.contexts < 1 || l.contexts > 8)
        throw corrupt(`${l.contexts} context models`);
    if (len < l.streams)
        throw corrupt(`context-coded buffer of ${len} bytes is too short for its ${l.k} codevectors`);
    checkCum(buf, l.tables, l.k, ' of the escape model');
    checkZero(buf, l.tables + 2 * l.k, l.map);
    for (let p = 0; p < 16; p++) {
        const c = (buf[l.map + (p >> 1)] >> (4 * (p & 1))) & 15;
        if (c >= l.contexts)
            throw corrupt(`context map entry ${p} is ${c} of ${l.contexts} models`);
    }
    for (let c = 0; c < l.contexts; c++)
        checkCum(buf, l.models + 2 * SYMBOLS * c, SYMBOLS, ' of a context model');
    checkStreams(buf, l.lengths, 2 * BLOCKS + 2);
}

/**
 * gv_tilebuf_check: throws an Error (code 'corrupt') unless buf (a
 * Uint8Array) is a well-formed tile buffer for `channels` (1 or 3).
 * Returns the rate r (0 for layouts D and D2, which have none).
 */
export function checkTile(buf, channels) {
    const len = buf.length;
    if (len < 4 || (len & 3))
        throw corrupt(`buffer of ${len} bytes is not a positive multiple of 4`);
    if (isDct(buf[0])) {
        dctCheck(buf, channels);
        return 0;
    }
    const rate = buf[0] & 0x0f;
    const ctxWithoutE = (buf[0] & CONTEXT) && !(buf[0] & ENTROPY);
    if ((buf[0] & 0x30) || ctxWithoutE || rate > MAX_RATE || (rate === 0 && buf[0]))
        throw corrupt(`bad rate byte 0x${buf[0].toString(16).padStart(2, '0')}`);
    if (buf[0] & ENTROPY) {
        ransCheck(buf, rate, channels);
        return rate;
    }
    const want = tileBufferSize(rate, channels);
    if (len !== want)
        throw corrupt(`${len} bytes where rate ${rate} needs ${want}`);
    return rate;
}

/** The k + 1 cumulative frequencies of a model at `at` (cum[k] = 2^15). */
function readCum(buf, at, k) {
    const cum = new Uint32Array(k + 1);
    for (let s = 0; s < k; s++)
        cum[s] = u16(buf, at + 2 * s);
    cum[k] = PROB_SCALE;
    return cum;
}

/** Last symbol of cum (k symbols) whose cumulative frequency is <= slot. */
function findSymbol(cum, k, slot) {
    let lo = 0, hi = k - 1;
    while (lo < hi) {
        const mid = (lo + hi + 1) >> 1;
        if (cum[mid] <= slot)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/**
 * gv_rans_unpack: decode the 257 streams of an entropy-coded buffer (E or
 * EX) into idx (a Uint16Array of NBLOCKS, row-major by block row),
 * validating each stream (no read past its end, clean final state).
 * Throws on damage.
 */
export function ransUnpack(buf, rate, channels, idx) {
    ransCheck(buf, rate, channels);
    const l = ransLayout(buf, rate, channels);
    const k = l.k;
    // The cumulative frequencies once, with cum[k] = PROB_SCALE, so the
    // inner loop reads arrays rather than bytes (same values).
    const cum = readCum(buf, l.tables, k);
    let models = null, map = null;
    if (l.ctx) {
        models = [];
        for (let c = 0; c < l.contexts; c++)
            models.push(readCum(buf, l.models + 2 * SYMBOLS * c, SYMBOLS));
        map = [];
        for (let p = 0; p < 16; p++)
            map.push(models[(buf[l.map + (p >> 1)] >> (4 * (p & 1))) & 15]);
    }
    let at = l.streams;
    for (let row = 0; row < BLOCKS; row++) {
        const n = u16(buf, l.lengths + 2 * row);
        const w = at;
        // x stays below 2^32: use >>> 0 to keep it unsigned.
        let x = (u16(buf, w) | (u16(buf, w + 2) << 16)) >>> 0;
        let next = 2;
        // One symbol of model m (k symbols): its value; throws on damage.
        // f <= 2^15 and x >> 15 < 2^17: exact in a double; >>> 0 wraps
        // like the C uint32 arithmetic (only damaged data gets that far).
        const step = (m, km, linear) => {
            if (x < RANS_L)
                throw corrupt(`stream ${row} is corrupt`);
            const slot = x & (PROB_SCALE - 1);
            let s;
            if (linear) {
                s = 0;
                while (s < ESCAPE && m[s + 1] <= slot)
                    s++;
            } else {
                s = findSymbol(m, km, slot);
            }
            const c = m[s], f = m[s + 1] - c;
            if (f === 0)
                throw corrupt(`stream ${row} is corrupt`);
            x = (f * (x >>> PROB_BITS) + slot - c) >>> 0;
            if (x < RANS_L) {
                if (next >= n)
                    throw corrupt(`stream ${row} ends early`);
                x = (x * 65536 + u16(buf, w + 2 * next++)) >>> 0;
            }
            return s;
        };
        const base = row * BLOCKS;
        let a = 0, b = 0;   // EX: classes of the two blocks before
        for (let i = 0; i < BLOCKS; i++) {
            let v;
            if (l.ctx) {
                const s = step(map[4 * a + b], SYMBOLS, true);
                v = s === ESCAPE ? step(cum, k, false) : s;
                b = a;
                a = CLASS[s];
            } else {
                v = step(cum, k, false);
            }
            idx[base + i] = v;
        }
        if (x !== RANS_L || next !== n)
            throw corrupt(`stream ${row} does not end cleanly`);
        at += 2 * n;
    }
}

/** Words of the R32UI texture that holds a tile buffer: 1024 per row. */
export const WORDS_WIDTH = 1024;
export const WORDS_ROWS_MAX = Math.ceil(TILEBUF_MAX / 4 / WORDS_WIDTH);

/**
 * Everything the GPU needs for one tile buffer (a Uint8Array): the buffer
 * as 32-bit little-endian words padded to whole rows of WORDS_WIDTH, for
 * an entropy-coded tile (E, EX) its decoded indices (else null), for a
 * layout-D tile its coefficient plane (an Int16Array of DCT_PLANE, with
 * each block's bounds in its first texel's fourth component, else
 * null; its words are the first row only, which holds byte 0: the shader
 * reads nothing else of a D buffer).  Checks the buffer first; throws on
 * damage.
 */
export function prepareTile(buf, channels) {
    const rate = checkTile(buf, channels);
    const dct = isDct(buf[0]);
    const nwords = dct ? Math.min(buf.length >> 2, WORDS_WIDTH) : buf.length >> 2;
    const rows = Math.max(1, Math.ceil(nwords / WORDS_WIDTH));
    const words = new Uint32Array(rows * WORDS_WIDTH);
    const dv = new DataView(buf.buffer, buf.byteOffset, buf.length);
    for (let i = 0; i < nwords; i++)
        words[i] = dv.getUint32(4 * i, true);
    let indices = null, coefs = null;
    if (dct) {
        coefs = new Int16Array(DCT_PLANE);
        dctUnpack(buf, channels, coefs, true);   // with the blocks' bounds
    } else if (buf[0] & ENTROPY) {
        indices = new Uint16Array(NBLOCKS);
        ransUnpack(buf, rate, channels, indices);
    }
    return { rate, entropy: dct || !!(buf[0] & ENTROPY), dct, bytes: buf.length, rows, words, indices, coefs };
}
