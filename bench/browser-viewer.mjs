// browser-viewer.mjs - the browser viewer's speed, in headless Chromium
// (playwright-core from tests/browser/node_modules), against a running
// gigaviewd.  Run by bench/browser-viewer.sh, which makes the stores and
// starts the daemon; it prints one "RESULT" line per figure.
//
//   node browser-viewer.mjs --base URL --images ID,ID... [--reps N]
//        [--size WxH] [--chromium PATH] [--gpu swiftshader|host]
//
// For every image:
//   - time to the first complete view, twice: the whole image (the
//     viewer's home view) and a 1:1 view of level 0 at the image centre.
//     A fresh browser profile each time (no HTTP cache), over loopback;
//     measured from the navigation start (performance.timeOrigin) to the
//     first frame in which every tile of the view is drawn from its own
//     decoded texture (viewer.timing).  Median of --reps runs, with the
//     tiles, batches and bytes fetched and the tiles decoded by then.
//   - tiles decoded per second: every tile of the image, fetched in
//     batches and prepared on the main thread (tile check, rANS indices),
//     then decoded on the GPU level by level, each from its parent, with
//     the viewer's own modules (gpu_decode.js, the shared decode shader);
//     the GPU time ends with a one-pixel read-back (a full pipeline
//     flush).  Reported separately: GPU decoding, CPU preparation, and the
//     two together, in tiles/s and in megapixels of level per second
//     (513 x 513 pixels a tile).  Best of --reps.
// The renderer string says what did the GPU work: SwiftShader is Chrome's
// CPU implementation of Vulkan (with --gpu swiftshader, the default, as
// in tests/browser_viewer.sh).
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium, chromiumArgs, parseOptions } from './browser_lib.mjs';

const opt = parseOptions({ base: '', images: '', reps: '3', size: '1280x800', chromium: '/usr/bin/chromium', gpu: 'swiftshader' },
    'node browser-viewer.mjs --base URL --images ID,... [--reps N] [--size WxH] [--chromium PATH] [--gpu swiftshader|host]');
const base = opt.base.replace(/\/+$/, '');
const [W, H] = opt.size.split('x').map(Number);
const reps = Math.max(1, +opt.reps);
const args = chromiumArgs(opt.gpu);

const median = (a) => [...a].sort((x, y) => x - y)[Math.floor((a.length - 1) / 2)];

async function browser() {
    const profile = mkdtempSync(join(tmpdir(), 'gv-bench-'));
    const ctx = await chromium.launchPersistentContext(profile, {
        executablePath: opt.chromium, headless: true, viewport: { width: W, height: H },
        deviceScaleFactor: 1, timeout: 60000, args,
    });
    return { ctx, close: async () => { await ctx.close(); rmSync(profile, { recursive: true, force: true }); } };
}

async function firstView(id, hash) {
    const b = await browser();
    try {
        const pg = b.ctx.pages()[0] || await b.ctx.newPage();
        pg.setDefaultTimeout(300000);
        const errors = [];
        pg.on('pageerror', (e) => errors.push(e.message));
        await pg.goto(`${base}/${hash}`);
        await pg.evaluate(() => window.gigaview.ready);
        await pg.evaluate(() => window.gigaview.viewer.settled());
        const r = await pg.evaluate(() => {
            const s = window.gigaview.viewer.stats;
            const f = s.atFirstComplete;
            return { ms: s.openStart + s.firstCompleteMs, open: s.openStart, tiles: f.tiles,
                batches: f.batches, bytes: f.bytes, decoded: f.decoded, renderer: s.renderer, kind: s.kind,
                level: window.gigaview.viewer.lastResult.level };
        });
        if (errors.length)
            r.errors = errors;
        return r;
    } finally {
        await b.close();
    }
}

// In the page: fetch, prepare and decode every tile of image `id`.
async function decodeAll(id) {
    const b = await browser();
    try {
        const pg = b.ctx.pages()[0] || await b.ctx.newPage();
        pg.setDefaultTimeout(600000);
        await pg.goto(`${base}/`);
        await pg.evaluate(() => window.gigaview.ready);
        return await pg.evaluate(async ({ id, reps }) => {
            const { fetchPrepared } = await import('./web/batch.js');
            const { GpuDecoder } = await import('./web/gpu_decode.js');
            const { fetchText } = await import('./web/gl_util.js');
            const { rendererString } = await import('./web/gl_backend.js');
            const url = new URL(`v1/images/${id}`, document.baseURI).href;
            const info = await (await fetch(url)).json();
            const root = new Uint8Array(await (await fetch(`${url}/root?format=raw`)).arrayBuffer());
            const canvas = document.createElement('canvas');
            canvas.width = canvas.height = 1;
            const gl = canvas.getContext('webgl2');
            gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
            const dec = new GpuDecoder(gl, info.channels, await fetchText('fullscreen.vert.glsl'),
                await fetchText('tile_decode.frag.glsl'));
            // Fetch and prepare every tile, coarse levels first.
            const prepared = new Map();
            let fetchMs = 0, prepMs = 0, bytes = 0, n = 0, entropy = 0;
            for (let k = info.levels_tiled - 1; k >= 0; k--) {
                const L = info.levels[k], all = [];
                for (let ty = 0; ty < L.tiles_y; ty++)
                    for (let tx = 0; tx < L.tiles_x; tx++)
                        all.push([k, tx, ty]);
                for (let i = 0; i < all.length; i += 64) {
                    const r = await fetchPrepared(url, all.slice(i, i + 64), { channels: info.channels, codes: false });
                    fetchMs += r.fetchMs;
                    prepMs += r.prepMs;
                    bytes += r.bytes;
                    for (const t of r.tiles) {
                        prepared.set(`${t.level}/${t.tx}/${t.ty}`, t.prep);
                        n++;
                        if (t.prep.entropy) entropy++;
                    }
                }
            }
            // The root tile: the root clamp-padded to 513 x 513.
            const c = info.channels, rw = info.root.width, rh = info.root.height;
            const padded = new Uint8Array(513 * 513 * c);
            for (let v = 0; v < 513; v++)
                for (let u = 0; u < 513; u++)
                    for (let q = 0; q < c; q++)
                        padded[(v * 513 + u) * c + q] = root[(Math.min(v, rh - 1) * rw + Math.min(u, rw - 1)) * c + q];
            const sync = () => {
                const fb = gl.createFramebuffer(), t = dec.upload(new Uint8Array(c), 1, 1);
                gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
                gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, t, 0);
                gl.readPixels(0, 0, 1, 1, gl.RGBA_INTEGER, gl.UNSIGNED_INT, new Uint32Array(4));
                gl.bindFramebuffer(gl.FRAMEBUFFER, null);
                gl.deleteFramebuffer(fb);
                gl.deleteTexture(t);
            };
            let best = Infinity;
            for (let rep = 0; rep < reps; rep++) {
                const rootTex = dec.upload(padded, 513, 513);
                sync();
                const t0 = performance.now();
                let parents = new Map([['0/0', rootTex]]);
                for (let k = info.levels_tiled - 1; k >= 0; k--) {
                    const L = info.levels[k], made = new Map();
                    for (let ty = 0; ty < L.tiles_y; ty++)
                        for (let tx = 0; tx < L.tiles_x; tx++) {
                            const p = parents.get(`${tx >> 1}/${ty >> 1}`);
                            made.set(`${tx}/${ty}`, dec.decode(prepared.get(`${k}/${tx}/${ty}`), p, tx & 1, ty & 1));
                        }
                    for (const t of parents.values())
                        dec.release(t);
                    parents = made;
                }
                sync();
                best = Math.min(best, performance.now() - t0);
                for (const t of parents.values())
                    dec.release(t);
            }
            return { tiles: n, entropy, bytes, fetchMs, prepMs, gpuMs: best, renderer: rendererString(gl) };
        }, { id, reps });
    } finally {
        await b.close();
    }
}

for (const id of opt.images.split(',')) {
    const info = await (await fetch(`${base}/v1/images/${id}`)).json();
    for (const [name, hash] of [['whole image', `#image=${id}`],
        ['level 0 1:1 at the centre', `#image=${id}&x=${info.width / 2}&y=${info.height / 2}&z=0&r=0`]]) {
        const runs = [];
        for (let i = 0; i < reps; i++)
            runs.push(await firstView(id, hash));
        const m = median(runs.map((r) => r.ms));
        const r = runs.find((x) => x.ms === m);
        console.log(`RESULT first-view ${id} "${name}" ${W}x${H}: median ${m.toFixed(0)} ms from navigation start ` +
            `(runs ${runs.map((x) => x.ms.toFixed(0)).join(', ')}; page ready to open ${r.open.toFixed(0)} ms); ` +
            `level ${r.level}, ${r.tiles} tiles in ${r.batches} batches, ${(r.bytes / 1024).toFixed(0)} KiB, ${r.decoded} decoded; ` +
            `${r.kind} on ${r.renderer}${r.errors ? `; page errors: ${r.errors.join('; ')}` : ''}`);
    }
    const d = await decodeAll(id);
    const mp = 513 * 513 / 1e6;
    console.log(`RESULT decode ${id}: ${d.tiles} tiles (${d.entropy} entropy-coded), ${(d.bytes / 1048576).toFixed(2)} MiB in batches; ` +
        `GPU ${(d.tiles / d.gpuMs * 1000).toFixed(1)} tiles/s (${(d.tiles * mp / d.gpuMs * 1000).toFixed(1)} MP/s, ${(d.gpuMs / d.tiles).toFixed(2)} ms/tile, best of ${reps}); ` +
        `CPU preparation (check + rANS, main thread) ${(d.tiles / d.prepMs * 1000).toFixed(1)} tiles/s (${(d.prepMs / d.tiles).toFixed(2)} ms/tile); ` +
        `both ${(d.tiles / (d.gpuMs + d.prepMs) * 1000).toFixed(1)} tiles/s; fetch ${(d.fetchMs).toFixed(0)} ms; renderer ${d.renderer}`);
}
