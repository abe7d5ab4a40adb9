// height.mjs - the browser's WebGL2 decoder of codes (client/web/heighttile.js,
// client/web/codes_decode.js, shaders/height_decode.frag.glsl as GLSL ES
// 3.00 with GV_LAYERED) in headless Chromium: every tile of every level of
// the height store `--id` decoded in the page from the root and the tile
// buffers the daemon serves, compared with the CPU reference decoder's
// codes (/region?format=png16 over the pixels the tile is the source of),
// sample for sample.  A sample store (docs/FORMAT.md section 13) has every
// channel decoded, each tile split by heighttile.js's prepareSampleTile
// into the layers of one texture; channel K is compared with channel K of
// the png16 region.  Prints TAP lines; tests/browser_height.sh runs it.
//
//   node height.mjs --base URL --id ID --chromium PATH [--channel K]
import { inflateSync } from 'node:zlib';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launchChromium } from './chromium.mjs';

const opt = {};
for (let i = 2; i + 1 < process.argv.length; i += 2)
    opt[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];

let n = 0, failed = 0;
function check(ok, what, ...why) {
    n++;
    console.log(`${ok ? 'ok' : 'not ok'} ${n} - ${what}`);
    if (!ok) { failed++; for (const w of why) console.log(`#   ${w}`); }
}

// Channel `ch` of a 16-bit PNG of 1 to 4 channels (what
// /region?format=png16 sends) as a Uint16Array.
function png16(bytes, ch = 0) {
    const b = Buffer.from(bytes);
    let at = 8, w = 0, h = 0, nc = 1;
    const idat = [];
    while (at < b.length) {
        const len = b.readUInt32BE(at), type = b.toString('latin1', at + 4, at + 8);
        const data = b.subarray(at + 8, at + 8 + len);
        if (type === 'IHDR') {
            w = data.readUInt32BE(0); h = data.readUInt32BE(4);
            nc = { 0: 1, 4: 2, 2: 3, 6: 4 }[data[9]];
            if (data[8] !== 16 || !nc || data[12] !== 0)
                throw new Error('not a non-interlaced 16-bit PNG');
        } else if (type === 'IDAT') idat.push(data);
        at += 12 + len;
    }
    const raw = inflateSync(Buffer.concat(idat)), stride = 2 * nc * w, bpp = 2 * nc;
    const out = Buffer.alloc(stride * h);
    for (let y = 0; y < h; y++) {
        const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
        for (let x = 0; x < stride; x++) {
            const a = x >= bpp ? out[y * stride + x - bpp] : 0;
            const up = y > 0 ? out[(y - 1) * stride + x] : 0;
            const c = y > 0 && x >= bpp ? out[(y - 1) * stride + x - bpp] : 0;
            let v = src[x];
            if (f === 1) v += a;
            else if (f === 2) v += up;
            else if (f === 3) v += (a + up) >> 1;
            else if (f === 4) {
                const p = a + up - c, pa = Math.abs(p - a), pb = Math.abs(p - up), pc = Math.abs(p - c);
                v += pa <= pb && pa <= pc ? a : pb <= pc ? up : c;
            }
            out[y * stride + x] = v & 255;
        }
    }
    const codes = new Uint16Array(w * h);
    for (let i = 0; i < w * h; i++) codes[i] = out.readUInt16BE(2 * (i * nc + ch));
    return { w, h, codes };
}

const profile = mkdtempSync(join(tmpdir(), 'gv-height-'));
let ctx;
try {
    ctx = await launchChromium(profile, opt.chromium, 800, 600);
    const pg = await ctx.newPage();
    const errors = [];
    pg.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    pg.on('pageerror', (e) => errors.push(String(e)));
    await pg.goto(`${opt.base}/`);
    const ch = Number(opt.channel || 0);
    const r = await pg.evaluate(async ([id, ch]) => {
        const { CodesDecoder } = await import('/web/codes_decode.js');
        const { prepareSampleTile } = await import('/web/heighttile.js');
        const text = async (u) => (await fetch(u)).text();
        const bytes = async (u) => new Uint8Array(await (await fetch(u)).arrayBuffer());
        const info = await (await fetch(`/v1/images/${id}`)).json();
        const gl = document.createElement('canvas').getContext('webgl2');
        if (!gl) return { error: 'no WebGL2' };
        // Every channel decoded at once, into the layers of one texture.
        const nc = info.samples ? info.channels : 1;
        const d = new CodesDecoder(gl, nc, await text('/web/fullscreen.vert.glsl'),
            await text('/web/height_decode.frag.glsl'));
        // The root tile: the root clamp-padded to 513 x 513.
        const rw = info.root.width, rh = info.root.height;
        const rootBytes = await bytes(`/v1/images/${id}/root?format=raw`);
        const root = new Uint16Array(rootBytes.buffer, 0, rw * rh * nc), pad = new Uint16Array(513 * 513 * nc);
        for (let v = 0; v < 513; v++)
            for (let u = 0; u < 513; u++)
                for (let k = 0; k < nc; k++)
                    pad[(v * 513 + u) * nc + k] = root[(Math.min(v, rh - 1) * rw + Math.min(u, rw - 1)) * nc + k];
        let up = [d.upload(pad, 513, 513)], upTx = 1;
        const tiles = [];
        for (let k = info.levels_tiled - 1; k >= 0; k--) {
            const L = info.levels[k], cur = [];
            for (let ty = 0; ty < L.tiles_y; ty++)
                for (let tx = 0; tx < L.tiles_x; tx++) {
                    const whole = await bytes(`/v1/images/${id}/tiles/${k}/${tx}/${ty}`);
                    const prep = prepareSampleTile(whole, nc);
                    const tex = d.decode(prep, up[(ty >> 1) * upTx + (tx >> 1)], tx & 1, ty & 1);
                    cur.push(tex);
                    const codes = d.read(tex);
                    // The pixels this tile is the source of (FORMAT.md 2).
                    const x = 512 * tx, y = 512 * ty;
                    const w = tx === L.tiles_x - 1 ? L.width - x : 512, h = ty === L.tiles_y - 1 ? L.height - y : 512;
                    const mine = [];
                    for (let j = 0; j < h; j++)
                        for (let i = 0; i < w; i++) mine.push(codes[(j * 513 + i) * nc + ch]);
                    tiles.push({ k, tx, ty, x, y, w, h, mode: prep.coded[ch], mine });
                }
            for (const t of up) gl.deleteTexture(t);
            up = cur;
            upTx = L.tiles_x;
        }
        return { tiles };
    }, [opt.id, ch]);
    if (r.error) {
        console.log(`1..0 # SKIP ${r.error}`);
        process.exit(0);
    }
    let exact = 0, coded = 0;
    const bad = [];
    for (const t of r.tiles) {
        const res = await fetch(`${opt.base}/v1/images/${opt.id}/region?level=${t.k}&x=${t.x}&y=${t.y}&w=${t.w}&h=${t.h}&format=png16`);
        const ref = png16(new Uint8Array(await res.arrayBuffer()), ch);
        let diff = 0, first = '';
        for (let i = 0; i < ref.codes.length; i++)
            if (ref.codes[i] !== t.mine[i]) {
                if (!diff) first = ` first at (${i % t.w},${Math.floor(i / t.w)}): browser ${t.mine[i]}, CPU ${ref.codes[i]}`;
                diff++;
            }
        if (diff === 0 && ref.codes.length === t.mine.length) exact++;
        else bad.push(`${t.k}/${t.tx}/${t.ty}: ${diff} samples differ${first}`);
        coded += t.mode === 1;
    }
    check(r.tiles.length > 0 && exact === r.tiles.length,
        `${opt.id}${opt.channel ? ` channel ${ch}` : ''}: all ${r.tiles.length} height tiles decoded by WebGL2 equal the CPU decoder sample for sample (${coded} rANS-coded)`,
        ...bad.slice(0, 8));
    check(errors.length === 0, `${opt.id}: no console errors`, ...errors.slice(0, 5));
} catch (e) {
    check(false, 'the browser run', String(e && e.stack || e));
} finally {
    if (ctx) await ctx.close();
    rmSync(profile, { recursive: true, force: true });
}
console.log(`1..${n}`);
process.exit(failed ? 1 : 0);
