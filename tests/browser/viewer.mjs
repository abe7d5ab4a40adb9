// viewer.mjs - the browser viewer (client/web/, served by gigaviewd at /)
// in headless Chromium with WebGL2 on SwiftShader, driven by
// playwright-core.
//
//   node viewer.mjs --base http://127.0.0.1:PORT --gigaview PATH
//        [--chromium /usr/bin/chromium] [--out DIR] [--sabotage shader|rans|dct|matrix|root[,...]] [--only eviction|dct]
//        [--dctcoefs tests/dct_coefs]
//
// Needs stores "picos" (tests/data/picos-1100x700.jpg: two tiled levels,
// every tile entropy-coded), "synth" (synth:3000x2000: three tiled
// levels at -q 30, fixed-layout and entropy-coded tiles), "picosd" and
// "grayd" (layout-D tiles, RGB and gray) on the server.  The page
// is 800 x 500 CSS pixels at device scale 1.
//
// Checks, one a line as "PASS text" or "FAIL text" (details start with
// "#"; tests/browser_viewer.sh turns them into TAP):
//   1. 1:1 views of a level (integer zoom, no rotation, the view centre
//      placed so that pixel centres fall on texel centres) read back from
//      the canvas equal the server's region endpoint (CPU reference
//      decoder) bit for bit: every pixel identical (so also the mean
//      absolute difference <= MAX_MAD per channel that the viewer's goal
//      asks for); on levels 0 and 1 of picos and synth, across tile edges, and
//      with the image smaller than the canvas (black outside); the root
//      they start from came in one request, the store's lossless WebP;
//   2. every decoded tile texture, read back, equals the region endpoint
//      over the tile's 513 x 513 pixels (inside the level), for both tile
//      layouts: the shared decode shader and the JavaScript rANS decoder
//      are bit-exact in the browser; also after an eviction tour at a
//      16 MiB texture budget, and for a prefetch that must make room
//      while the parent it decodes from is the least recently used tile
//      (checkPrefetchEviction: that parent must not be the one evicted);
//   2b. the same two checks on the stores picosd and grayd, among whose
//      decoded tiles there must be layout-D ones (checkDctStores); with
//      --dctcoefs, the synthetic layout-D tiles of `dct_coefs
//      --fixture-tiles` (escapes, clamped coefficients and pixels, full
//      and empty blocks) decoded by the page's own GpuDecoder equal
//      gv_tile_decode's, and one with a changed step does not;
//   3. each metric rejects the reference moved by one pixel, so it cannot
//      pass by accident;
//   4. scripted input: a mouse drag pans by exactly its distance, "+"
//      zooms by half a level about the centre, "]" rotates by 15 degrees,
//      the wheel zooms about the cursor (the image point under it stays),
//      a two-finger touch gesture (Chrome DevTools Protocol touch events)
//      pinches and rotates, a gamepad stick (a scripted Gamepad API
//      device) pans, and "0" returns to the whole image; the views reached
//      are compared with `gigaview render` of the same view (the native
//      client: same sampling, decoded through EGL), MAD <= MAX_MAD;
//   5. the URL hash: a view written to the hash, opened in a new page,
//      gives the same view state and the same pixels;
//   6. without WebGL2 (renderer=region) a 1:1 view matches the region
//      endpoint too;
//   7. the image list is served in the page, and nothing was logged to
//      the console as an error.
// --sabotage shader serves a decode shader with one prediction weight
// changed, --sabotage rans a rANS decoder that flips the lowest bit of
// every index, --sabotage dct a layout-D unpacking with the zigzag order
// transposed (on picosd), --sabotage matrix a decode shader whose matrix
// K (shaders/dct_matrix.glsl, included in the served text) has one entry
// changed (on picosd), --sabotage root a root whose every 97th sample
// has its lowest bit flipped: check 1 must then FAIL (tests/browser_viewer.sh expects
// that: negative controls of the whole pipeline); only check 1 runs.
// Several, comma-separated (--sabotage shader,rans,root), run one after
// the other in the same browser, each on a page of its own whose output
// begins with "# sabotage: NAME" (one browser start for all of them).
// Exit status 0 when everything passed, 1 otherwise, 2 on a usage error.
import { execFileSync } from 'node:child_process';
import { mkdtempSync, mkdirSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launchChromium, PATIENCE_MS } from './chromium.mjs';
import { pass, fail, note, check, failed, parseArgs } from './report.mjs';

const MAX_MAD = 1;      // mean absolute difference per channel, 8-bit units
const W = 800, H = 500;

const opt = { chromium: '/usr/bin/chromium', out: '', sabotage: '', only: '', base: '', gigaview: '', filters: '0', token: '', dctcoefs: '' };
parseArgs(opt, 'usage: node viewer.mjs --base URL --gigaview PATH [--chromium PATH] [--out DIR] [--sabotage shader|rans|dct|matrix|root[,...]] [--only eviction|dct] [--dctcoefs PATH] [--filters 1 --token TOKEN]', 'viewer.mjs', ['base', 'gigaview']);
const base = opt.base.replace(/\/+$/, '');

let lapT = Date.now();
// lap(what): how long the checks since the last lap took.
const lap = (what) => { note(`time: ${what} ${Date.now() - lapT} ms`); lapT = Date.now(); };
const scratch = mkdtempSync(join(tmpdir(), 'gv-viewer-'));
const consoleErrors = [];
// Errors a flow provokes on purpose: Chrome logs every HTTP error status
// of a fetch as a console error, and the compile-error check gets a 400.
const expectedErrors = [];


// ------------------------------------------------------------ helpers

async function newPage(c) {
    const pg = await c.newPage();
    pg.setDefaultTimeout(60000);
    pg.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(`${m.text()} (${m.location().url})`); });
    pg.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
    return pg;
}

// Open the viewer at hash h (query q) and wait for a complete picture.
async function open(pg, h, q = '') {
    await pg.goto(`${base}/${q}${h}`);
    await pg.evaluate(() => window.gigaview.ready);
    // A change of the hash alone opens the image after `ready`.
    const id = new URLSearchParams(h.slice(1)).get('image');
    await pg.waitForFunction((id) => window.gigaview.viewer.image && window.gigaview.viewer.image.id === id &&
        window.gigaview.viewer.view, id);
    return settle(pg);
}

const settle = (pg) => pg.evaluate(() => window.gigaview.viewer.settled());
const view = (pg) => pg.evaluate(() => window.gigaview.viewer.view);
const setView = (pg, v) => pg.evaluate((v) => window.gigaview.viewer.setView(v), v);
const fmtv = (v) => `centre ${v.cx.toFixed(3)},${v.cy.toFixed(3)} zoom ${v.zoom.toFixed(4)} rotation ${v.rot.toFixed(3)}`;
const near = (a, b, eps = 1e-6) => Math.abs(a - b) <= eps;

// The in-page comparison code, installed once per page: decode a PNG
// (URL or data:) to RGBA without colour management; compare two RGBA
// buffers over a window; read the viewer's canvas.
async function installCompare(pg) {
    await pg.evaluate(() => {
        window.gvt = {
            async png(url) {
                let blob;
                if (url.startsWith('data:')) {    // the page's CSP allows no fetch of data: URLs
                    const bin = atob(url.slice(url.indexOf(',') + 1));
                    const u8 = new Uint8Array(bin.length);
                    for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
                    blob = new Blob([u8], { type: 'image/png' });
                } else {
                    const r = await fetch(url);
                    if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
                    blob = await r.blob();
                }
                const b = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
                const c = new OffscreenCanvas(b.width, b.height);
                const g = c.getContext('2d', { willReadFrequently: true });
                g.drawImage(b, 0, 0);
                return { w: b.width, h: b.height, px: g.getImageData(0, 0, b.width, b.height).data };
            },
            // a (aw wide, RGBA) at (ox + x + dx, oy + y) against b (bw wide,
            // RGBA or C channels) at (x, y), for x < w, y < h.
            diff(a, aw, b, bw, bc, ox, oy, w, h, dx = 0) {
                const sad = [0, 0, 0];
                let max = 0, same = 0, n = 0;
                for (let y = 0; y < h; y++)
                    for (let x = 0; x < w; x++) {
                        const ax = ox + x + dx;
                        if (ax < ox || ax >= ox + w) continue;
                        const i = 4 * ((oy + y) * aw + ax), j = bc * (y * bw + x);
                        let eq = true;
                        for (let c = 0; c < 3; c++) {
                            const d = Math.abs(a[i + c] - b[j + (bc === 1 ? 0 : c)]);
                            sad[c] += d;
                            if (d > max) max = d;
                            if (d) eq = false;
                        }
                        same += eq;
                        n++;
                    }
                return { mad: sad.map((s) => s / n), max, same, n };
            },
            // Pixels of a (aw x ah) outside [ox, ox+w) x [oy, oy+h) that are not black.
            outside(a, aw, ah, ox, oy, w, h) {
                let bad = 0;
                for (let y = 0; y < ah; y++)
                    for (let x = 0; x < aw; x++) {
                        if (x >= ox && x < ox + w && y >= oy && y < oy + h) continue;
                        const i = 4 * (y * aw + x);
                        if (a[i] || a[i + 1] || a[i + 2]) bad++;
                    }
                return bad;
            },
        };
    });
}

const fmtd = (m) => `MAD R/G/B ${m.mad.map((x) => x.toFixed(3)).join('/')}, max ${m.max}, identical ${m.same}/${m.n}`;
const within = (m) => m.mad.every((v) => v <= MAX_MAD);

// Compare the viewer's canvas with the region endpoint: level k pixels
// (x, y, w, h) shown at canvas (ox, oy); black elsewhere.
async function checkRegion(pg, label, k, x, y, w, h, ox, oy, sensitivity = true) {
    const url = `${base}/v1/images/${await pg.evaluate(() => window.gigaview.viewer.image.id)}/region?level=${k}&x=${x}&y=${y}&w=${w}&h=${h}&format=png`;
    const r = await pg.evaluate(async ({ url, k, w, h, ox, oy, W, H }) => {
        const v = window.gigaview.viewer;
        const a = v.snapshot();
        const ref = await window.gvt.png(url);
        return {
            same: window.gvt.diff(a, W, ref.px, ref.w, 4, ox, oy, w, h),
            shifted: window.gvt.diff(a, W, ref.px, ref.w, 4, ox, oy, w, h, 1),
            outside: window.gvt.outside(a, W, H, ox, oy, w, h),
            cw: v.canvas.width, ch: v.canvas.height,
        };
    }, { url, k, w, h, ox, oy, W, H });
    if (r.cw !== W || r.ch !== H)
        fail(`${label}: the canvas is ${W}x${H}`, `it is ${r.cw}x${r.ch}`);
    // A 1:1 view must be identical, not merely close: a decoder with one
    // prediction weight off by one stays under MAD 0.2 (--sabotage shader).
    check(within(r.same) && r.same.same === r.same.n && r.outside === 0,
        `${label}: the canvas matches ${url.slice(base.length)} at (${ox},${oy}) bit for bit (${fmtd(r.same)}; ${r.outside} non-black pixels outside the image)`,
        `${fmtd(r.same)}; wanted every pixel identical (and MAD <= ${MAX_MAD}); non-black outside: ${r.outside}`);
    if (sensitivity)
        check(!within(r.shifted), `${label}: the metric rejects the reference moved by 1 pixel (${fmtd(r.shifted)})`,
            `shifted: ${fmtd(r.shifted)}`);
    return r.same;
}

// `gigaview render` of the view shown, as a data: URL of a PNG.
function nativeRender(id, v) {
    const out = join(scratch, `ref-${Date.now()}.png`);
    execFileSync(opt.gigaview, ['render', base, '--image', id, '--center', `${v.cx},${v.cy}`,
        '--zoom', String(v.zoom), '--rotate', String(v.rot), '--size', `${W}x${H}`, '--no-cache', '-o', out],
    { stdio: ['ignore', 'ignore', 'pipe'], timeout: PATIENCE_MS });
    const png = readFileSync(out);
    if (opt.out) writeFileSync(join(opt.out, `native-${v.zoom}-${v.rot}.png`), png);
    return `data:image/png;base64,${png.toString('base64')}`;
}

// Compare the canvas with the native client's render of the same view.
async function checkNative(pg, label) {
    const v = await view(pg);
    const id = await pg.evaluate(() => window.gigaview.viewer.image.id);
    let url;
    try {
        url = nativeRender(id, v);
    } catch (e) {
        fail(`${label}: gigaview render of the same view`, String(e.stderr || e.message));
        return;
    }
    const r = await pg.evaluate(async ({ url, W, H }) => {
        const a = window.gigaview.viewer.snapshot();
        const ref = await window.gvt.png(url);
        return { same: window.gvt.diff(a, W, ref.px, ref.w, 4, 0, 0, W, H),
            shifted: window.gvt.diff(a, W, ref.px, ref.w, 4, 0, 0, W, H, 1) };
    }, { url, W, H });
    check(within(r.same) && !within(r.shifted),
        `${label}: the canvas matches gigaview render of ${fmtv(v)} (${fmtd(r.same)}; moved 1 px: MAD ${r.shifted.mad.map((x) => x.toFixed(2)).join('/')})`,
        `${fmtd(r.same)} (limit ${MAX_MAD}); moved by 1 px: ${fmtd(r.shifted)} (must exceed the limit)`);
    if (opt.out) await shot(pg, `view-${label.replace(/\W+/g, '-')}`);
}

async function shot(pg, name) {
    if (!opt.out) return;
    mkdirSync(opt.out, { recursive: true });
    await pg.screenshot({ path: join(opt.out, `${name}.png`) });
}

// Every decoded tile against the region endpoint over the tile.
async function checkTiles(pg, label) {
    const r = await pg.evaluate(async () => {
        const v = window.gigaview.viewer, b = v.backend, info = v.image.info;
        const out = { exact: 0, entropy: 0, fixed: 0, dct: 0, bad: [] };
        for (const t of b.tiles()) {
            // The pixels the tile is the source of (FORMAT.md section 2):
            // its last row and column belong to the next tile, if any,
            // whose own decode of them may differ.
            const L = info.levels[t.level];
            const x = 512 * t.tx, y = 512 * t.ty;
            const w = t.tx === L.tiles_x - 1 ? L.width - x : 512, h = t.ty === L.tiles_y - 1 ? L.height - y : 512;
            const ref = await window.gvt.png(`${v.image.url}/region?level=${t.level}&x=${x}&y=${y}&w=${w}&h=${h}&format=png`);
            const px = b.readTile(t.level, t.tx, t.ty), c = info.channels;
            let diff = 0;
            for (let j = 0; j < h; j++)
                for (let i = 0; i < w; i++)
                    for (let k = 0; k < c; k++)
                        if (px[c * (j * 513 + i) + k] !== ref.px[4 * (j * w + i) + k]) diff++;
            if (diff === 0) out.exact++; else out.bad.push(`${t.level}/${t.tx}/${t.ty}: ${diff} samples differ`);
            if (t.entropy) out.entropy++; else out.fixed++;
            if (t.dct) out.dct++;
        }
        return out;
    });
    const n = r.entropy + r.fixed;
    check(n > 0 && r.exact === n,
        `${label}: all ${n} decoded tiles equal the CPU decoder bit for bit (${r.entropy} entropy-coded, ${r.dct} of them layout D; ${r.fixed} fixed layout)`,
        ...r.bad.slice(0, 8));
    return r;
}

// The race behind a view once seen half wrong after the eviction tour:
// prefetching makes room for a tile by evicting the least recently used
// tile outside the view and the circle, and that may be the very parent
// the tile is about to be decoded from (a prefetched tile's parent is
// often in no chain of the view).  The decode then reads no texture and
// leaves a wrong tile resident, drawn once the view gets there.  Forced
// here step by step on a TileCache of the page's own classes, decoder
// and image (synth: levels 0-2 tiled): G = 2/0/0 and P = 1/0/0 resident,
// P less recently used than G, child T = 0/1/1 fetched, the budget full
// at two tiles; then one frame that only prefetches T.
async function checkPrefetchEviction(pg) {
    const r = await pg.evaluate(async () => {
        const v = window.gigaview.viewer, b = v.backend, info = v.image.info;
        const TileCache = b.cache.constructor, Fetcher = b.fetcher.constructor;
        const fetcher = new Fetcher(0);
        let wake = null;
        const cache = new TileCache({
            decoder: b.decoder, info, imageUrl: v.image.url, levels: v.image.levels, fetcher,
            budget: 1 << 30, onChange: () => wake && wake(),
        });
        const changed = () => new Promise((ok) => { wake = ok; });
        const K = (t) => t.join('/');
        const G = [2, 0, 0], P = [1, 0, 0], T = [0, 1, 1];
        // frames(cond, needed): frames of `needed` until cond() holds.
        const frames = async (cond, needed) => {
            for (let i = 0; i < 50 && !cond(); i++) {
                const w = changed();
                cache.update(needed, [], 1e9);
                if (!cond() && (cache.batches > 0 || i === 0))
                    await w;
            }
        };
        try {
            cache.setRoot(b.image.root.px, b.image.root.w, b.image.root.h);
            await frames(() => cache.has(...P), [P]);
            const w = changed();
            cache.request(cache.wanted([T]));
            await w;
            cache.update([G], [], 1e9);             // G used after P
            const before = { g: cache.has(...G), p: cache.has(...P), t: cache.has(...T),
                prepared: cache.prep.has(K(T)), older: cache.tex.get(K(P)).used < cache.tex.get(K(G)).used };
            cache.budget = cache.texBytes;          // full: G and P
            cache.update([], [T], 1e9);             // prefetch T only
            const out = { before, g: cache.has(...G), p: cache.has(...P), t: cache.has(...T),
                evicted: cache.stats.evicted, diff: -1 };
            if (out.t) {
                const L = info.levels[0], x = 512 * T[1], y = 512 * T[2];
                const w0 = Math.min(512, L.width - x), h0 = Math.min(512, L.height - y), c = info.channels;
                const ref = await window.gvt.png(`${v.image.url}/region?level=0&x=${x}&y=${y}&w=${w0}&h=${h0}&format=png`);
                const px = b.decoder.read(cache.get(...T), 513, 513);
                out.diff = 0;
                for (let j = 0; j < h0; j++)
                    for (let i = 0; i < w0; i++)
                        for (let k = 0; k < c; k++)
                            if (px[c * (j * 513 + i) + k] !== ref.px[4 * (j * w0 + i) + k]) out.diff++;
                out.n = w0 * h0 * c;
            }
            return out;
        } finally {
            cache.dispose();
            fetcher.dispose();
        }
    });
    const b = r.before;
    if (!(b.g && b.p && !b.t && b.prepared && b.older)) {
        fail('prefetch eviction race: set-up', JSON.stringify(r));
        return;
    }
    check(r.t && r.p && !r.g && r.evicted === 1 && r.diff === 0,
        `a prefetched tile never evicts the parent it is decoded from: G evicted instead of P, T equals the CPU decoder (${r.diff} of ${r.n} samples differ)`,
        `after the prefetch frame: G ${r.g}, P ${r.p}, T ${r.t}, ${r.evicted} evicted, ${r.diff} of ${r.n} samples of T differ`);
}

// ------------------------------------------------------------ the run

// Layout D (FORMAT.md 4.3): "picosd" (RGB) and "grayd" (gray), encoded
// with transform-coded tiles, each decoded in the browser (tile_dct.js
// unpacks, the shader's u_coefs path transforms) at 1:1 on level 0 and
// every decoded tile against the CPU decoder; some must really be D (the
// encoder keeps VQ where that costs less).
async function checkDctStores(c) {
    const pg = await newPage(c);
    for (const [id, kind] of [['picosd', 'RGB'], ['grayd', 'gray']]) {
        await open(pg, `#image=${id}&x=550&y=350&z=0&r=0`);
        await installCompare(pg);
        check((await pg.evaluate(() => window.gigaview.viewer.stats.kind)) === 'webgl2',
            `${id}: the viewer opened with WebGL2`);
        await checkRegion(pg, `${id} (layout D2, ${kind}) level 0 1:1`, 0, 150, 100, W, H, 0, 0, false);
        const r = await checkTiles(pg, `${id} (layout D2, ${kind})`);
        const n = r.entropy + r.fixed;
        check(r.dct > 0, `${id}: layout-D2 tiles were decoded (${r.dct} of ${n})`);
        if (opt.dctcoefs)
            await checkDctFixtures(pg, id, kind === 'RGB' ? 3 : 1);
    }
    await pg.close();
}

// The synthetic layout-D tiles of `dct_coefs --fixture-tiles C` decoded
// by the page's GpuDecoder (its parent uploaded as the root is) against
// gv_tile_decode's tiles, bit for bit; the first also with quantizer step
// 0 changed, which must differ (the comparison can fail).
async function checkDctFixtures(pg, id, channels) {
    const raw = execFileSync(opt.dctcoefs, ['--fixture-tiles', String(channels)], { maxBuffer: 64 << 20 });
    const recs = [], tb = 513 * 513 * channels;
    for (let at = 0; at < raw.length;) {
        const len = raw.readUInt32LE(at), qx = raw[at + 5], qy = raw[at + 6], b = at + 9;
        recs.push({ qx, qy, buf: raw.subarray(b, b + len).toString('base64'),
            parent: raw.subarray(b + len, b + len + tb).toString('base64'),
            out: raw.subarray(b + len + tb, b + len + 2 * tb).toString('base64') });
        at = b + len + 2 * tb;
    }
    const r = await pg.evaluate(async ({ recs, channels }) => {
        const { prepareTile } = await import(new URL('web/tilebuf.js', document.baseURI));
        const bytes = (s) => Uint8Array.from(atob(s), (ch) => ch.charCodeAt(0));
        const d = window.gigaview.viewer.backend.decoder;
        const decode = (buf, parent, qx, qy) => {
            const ptex = d.upload(parent, 513, 513);
            const tex = d.decode(prepareTile(buf, channels), ptex, qx, qy);
            const px = d.read(tex, 513, 513);
            d.release(tex);
            d.release(ptex);
            return px;
        };
        const differ = (a, b) => { let n = 0; for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) n++; return n; };
        const out = { diffs: [], control: -1 };
        for (const [i, rec] of recs.entries()) {
            const buf = bytes(rec.buf), parent = bytes(rec.parent), ref = bytes(rec.out);
            out.diffs.push(differ(decode(buf, parent, rec.qx, rec.qy), ref));
            if (i === 0) {
                buf[2] ^= 1;     // quantizer step 0, still 1..4095
                out.control = differ(decode(buf, parent, rec.qx, rec.qy), ref);
            }
        }
        return out;
    }, { recs, channels });
    check(r.diffs.length === 4 && r.diffs.every((n) => n === 0),
        `${id}: the 4 synthetic layout-D tiles of dct_coefs (escapes, clamps, full and empty blocks) decode in WebGL2 as gv_tile_decode's, bit for bit`,
        `samples that differ, per tile: ${r.diffs.join(', ')}`);
    check(r.control > 0, `${id}: negative control: the first with quantizer step 0 changed differs (${r.control} samples)`);
}

async function run(c) {
    const pg = await newPage(c);
    const t0 = Date.now();
    // 1 and 2: picos, level 0 at 1:1, the image centre (550, 350) in the
    // centre: canvas pixel (i, j) is level-0 pixel (150 + i, 100 + j).
    const r0 = await open(pg, '#image=picos&x=550&y=350&z=0&r=0');
    await installCompare(pg);
    const st = await pg.evaluate(() => window.gigaview.viewer.stats);
    check(st.kind === 'webgl2', `the viewer decodes on the GPU with WebGL2: ${st.renderer}`, `backend ${st.kind}`);
    note(`first complete view ${st.firstCompleteMs.toFixed(0)} ms after open (page load to complete ${Date.now() - t0} ms); ` +
        `${st.tilesFetched} tiles in ${st.batches} batches, ${st.bytes} bytes; tiles prepared in ${st.fetchMode}`);
    check(r0.complete && r0.level === 0 && r0.t === 0, 'picos opens complete at level 0', JSON.stringify(r0));
    // Every decode starts from the root (the 1:1 matches show it exact):
    // it comes in one request, as the store's lossless WebP.
    const roots = await pg.evaluate(() => [window.gigaview.viewer.image.root.via,
        performance.getEntriesByType('resource').map((e) => e.name).filter((u) => /\/root(\?|$)/.test(u))]);
    check(roots[0] === 'webp' && roots[1].length === 1 && roots[1][0].endsWith('/v1/images/picos/root?format=webp'),
        "the root came as the store's lossless WebP, in one request (not as PNG, not raw)", JSON.stringify(roots));
    await checkRegion(pg, 'picos level 0 1:1', 0, 150, 100, W, H, 0, 0);
    await shot(pg, 'picos-level0');
    // Level 1 (550 x 350) is smaller than the canvas: it sits at (125, 75).
    await setView(pg, { cx: 550, cy: 350, zoom: 1, rot: 0 });
    await settle(pg);
    await checkRegion(pg, 'picos level 1 1:1, smaller than the canvas', 1, 0, 0, 550, 350, 125, 75, false);
    await checkTiles(pg, 'picos');

    lap('open picos, 1:1 views, tiles');
    // Input on picos, from level 0 at 1:1 again.
    await setView(pg, { cx: 550, cy: 350, zoom: 0, rot: 0 });
    await settle(pg);
    await pg.mouse.move(400, 250);
    await pg.mouse.down();
    await pg.mouse.move(350, 220, { steps: 4 });
    await pg.mouse.move(300, 190, { steps: 4 });
    await pg.mouse.up();
    await settle(pg);
    let v = await view(pg);
    check(near(v.cx, 650) && near(v.cy, 410) && v.zoom === 0 && v.rot === 0,
        'a mouse drag by (-100, -60) pans the centre to (650, 410)', fmtv(v));
    await checkRegion(pg, 'after the drag, 1:1', 0, 250, 160, W, H, 0, 0, false);

    await pg.keyboard.press('+');
    await settle(pg);
    v = await view(pg);
    check(near(v.cx, 650) && near(v.cy, 410) && near(v.zoom, -0.5) && v.rot === 0,
        '"+" zooms in by half a level about the centre', fmtv(v));
    await checkNative(pg, 'magnified');
    await pg.keyboard.press(']');
    await settle(pg);
    v = await view(pg);
    check(near(v.cx, 650) && near(v.cy, 410) && near(v.zoom, -0.5) && near(v.rot, 15),
        '"]" rotates by 15 degrees clockwise', fmtv(v));
    await checkNative(pg, 'rotated');
    await pg.keyboard.press('-');
    await pg.keyboard.press('-');
    await pg.keyboard.press('-');
    await settle(pg);
    v = await view(pg);
    check(near(v.zoom, 1), 'three "-" zoom out to level 1', fmtv(v));
    await setView(pg, { cx: 600, cy: 380, zoom: 0.5, rot: -30 });
    await settle(pg);
    await checkNative(pg, 'two levels blended at zoom 0.5');

    lap('drag, keys, native renders');
    // Wheel about the cursor: the image point under (200, 150) stays.
    const before = await pg.evaluate(() => {
        const g = window.gigaview.viewer;
        return [g.view.zoom, ...window.gigaview.screenToImage(g.view, g.cssW, g.cssH, 200, 150)];
    });
    await pg.mouse.move(200, 150);
    await pg.mouse.wheel(0, -400);
    await settle(pg);
    const after = await pg.evaluate(() => {
        const g = window.gigaview.viewer;
        return [g.view.zoom, ...window.gigaview.screenToImage(g.view, g.cssW, g.cssH, 200, 150)];
    });
    check(near(after[0], before[0] - 1, 1e-9) && near(after[1], before[1], 1e-6) && near(after[2], before[2], 1e-6),
        `the wheel zooms in one level about the cursor (image point ${before[1].toFixed(2)},${before[2].toFixed(2)} stays under it)`,
        `before zoom ${before[0]} at ${before[1]},${before[2]}; after zoom ${after[0]} at ${after[1]},${after[2]}`);

    // Two fingers through the DevTools protocol: spread from 100 to 200
    // pixels apart while turning by 30 degrees about (400, 250).
    await setView(pg, { cx: 550, cy: 350, zoom: 0, rot: 0 });
    await settle(pg);
    const cdp = await c.newCDPSession(pg);
    await cdp.send('Emulation.setTouchEmulationEnabled', { enabled: true, maxTouchPoints: 5 });
    const fingers = (d, a) => {
        const r = a * Math.PI / 180, dx = Math.cos(r) * d / 2, dy = Math.sin(r) * d / 2;
        return [{ x: 400 - dx, y: 250 - dy, id: 0 }, { x: 400 + dx, y: 250 + dy, id: 1 }];
    };
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchStart', touchPoints: fingers(100, 0) });
    for (let i = 1; i <= 6; i++)
        await cdp.send('Input.dispatchTouchEvent', { type: 'touchMove', touchPoints: fingers(100 + 100 * i / 6, 30 * i / 6) });
    await cdp.send('Input.dispatchTouchEvent', { type: 'touchEnd', touchPoints: [] });
    await settle(pg);
    v = await view(pg);
    // Touch coordinates are rounded to CSS pixels on the way: allow for it.
    check(near(v.zoom, -1, 0.02) && near(v.rot, 30, 0.6) && near(v.cx, 550, 1) && near(v.cy, 350, 1),
        'a two-finger pinch to twice the distance, turning 30 degrees, zooms in one level and rotates by 30 about the fingers',
        fmtv(v));
    await cdp.send('Emulation.setTouchEmulationEnabled', { enabled: false });

    // A gamepad (Gamepad API, scripted): left stick right for a while.
    await setView(pg, { cx: 550, cy: 350, zoom: 0, rot: 0 });
    await settle(pg);
    await pg.evaluate(() => {
        const pad = { id: 'scripted', index: 0, connected: true, mapping: 'standard', timestamp: 0,
            axes: [0, 0, 0, 0], buttons: Array.from({ length: 17 }, () => ({ pressed: false, touched: false, value: 0 })) };
        window.gvt.pad = pad;
        navigator.getGamepads = () => [pad];
        window.dispatchEvent(new Event('gamepadconnected'));
        pad.axes[0] = 1;
    });
    // Held until the view has moved past the check's mark: a fixed time
    // would be fewer frames on a busy machine.
    await pg.waitForFunction(() => window.gigaview.viewer.view.cx > 560).catch(() => {});
    await pg.evaluate(() => { window.gvt.pad.axes[0] = 0; });
    await settle(pg);
    v = await view(pg);
    check(v.cx > 560 && near(v.cy, 350) && v.zoom === 0, 'the gamepad left stick pans the view right', fmtv(v));
    await pg.evaluate(() => { window.gvt.pad.connected = false; navigator.getGamepads = () => []; window.dispatchEvent(new Event('gamepaddisconnected')); });

    await pg.keyboard.press('0');
    await settle(pg);
    v = await view(pg);
    const home = await pg.evaluate(() => window.gigaview.viewer.home());
    check(near(v.cx, home.cx) && near(v.cy, home.cy) && near(v.zoom, home.zoom) && v.rot === 0,
        '"0" returns to the whole image', `${fmtv(v)}; home ${fmtv(home)}`);
    await pg.keyboard.press('ArrowRight');
    await settle(pg);
    v = await view(pg);
    const step = 0.2 * W * 2 ** home.zoom;
    check(near(v.cx, home.cx + step) && near(v.cy, home.cy) && near(v.zoom, home.zoom),
        `the right arrow pans by a fifth of the view (${step.toFixed(2)} image pixels)`, fmtv(v));

    lap('wheel, touch, gamepad, reset');
    // 5: the hash round trip.
    await setView(pg, { cx: 612.25, cy: 377.5, zoom: 0.75, rot: 30 });
    await settle(pg);
    await pg.waitForFunction(() => location.hash.includes('z=0.75'), null, { timeout: PATIENCE_MS }).catch(() => {});
    const url = pg.url();
    const digest = () => {
        // FNV-1a over the picture and a count of its non-black pixels.
        const a = window.gigaview.viewer.snapshot();
        let h = 0x811c9dc5, lit = 0;
        for (let i = 0; i < a.length; i++) {
            h = Math.imul(h ^ a[i], 16777619) >>> 0;
            if ((i & 3) === 0 && (a[i] || a[i + 1] || a[i + 2])) lit++;
        }
        return `${h.toString(16)}/${lit}`;
    };
    const pix1 = await pg.evaluate(digest);
    const pg2 = await newPage(c);
    await open(pg2, url.slice(base.length + 1));
    const v2 = await view(pg2);
    const pix2 = await pg2.evaluate(digest);
    check(url.includes('#image=picos&x=612.25&y=377.5&z=0.75&r=30') && near(v2.cx, 612.25) && near(v2.cy, 377.5) &&
        near(v2.zoom, 0.75) && near(v2.rot, 30) && pix1 === pix2,
        `the URL hash round trip (${url.slice(base.length)}) reopens the same view with the same pixels (digest/lit pixels ${pix1})`,
        `url ${url}; reopened: ${fmtv(v2)}; picture digest ${pix1} then ${pix2}`);
    await pg2.close();

    lap('hash round trip');
    // synth: three tiled levels, both tile layouts.
    await open(pg, '#image=synth&x=1500&y=1000&z=1&r=0');
    await installCompare(pg);
    await checkRegion(pg, 'synth level 1 1:1', 1, 350, 250, W, H, 0, 0);
    await setView(pg, { cx: 1500, cy: 1030, zoom: 0, rot: 0 });
    await settle(pg);
    await checkRegion(pg, 'synth level 0 1:1', 0, 1100, 780, W, H, 0, 0);
    const ts = await checkTiles(pg, 'synth');
    check(ts.entropy > 0 && ts.fixed > 0, `both tile layouts were decoded (${ts.entropy} entropy-coded, ${ts.fixed} fixed)`);
    // The prefetch circle (thesis section 7.5) fills in around the view
    // once the view itself is complete.
    await pg.waitForFunction(() => window.gigaview.viewer.stats.prefetched > 0, null, { timeout: PATIENCE_MS }).catch(() => {});
    const s2 = await pg.evaluate(() => window.gigaview.viewer.stats);
    check(s2.prefetched > 0, `tiles around the view are prefetched once it is complete (${s2.prefetched} so far)`);
    note(`synth: ${s2.decoded} tiles decoded, ${s2.resident} textures resident (${(s2.textureBytes / 1048576).toFixed(1)} MiB), ${s2.evicted} evicted`);

    lap('synth 1:1 views, tiles, prefetch');
    await checkDctStores(c);
    lap('layout D stores');
    // A 16 MiB texture cache (15 tiles) on a tour of synth's 24 level-0
    // tiles: least recently used tiles go, the budget holds, and coming
    // back gives the same exact picture.
    await open(pg, '#image=synth&x=1500&y=1030&z=0&r=0', '?cache=16');
    await installCompare(pg);
    const budget = 16 * 1048576;
    let over = 0;
    for (const [x, y] of [[400, 250], [2600, 250], [2600, 1750], [400, 1750], [1500, 1030]]) {
        await setView(pg, { cx: x, cy: y, zoom: 0, rot: 0 });
        await settle(pg);
        const b = await pg.evaluate(() => window.gigaview.viewer.stats.textureBytes);
        if (b > budget) over++;
    }
    const s3 = await pg.evaluate(() => window.gigaview.viewer.stats);
    check(s3.evicted > 0 && over === 0,
        `with cache=16 MiB a tour of level 0 evicts least recently used tiles (${s3.evicted} evicted, ${s3.decoded} decodes; never over 16 MiB once a view is complete, ${(s3.textureBytes / 1048576).toFixed(1)} MiB at the end)`,
        `evicted ${s3.evicted}, ${over} views over the budget`);
    await checkRegion(pg, 'synth level 0 1:1 after evictions', 0, 1100, 780, W, H, 0, 0, false);
    await checkTiles(pg, 'synth after the eviction tour');
    await checkPrefetchEviction(pg);

    lap('eviction tour');
    // While tiles are on their way, their ancestors stand in, upsampled:
    // batches held back until the first picture is read, which has no
    // black hole and shows the loading indicator.
    const pg5 = await newPage(c);
    let releaseBatches;
    const batchesHeld = new Promise((ok) => { releaseBatches = ok; });
    await pg5.route(/\/v1\/images\/picos\/batch/, async (route) => {
        await batchesHeld;
        await route.continue().catch(() => {});
    });
    await pg5.goto(`${base}/#image=picos&x=550&y=350&z=0&r=0`);
    await pg5.evaluate(() => window.gigaview.ready);
    await pg5.waitForFunction(() => window.gigaview.viewer.lastResult);
    const early = await pg5.evaluate(() => {
        const v = window.gigaview.viewer, a = v.snapshot(), r = v.lastResult;
        let black = 0;
        for (let i = 0; i < a.length; i += 4)
            if (!a[i] && !a[i + 1] && !a[i + 2]) black++;
        window.gvEarly = a;
        return { black, complete: r.complete, loading: !document.getElementById('loading').hidden };
    });
    releaseBatches();
    await settle(pg5);
    const mad = await pg5.evaluate(() => {
        const late = window.gigaview.viewer.snapshot(), early = window.gvEarly;
        let sad = 0;
        for (let i = 0; i < late.length; i++) if (i % 4 !== 3) sad += Math.abs(late[i] - early[i]);
        return sad / (late.length * 3 / 4);
    });
    check(!early.complete && early.black === 0 && early.loading && mad > 0 && mad < 12,
        `while its tiles load, the view shows the root upsampled: no black pixel, the loading indicator on, MAD ${mad.toFixed(2)} from the final picture`,
        `complete ${early.complete}, black pixels ${early.black}, loading indicator ${early.loading}, MAD to the final picture ${mad.toFixed(2)}`);
    await pg5.close();

    lap('slow batches');
    // 6: without WebGL2.
    const pg3 = await newPage(c);
    const r3 = await open(pg3, '#image=picos&x=550&y=350&z=0&r=0', '?renderer=region');
    await installCompare(pg3);
    check((await pg3.evaluate(() => window.gigaview.viewer.stats.kind)) === 'region' && r3.complete,
        'with renderer=region the viewer draws server-decoded regions');
    await checkRegion(pg3, 'region fallback, level 0 1:1', 0, 150, 100, W, H, 0, 0, false);
    await pg3.close();

    lap('region fallback');
    // 7: the list, served in the page.
    const pg4 = await newPage(c);
    await pg4.goto(`${base}/`);
    await pg4.evaluate(() => window.gigaview.ready);
    const list = await pg4.evaluate(() => [...document.querySelectorAll('#image-list li > a:first-child')].map((a) => a.textContent));
    check(list.includes('picos') && list.includes('synth') && await pg4.isVisible('#images'),
        `without an image in the hash the page lists the images (${list.join(', ')})`);
    await pg4.click('#image-list a[href="#image=picos"]');
    await pg4.waitForFunction(() => window.gigaview.viewer.image && window.gigaview.viewer.image.id === 'picos');
    await settle(pg4);
    check(!(await pg4.isVisible('#images')), 'clicking an entry opens the image');
    await pg4.close();

    lap('list');
    if (opt.filters === '1')
        await filters(c);
    const left = expectedErrors.map((x) => x.max);
    const unexpected = consoleErrors.filter((e) => {
        const i = expectedErrors.findIndex((x, j) => left[j] > 0 && x.re.test(e));
        if (i < 0)
            return true;
        left[i]--;
        return false;
    });
    check(unexpected.length === 0, `nothing was logged to the console as an error${consoleErrors.length ?
        ` (but the ${consoleErrors.length} the checks provoke: ${consoleErrors.join('; ')})` : ''}`, ...unexpected.slice(0, 10));
    note(`browser checks took ${Date.now() - t0} ms`);
}

// ------------------------------------------------------------ filters

// The canvas against the original image with a filter result pasted in:
// view of level `k` at 1:1 showing level pixels (x0, y0) at the canvas
// origin; the ROI (canvas rectangle roi) must show the server's filter
// endpoint for `body`, the rest the region endpoint.  Exact.
async function checkFiltered(pg, label, k, x0, y0, roi, body) {
    const r = await pg.evaluate(async ({ k, x0, y0, roi, body, W, H }) => {
        const v = window.gigaview.viewer;
        const a = v.snapshot();
        const orig = await window.gvt.png(`${v.image.url}/region?level=${k}&x=${x0}&y=${y0}&w=${W}&h=${H}&format=png`);
        const resp = await fetch(`${v.image.url}/filter`, { method: 'POST', headers: { 'Content-Type': 'application/json' },
            body: JSON.stringify(body) });
        if (!resp.ok) return { error: `filter endpoint: HTTP ${resp.status} ${await resp.text()}` };
        const blob = await resp.blob();
        const bm = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
        const cv = new OffscreenCanvas(bm.width, bm.height), g = cv.getContext('2d');
        g.drawImage(bm, 0, 0);
        const f = g.getImageData(0, 0, bm.width, bm.height).data;
        const ref = new Uint8ClampedArray(orig.px);
        for (let y = 0; y < roi[3]; y++)
            for (let x = 0; x < roi[2]; x++)
                for (let c = 0; c < 4; c++)
                    ref[4 * ((roi[1] + y) * W + roi[0] + x) + c] = f[4 * (y * bm.width + x) + c];
        const same = window.gvt.diff(a, W, ref, W, 4, 0, 0, W, H);
        const unfiltered = window.gvt.diff(a, W, orig.px, W, 4, roi[0], roi[1], roi[2], roi[3]);
        return { same, unfiltered, fw: bm.width, fh: bm.height };
    }, { k, x0, y0, roi, body, W, H });
    if (r.error) {
        fail(`${label}: the filter endpoint answers`, r.error);
        return null;
    }
    check(r.fw === roi[2] && r.fh === roi[3] && r.same.same === r.same.n && !within(r.unfiltered),
        `${label}: the ROI shows the filter endpoint's result bit for bit and the original outside (${fmtd(r.same)}; ROI against the unfiltered image: MAD ${r.unfiltered.mad.map((x) => x.toFixed(1)).join('/')})`,
        `${fmtd(r.same)}; result ${r.fw}x${r.fh} for an ROI of ${roi[2]}x${roi[3]}; unfiltered: ${fmtd(r.unfiltered)}`);
    return r;
}

const idle = (pg) => pg.evaluate(() => window.gigaview.runner.idle());

// Choose a graph in the panel and wait for its result.
async function selectGraph(pg, id) {
    await pg.selectOption('#f-graph', id);
    await pg.waitForFunction((id) => window.gigaview.panel.id === id && window.gigaview.panel.plan, id);
    await idle(pg);
}

async function filters(c) {
    const pg = await newPage(c);
    const filterReqs = [];
    pg.on('request', (r) => { if (r.url().endsWith('/filter') && r.method() === 'POST') filterReqs.push(r.postDataJSON()); });
    const aborted = [];
    pg.on('requestfailed', (r) => { if (r.url().endsWith('/filter')) aborted.push(r.failure() && r.failure().errorText); });
    // F1: ROI and filter from the hash.  Level 0 at 1:1 with canvas pixel
    // (i, j) = level pixel (150 + i, 100 + j); the ROI is the canvas
    // rectangle (200, 150, 400, 200) = level region (350, 250, 400, 200).
    await open(pg, '#image=picos&x=550&y=350&z=0&r=0&roi=-200,-100,400,200&filter=negate');
    await installCompare(pg);
    await idle(pg);
    check(await pg.isVisible('#filters') && await pg.isVisible('#roi-box'), 'a link with a filter and an ROI opens the filter panel and shows the ROI');
    check(filterReqs.length >= 1 && JSON.stringify(filterReqs.at(-1).region) === '[350,250,400,200]' && filterReqs.at(-1).level === 0,
        `the viewer asks for the ROI's level region (${JSON.stringify(filterReqs.at(-1))})`);
    await checkFiltered(pg, 'negate from the link', 0, 150, 100, [200, 150, 400, 200],
        { filter: 'negate', level: 0, region: [350, 250, 400, 200] });

    lap('filters: link');
    // F2: Shift + drag selects a new ROI.
    await pg.keyboard.down('Shift');
    await pg.mouse.move(100, 80);
    await pg.mouse.down();
    await pg.mouse.move(200, 150, { steps: 3 });
    await pg.mouse.move(300, 230, { steps: 3 });
    await pg.mouse.up();
    await pg.keyboard.up('Shift');
    await idle(pg);
    let v = await view(pg);
    const roi = await pg.evaluate(() => window.gigaview.viewer.extra.roi);
    check(JSON.stringify(roi) === '[-300,-170,200,150]' && near(v.cx, 550) && near(v.cy, 350),
        `Shift + drag selects the ROI (${JSON.stringify(roi)}, relative to the centre) without moving the view`, fmtv(v));
    await checkFiltered(pg, 'negate in the dragged ROI', 0, 150, 100, [100, 80, 200, 150],
        { filter: 'negate', level: 0, region: [250, 180, 200, 150] });

    lap('filters: drag');
    // F3: a graph with a parameter; its slider, moved five times quickly.
    await selectGraph(pg, 'gamma');
    const slider = await pg.evaluate(() => {
        const i = document.querySelector('#f-params input[data-key="gamma.gamma"]');
        return i ? { min: +i.min, max: +i.max, value: +i.value, label: i.closest('label').textContent } : null;
    });
    check(slider && slider.min === 0.1 && slider.max === 10 && near(slider.value, 0.5),
        `the gamma graph gets one slider named and ranged from its parameter (${JSON.stringify(slider)})`);
    const n0 = filterReqs.length;
    // In one task: however slow the machine, all five land within the
    // debounce (a timer between them could fire late, past it).
    await pg.evaluate(() => {
        const i = document.querySelector('#f-params input[data-key="gamma.gamma"]');
        for (const val of ['1.2', '1.5', '1.8', '2.0', '2.2']) {
            i.value = val;
            i.dispatchEvent(new Event('input'));
        }
    });
    await idle(pg);
    const sent = filterReqs.slice(n0);
    check(sent.length === 1 && Math.abs(sent[0].params.gamma.gamma - 2.2) < 1e-9,
        `five quick slider moves send one request, with the last value (${sent.length} sent: ${sent.map((b) => JSON.stringify(b.params)).join(' ')})`);
    await checkFiltered(pg, 'gamma 2.2 from the slider', 0, 150, 100, [100, 80, 200, 150],
        { filter: 'gamma', params: { gamma: { gamma: 2.2 } }, level: 0, region: [250, 180, 200, 150] });
    await pg.waitForFunction(() => location.hash.includes('p=gamma.gamma%3A2.2'), null, { timeout: PATIENCE_MS }).catch(() => {});
    const h3 = await pg.evaluate(() => location.hash);
    check(h3.includes('filter=gamma') && h3.includes('p=gamma.gamma%3A2.2'), `the hash holds the filter and its parameter (${h3})`);

    lap('filters: sliders');
    // A slower server: a slider move while a request runs aborts it.  The
    // server here holds each filter request until the test opens its
    // gate, so what is in flight when is the test's choice, not a race.
    let openGate = null, gate = null;
    const closeGate = () => { gate = new Promise((ok) => { openGate = ok; }); };
    closeGate();
    await pg.route(/\/filter$/, async (route) => {
        await gate;
        await route.continue().catch(() => {});
    });
    const a0 = aborted.length;
    await pg.evaluate(() => {
        const i = document.querySelector('#f-params input[data-key="gamma.gamma"]');
        i.value = '3';
        i.dispatchEvent(new Event('input'));
    });
    await pg.waitForFunction(() => window.gigaview.runner.inflight > 0, null, { timeout: PATIENCE_MS });
    await pg.evaluate(() => {   // debounced, then in flight: now change it
        const i = document.querySelector('#f-params input[data-key="gamma.gamma"]');
        i.value = '4';
        i.dispatchEvent(new Event('input'));
    });
    // The abort follows the debounce; Chromium may report it only once
    // the held request is let go, so wait a while for it, then open.
    for (const end = Date.now() + PATIENCE_MS; Date.now() < end && aborted.length === a0;)
        await new Promise((ok) => setTimeout(ok, 100));
    openGate();
    await idle(pg);
    check(aborted.length > a0, `a parameter change while a request runs aborts the stale request (${aborted.slice(a0).join(', ')})`);
    await checkFiltered(pg, 'gamma 4 after the aborted request', 0, 150, 100, [100, 80, 200, 150],
        { filter: 'gamma', params: { gamma: { gamma: 4 } }, level: 0, region: [250, 180, 200, 150] });

    lap('filters: abort');
    // Re-run on pan; meanwhile the stale result moves with the image (the
    // new result held at the gate until the picture is taken).
    closeGate();
    await pg.mouse.move(200, 300);     // left of the filter panel
    await pg.mouse.down();
    await pg.mouse.move(150, 300, { steps: 4 });
    await pg.mouse.up();
    await settle(pg);
    const stale = await pg.evaluate(() => {
        window.gvStale = window.gigaview.viewer.snapshot();
        const r = window.gigaview.runner;
        return { inflight: r.inflight + (r.timer ? 1 : 0) };
    });
    openGate();
    await idle(pg);
    await pg.unroute(/\/filter$/);
    v = await view(pg);
    // New view: canvas (i, j) = level (200 + i, 100 + j); the ROI (100, 80,
    // 200, 150) is level (300, 180, 200, 150); the old result covered
    // level (250, 180, 200, 150) = canvas columns 50..249: the ROI's
    // columns 100..249 show it, 250..299 the original.
    const r2 = await checkFiltered(pg, 'gamma 4 after a pan by 50 pixels', 0, 200, 100, [100, 80, 200, 150],
        { filter: 'gamma', params: { gamma: { gamma: 4 } }, level: 0, region: [300, 180, 200, 150] });
    const staleOk = await pg.evaluate(async ({ W }) => {
        const v = window.gigaview.viewer, stale = window.gvStale;
        const fin = v.snapshot();
        const orig = await window.gvt.png(`${v.image.url}/region?level=0&x=200&y=100&w=${W}&h=300&format=png`);
        let oldPart = 0, origPart = 0, n1 = 0, n2 = 0;
        for (let y = 80; y < 230; y++)
            for (let x = 100; x < 300; x++)
                for (let c = 0; c < 3; c++) {
                    const i = 4 * (y * W + x);
                    if (x < 250) { n1++; if (stale[i + c] !== fin[i + c]) oldPart++; } else { n2++; if (stale[i + c] !== orig.px[i + c]) origPart++; }
                }
        return { oldPart, origPart, n1, n2 };
    }, { W });
    check(stale.inflight > 0 && staleOk.oldPart === 0 && staleOk.origPart === 0 && near(v.cx, 600),
        'after a pan, while the new result is on its way, the old one stays in the ROI where the image moved it (exactly) and the original shows where it does not reach',
        `request pending ${stale.inflight}; samples differing: old result part ${staleOk.oldPart}/${staleOk.n1}, original part ${staleOk.origPart}/${staleOk.n2}; ${fmtv(v)}`);

    lap('filters: pan');
    // F4: the graph's modules in execution order.
    await selectGraph(pg, 'detail-enhance');
    const plan = await pg.evaluate(async () => (await (await fetch('v1/filters/detail-enhance')).json()).plan.modules.map((m) => m.id));
    const shown = await pg.evaluate(() => [...document.querySelectorAll('#f-modules li')].map((li) => li.textContent));
    check(shown.length === plan.length && shown.every((t, i) => t.startsWith(plan[i])) && /enhance.*← source, blur/.test(shown.at(-1)),
        `the graph view lists the modules in execution order with their inputs (${shown.join(' | ')})`);

    // F5: a GLSL compile error is shown at its line.
    await selectGraph(pg, 'gamma');
    const body = await pg.inputValue('#f-glsl');
    const broken = body.split('\n');
    broken[1] = broken[1].replace(/;\s*$/, ' +;');
    await pg.fill('#f-glsl', broken.join('\n'));
    // The one console error this may log: Chrome's line for the 400 itself.
    expectedErrors.push({ re: /^Failed to load resource: the server responded with a status of 400 \(Bad Request\) \(http:[^ ]*\/v1\/images\/picos\/filter\)$/, max: 1 });
    await pg.click('#f-run');
    await idle(pg);
    const err = await pg.evaluate(() => ({
        text: document.getElementById('f-error').textContent, shown: !document.getElementById('f-error').hidden,
        bad: [...document.querySelectorAll('#f-gutter .bad')].map((d) => d.textContent),
        caretLine: (() => { const t = document.getElementById('f-glsl'); return t.value.slice(0, t.selectionStart).split('\n').length; })(),
    }));
    check(err.shown && /line 2/.test(err.text) && err.bad.join() === '2' && err.caretLine === 2,
        `a GLSL compile error is shown at its line (gutter line ${err.bad.join()}, caret on line ${err.caretLine}: "${err.text}")`);

    lap('filters: graph view, compile error');
    // F6: fix it, run it inline, save it with the token.
    const fixed = body.split('\n');
    fixed[1] = 'return vec4(pow(v.rgb, vec3($(1))) * 0.5, v.a);';
    await pg.fill('#f-glsl', fixed.join('\n'));
    await pg.click('#f-run');
    await idle(pg);
    const ok2 = await pg.evaluate(() => document.getElementById('f-error').hidden);
    check(ok2, 'the corrected body compiles and runs inline');
    await pg.fill('#f-token', opt.token);
    await pg.click('#f-save');
    await pg.waitForFunction(() => window.gigaview.panel.savedId, null, { timeout: PATIENCE_MS }).catch(() => {});
    const saved = await pg.evaluate(() => window.gigaview.panel.savedId);
    const listed = await pg.evaluate(async () => (await (await fetch('v1/filters')).json()).filters.map((f) => f.id));
    await idle(pg);
    if (saved)
        await pg.waitForFunction((id) => location.hash.includes(`filter=${id}`), saved).catch(() => {});
    const hash = await pg.evaluate(() => location.hash);
    check(saved && listed.includes(saved) && hash.includes(`filter=${saved}`),
        `"save" stores the graph on the server (${saved}, listed by GET /v1/filters, in the hash)`, `listed: ${listed.join(', ')}; hash ${hash}`);
    if (saved)
        await checkFiltered(pg, 'the saved graph', 0, 200, 100, [100, 80, 200, 150],
            { filter: saved, params: { gamma: { gamma: 0.5 } }, level: 0, region: [300, 180, 200, 150] });
    lap('filters: save');
    await pg.close();
}

// Negative controls: break the decoder on its way to the browser.
async function sabotaged(c, which) {
    note(`sabotage: ${which}`);
    const pg = await newPage(c);
    if (which === 'shader') {
        await pg.route(`${base}/web/tile_decode.frag.glsl`, async (route) => {
            const r = await route.fetch();
            const src = (await r.text()).replace('return k == 0 ? -3 : (k == 1 ? 29 : (k == 2 ? 111 : -9));',
                'return k == 0 ? -3 : (k == 1 ? 30 : (k == 2 ? 110 : -9));');
            await route.fulfill({ response: r, body: src });
        });
    } else if (which === 'rans') {
        await pg.route(`${base}/web/tilebuf.js`, async (route) => {
            const r = await route.fetch();
            const src = (await r.text()).replace('idx[base + i] = v;', 'idx[base + i] = v ^ 1;');
            await route.fulfill({ response: r, body: src });
        });
        // The workers load tilebuf.js outside the page's routes: prepare
        // tiles on the main thread.
    } else if (which === 'dct') {
        // Layout D's zigzag order transposed (coefficient (v, u) stored at
        // (u, v)), on picosd: every 1:1 view must fail.
        await pg.route(`${base}/web/tile_dct.js`, async (route) => {
            const r = await route.fetch(), orig = await r.text();
            const src = orig.replace('const v = d & 1 ? i : d - i, u = d - v;',
                'const v = d & 1 ? d - i : i, u = d - v;');
            if (src === orig)
                fail('sabotage dct: the zigzag line is not in tile_dct.js');
            await route.fulfill({ response: r, body: src });
        });
    } else if (which === 'matrix') {
        // Layout D's matrix K as the served decode shader carries it
        // (dct_matrix.glsl, expanded by gigaviewd's build): K[1][2] 50 -> 51.
        await pg.route(`${base}/web/tile_decode.frag.glsl`, async (route) => {
            const r = await route.fetch(), orig = await r.text();
            const src = orig.replace('    89,  75,  50,  18,', '    89,  75,  51,  18,');
            if (src === orig)
                fail('sabotage matrix: K is not in the served tile_decode.frag.glsl');
            await route.fulfill({ response: r, body: src });
        });
    } else if (which === 'root') {
        // The root as decoded by loadRoot, every 97th sample's lowest bit
        // flipped: every decode starts from it.
        await pg.route(`${base}/web/viewer.js`, async (route) => {
            const r = await route.fetch();
            const src = (await r.text()).replace('px[i * c + k] = rgba[4 * i + k];',
                'px[i * c + k] = rgba[4 * i + k] ^ ((i * c + k) % 97 === 0 ? 1 : 0);');
            await route.fulfill({ response: r, body: src });
        });
    } else {
        fail(`unknown sabotage ${which}`);
        await pg.close();
        return;
    }
    const id = which === 'dct' || which === 'matrix' ? 'picosd' : 'picos';
    await open(pg, `#image=${id}&x=550&y=350&z=0&r=0`, which === 'rans' || which === 'dct' ? '?workers=0' : '');
    await installCompare(pg);
    check((await pg.evaluate(() => window.gigaview.viewer.stats.kind)) === 'webgl2', 'the viewer opened with WebGL2');
    await checkRegion(pg, `${id} level 0 1:1`, 0, 150, 100, W, H, 0, 0, false);
    await pg.close();
}

// --only eviction: the eviction checks alone (quicker to iterate on).
async function evictionOnly(c) {
    const pg = await newPage(c);
    await open(pg, '#image=synth&x=1500&y=1030&z=0&r=0', '?cache=16');
    await installCompare(pg);
    await checkPrefetchEviction(pg);
    await pg.close();
}

// ------------------------------------------------------------ main

const profile = join(scratch, 'profile');
let ctx;
try {
    ctx = await launchChromium(profile, opt.chromium, W, H);
    if (opt.sabotage) {
        // One failing to run (a timeout) leaves the others to run.
        for (const which of opt.sabotage.split(',')) {
            try {
                await sabotaged(ctx, which);
            } catch (e) {
                fail(`sabotage ${which} ran`, String(e && e.stack || e));
            }
        }
    }
    else if (opt.only === 'eviction')
        await evictionOnly(ctx);
    else if (opt.only === 'dct')
        await checkDctStores(ctx);
    else
        await run(ctx);
} catch (e) {
    fail('browser run', String(e && e.stack || e));
} finally {
    if (ctx) await ctx.close().catch(() => {});
    rmSync(scratch, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
