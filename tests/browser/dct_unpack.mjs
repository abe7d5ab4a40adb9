// dct_unpack.mjs - the browser's layout-D unpacking (client/web/tile_dct.js,
// docs/FORMAT.md section 4.3) against the CPU reference decoder's
// (gv_dct_unpack, through tests/dct_coefs), in node: no browser needed.
//
//   node dct_unpack.mjs --base http://127.0.0.1:PORT --helper PATH --images ID[,ID...]
//
// Fetches every tile of every tiled level of the images (GET batches,
// client/web/batch.js's parser), keeps the layout-D ones (there must be
// some in each image), adds the buffers of `dct_coefs --fixtures` (what
// an encoder rarely writes: escapes over their whole range, products
// clamped to 16 bits, every coefficient coded, none), and checks for
// each, intact, with a quantizer step changed (still well-formed) and, for
// the tiles, damaged in deterministic ways (a random byte of the header,
// models or lengths changed, a random byte of the streams changed; each
// rule of the layout check broken once: steps of 0, 4096 and one for an
// absent channel, byte 1, a model's first frequency, a decreasing model,
// a stream of 1 word, nonzero padding, 4 bytes cut off, 4 zero bytes
// added, a stored model's mask bit cleared, mask bit 30 set; the other
// channel count), that tile_dct.js accepts exactly the buffers the C decoder
// accepts and then produces the same coefficient plane (its FNV-1a hash
// and nonzero count), and refuses the others with the same message;
// and that the bounds prepareTile adds to each block bound its nonzero
// coefficients exactly.  Negative control: a plane with one coefficient
// changed must not match.  Exit 0 when every check passed, 1 otherwise,
// 2 on a usage error.
import { spawnSync } from 'node:child_process';
import { parseBatch } from '../../client/web/batch.js';
import { DCT, DCT2, DCT_PLANE, dctUnpack, isDct } from '../../client/web/tile_dct.js';
import { check, fail, failed, note, parseArgs } from './report.mjs';

const opt = { base: '', helper: '', images: '' };
parseArgs(opt, 'usage: node dct_unpack.mjs --base URL --helper PATH --images ID[,ID...]',
    'dct_unpack.mjs', ['base', 'helper', 'images']);
const base = opt.base.replace(/\/+$/, '');
const BATCH = 64;

// FNV-1a over the plane's int16s as little-endian bytes (as dct_coefs).
function digest(coefs) {
    let h = 0x811c9dc5, nonzero = 0;
    for (let i = 0; i < coefs.length; i++) {
        const v = coefs[i] & 0xffff;
        h = Math.imul(h ^ (v & 0xff), 16777619);
        h = Math.imul(h ^ (v >> 8), 16777619);
        if (v) nonzero++;
    }
    return `${(h >>> 0).toString(16).padStart(8, '0')} ${nonzero}`;
}

// A small deterministic generator (mulberry32).
function rng(seed) {
    let a = seed >>> 0;
    return () => {
        a = (a + 0x6d2b79f5) >>> 0;
        let t = a;
        t = Math.imul(t ^ (t >>> 15), t | 1);
        t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
        return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
    };
}

// Where the parts of a (well-formed) D buffer lie: the stored models
// [m, offset, symbols] (65 symbols below model 6, 16 from it), the stream
// lengths (after them, even), the streams (130 bytes on) and their end.
function partsOf(buf) {
    const mask = (buf[8] | buf[9] << 8 | buf[10] << 16 | buf[11] << 24) >>> 0;
    const models = [];
    let off = 12;
    for (let m = 0; m < (buf[0] === DCT2 ? 32 : 30); m++)
        if ((mask >>> m) & 1) {
            models.push([m, off, m < 6 ? 65 : 16]);
            off += m < 6 ? 65 : 16;
        }
    const lengths = (off + 1) & ~1;
    let end = lengths + 130;
    for (let i = 0; i < 65; i++)
        end += 2 * (buf[lengths + 2 * i] | buf[lengths + 2 * i + 1] << 8);
    return { mask, models, lengths, streams: lengths + 130, end };
}

// A buffer with quantizer step 0 changed (to 4095, or 1 where it is
// 4095): still well-formed, other coefficients (clamped at 4095).
function restepped(buf) {
    const b = buf.slice(), s = b[2] | b[3] << 8, t = s === 4095 ? 1 : 4095;
    b[2] = t & 255;
    b[3] = t >> 8;
    return b;
}

// The variants of one buffer: [what, buffer, channels], intact first.
function variants(buf, channels, rand) {
    const out = [['intact', buf, channels], ['quantizer step 0 changed', restepped(buf), channels]];
    const at = (lo, hi) => lo + Math.floor(rand() * (hi - lo));
    const flip = (what, lo, hi) => {
        const b = buf.slice(), i = at(lo, hi);
        b[i] ^= 1 + Math.floor(rand() * 255);
        out.push([`${what} (byte ${i})`, b, channels]);
    };
    const p = partsOf(buf), s = p.streams;
    const set = (what, ...pairs) => {
        const b = buf.slice();
        for (let i = 0; i < pairs.length; i += 2)
            b[pairs[i]] = pairs[i + 1];
        out.push([what, b, channels]);
    };
    flip('a header, model or length byte changed', 0, s);
    flip('a stream byte changed', s, buf.length);
    set('quantizer step 0 of 0', 2, 0, 3, 0);
    set('quantizer step 0 of 4096', 2, 0, 3, 16);
    if (channels === 1)
        set('quantizer step 1 of 1 in a gray buffer', 4, 1);
    else
        set('quantizer step 2 of 0', 6, 0, 7, 0);
    set('byte 1 not 0', 1, 1);
    if (p.models.length) {
        const [m, mo, k] = p.models[0];
        set(`model ${m} starting at 1`, mo, 1);
        let top = k - 1;             // a symbol after a nonzero one: made to decrease
        while (top > 1 && buf[mo + top - 1] === 0) top--;
        if (buf[mo + top - 1] > 0)
            set(`model ${m} decreasing at symbol ${top}`, mo + top, buf[mo + top - 1] - 1);
    }
    set('stream 0 of 1 word', p.lengths, 1, p.lengths + 1, 0);
    if (p.end < buf.length)
        set('nonzero padding', buf.length - 1, 1);
    out.push(['4 bytes cut off', buf.slice(0, buf.length - 4), channels]);
    const longer = new Uint8Array(buf.length + 4);
    longer.set(buf);
    out.push(['4 zero bytes added', longer, channels]);
    if (p.models.length) {
        const m = p.models[Math.floor(rand() * p.models.length)][0], b = buf.slice();
        b[8 + (m >> 3)] &= ~(1 << (m & 7));
        out.push([`mask bit ${m} cleared`, b, channels]);
    }
    const b30 = buf.slice();
    b30[11] |= 0x40;
    out.push(['mask bit 30 set', b30, channels]);
    if (buf[0] === DCT2) {
        const bd = buf.slice();
        bd[0] = DCT;
        out.push(['named layout D', bd, channels]);
    }
    out.push(['the other channel count', buf, channels === 3 ? 1 : 3]);
    return out;
}

async function json(url) {
    const r = await fetch(url);
    if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
    return r.json();
}

// Every tile of every tiled level of image `id`: [{key, buf}].
async function tilesOf(id) {
    const info = await json(`${base}/v1/images/${id}`);
    const want = [];
    for (const L of info.levels)
        for (let y = 0; y < L.tiles_y; y++)
            for (let x = 0; x < L.tiles_x; x++)
                want.push([L.level, x, y]);
    const out = [];
    for (let i = 0; i < want.length; i += BATCH) {
        const part = want.slice(i, i + BATCH);
        const url = `${base}/v1/images/${id}/batch?t=${part.map((t) => t.join(',')).join(';')}`;
        const r = await fetch(url);
        if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
        for (const f of parseBatch(await r.arrayBuffer())) {
            if (f.status !== 200) throw new Error(`${id} ${f.level}/${f.tx}/${f.ty}: HTTP ${f.status}`);
            out.push({ key: `${id} ${f.level}/${f.tx}/${f.ty}`, buf: new Uint8Array(f.tile) });
        }
    }
    return { channels: info.channels, tiles: out };
}

try {
    const cases = [];
    for (const id of opt.images.split(',')) {
        const { channels, tiles } = await tilesOf(id);
        const d = tiles.filter((t) => isDct(t.buf[0]));
        check(d.length > 0, `${id}: ${d.length} of its ${tiles.length} tiles are layout D or D2 (${channels === 3 ? 'RGB' : 'gray'})`);
        const rand = rng(12 + d.length);
        for (const t of d)
            for (const [what, buf, c] of variants(t.buf, channels, rand))
                cases.push({ key: `${t.key}: ${what}`, buf, channels: c, intact: what === 'intact',
                    tile: what === 'intact' });
    }
    // The helper's fixtures (escapes, clamps, full and empty blocks;
    // gray, then RGB), each also with a changed step.
    const fx = spawnSync(opt.helper, ['--fixtures'], { maxBuffer: 64 << 20 });
    if (fx.status !== 0)
        throw new Error(`${opt.helper} --fixtures: exit ${fx.status}: ${fx.stderr}`);
    let nfix = 0;
    for (let at = 0; at < fx.stdout.length; nfix++) {
        const len = fx.stdout.readUInt32LE(at), channels = fx.stdout[at + 4];
        const buf = new Uint8Array(fx.stdout.subarray(at + 5, at + 5 + len));
        cases.push({ key: `fixture ${nfix} (${channels === 3 ? 'RGB' : 'gray'})`, buf, channels, intact: true });
        cases.push({ key: `fixture ${nfix}: quantizer step 0 changed`, buf: restepped(buf), channels, intact: false });
        at += 5 + len;
    }
    check(nfix === 8, `dct_coefs --fixtures wrote ${nfix} buffers (4 kinds, gray and RGB)`);
    // One run of the helper for all of them.
    const parts = [];
    for (const c of cases) {
        const h = Buffer.alloc(5);
        h.writeUInt32LE(c.buf.length, 0);
        h[4] = c.channels;
        parts.push(h, Buffer.from(c.buf.buffer, c.buf.byteOffset, c.buf.length));
    }
    const r = spawnSync(opt.helper, [], { input: Buffer.concat(parts), maxBuffer: 64 << 20 });
    if (r.status !== 0)
        throw new Error(`${opt.helper}: exit ${r.status}: ${r.stderr}`);
    const lines = r.stdout.toString().split('\n').filter((l) => l);
    if (lines.length !== cases.length)
        throw new Error(`${opt.helper}: ${lines.length} lines for ${cases.length} buffers`);
    const coefs = new Int16Array(DCT_PLANE);
    let intact = 0, refused = 0, accepted = 0, control = null, unpackMs = 0, unpacked = 0;
    // With bounds (what prepareTile uploads): the same plane but in the
    // fourth component of each block's first texel, which must bound the
    // block's nonzero coefficients exactly (rows | columns << 4, 1..8).
    const withBounds = new Int16Array(DCT_PLANE), badBounds = [];
    const checkBounds = (c) => {
        dctUnpack(c.buf, c.channels, withBounds, true);
        let wrong = 0;
        for (let Y = 0; Y < 520; Y++)
            for (let X = 0; X < 520; X++) {
                const i = 4 * (520 * Y + X);
                for (let k = 0; k < 3; k++)
                    if (withBounds[i + k] !== coefs[i + k]) wrong++;
                if ((X & 7) || (Y & 7)) {
                    if (withBounds[i + 3] !== 0) wrong++;
                    continue;
                }
                let rows = 1, cols = 1;
                for (let v = 0; v < 8; v++)
                    for (let u = 0; u < 8; u++)
                        for (let k = 0; k < 3; k++)
                            if (coefs[i + 4 * (520 * v + u) + k]) {
                                rows = Math.max(rows, v + 1);
                                cols = Math.max(cols, u + 1);
                            }
                if (withBounds[i + 3] !== (rows | cols << 4)) wrong++;
            }
        if (wrong)
            badBounds.push(`${c.key}: ${wrong} values wrong`);
    };
    const bad = [], badIntact = [];
    cases.forEach((c, i) => {
        const cpu = lines[i];
        let js;
        try {
            const t0 = performance.now();
            dctUnpack(c.buf, c.channels, coefs);
            if (c.tile) {
                unpackMs += performance.now() - t0;
                unpacked++;
            }
            js = `ok ${digest(coefs)}`;
        } catch (e) {
            if (e.code !== 'corrupt') throw e;
            js = `corrupt ${e.message}`;   // "tile: ..." as the C decoder's
        }
        const same = js === cpu;   // the same coefficients, or the same message
        if (!same)
            (c.intact ? badIntact : bad).push(`${c.key}: C "${cpu}", JavaScript "${js}"`);
        if (c.intact) {
            intact += cpu.startsWith('ok ') && same;
            if (cpu.startsWith('ok '))
                checkBounds(c);
            if (control === null && cpu.startsWith('ok ')) {
                coefs[4 * (520 * 3 + 5)] ^= 1;   // texel (5, 3), channel 0
                control = `ok ${digest(coefs)}` !== cpu;
            }
        } else if (cpu.startsWith('ok ')) {
            accepted++;
        } else {
            refused++;
        }
    });
    const nIntact = cases.filter((c) => c.intact).length;
    check(intact === nIntact && nIntact > 0,
        `all ${nIntact} layout-D buffers (the stores' tiles and ${nfix} fixtures): tile_dct.js unpacks the same coefficients as gv_dct_unpack`,
        ...badIntact.slice(0, 8));
    check(bad.length === 0,
        `${cases.length - nIntact} changed or damaged buffers: both refuse the same ${refused} with the same message, both accept the same ${accepted} with the same coefficients`,
        ...bad.slice(0, 8));
    check(badBounds.length === 0 && intact > 0,
        `the ${intact} planes with their blocks' bounds (as prepareTile uploads them) differ only there, each bounding its block's nonzero coefficients`,
        ...badBounds.slice(0, 8));
    check(control === true, 'negative control: a plane with one coefficient changed does not match');
    note(`${cases.length} buffers compared; tile_dct.js unpacked the ${unpacked} intact store tiles in ${unpackMs.toFixed(0)} ms (a measurement, not a check)`);
} catch (e) {
    fail('dct_unpack.mjs ran', String(e && e.stack || e));
}
process.exit(failed ? 1 : 0);
