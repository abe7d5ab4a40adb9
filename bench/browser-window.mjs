// browser-window.mjs - how fast the browser viewer redraws when a sample
// store's display window or colours change, in headless Chromium
// (playwright-core from tests/browser/node_modules), against a running
// gigaviewd.  Run by bench/browser-window.sh, which makes the stores and
// starts the daemon; it prints one "RESULT" line per figure.
//
//   node browser-window.mjs --base URL --images ID,... [--changes N]
//        [--size WxH] [--chromium PATH] [--gpu swiftshader|host]
//
// For every image, twice: with WebGL2 (the viewer decodes the tiles and
// applies the window and colours in its display shader, looks.js) and
// with renderer=region (the anchor: the server applies them to a region,
// fetched again for each change, as a viewer without GPU windowing does).
// The view is the whole image, then a 1:1 view of level 0 at its centre;
// once it is complete, N windows (black, white and gamma drawn from a
// fixed sequence) and then N colour sets are applied one after another;
// each is timed from the call (viewer.setWindow / setColours) to the
// first complete frame that shows it (viewer.settled()), and the requests
// the page made meanwhile are counted.  Median and 90th percentile in ms.
// With WebGL2 also the draw alone: one frame of the view drawn again and
// flushed by a one-pixel read-back, median of 10.  An 8-bit image store
// ("picos") runs the same way, its window on 8-bit samples, so that a
// sample store's frame can be set beside an image store's on the same
// GPU.
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium, chromiumArgs, parseOptions } from './browser_lib.mjs';

const opt = parseOptions({ base: '', images: '', changes: '20', size: '1280x800', chromium: '/usr/bin/chromium', gpu: 'swiftshader' },
    'node browser-window.mjs --base URL --images ID,... [--changes N] [--size WxH] [--chromium PATH] [--gpu swiftshader|host]');
const base = opt.base.replace(/\/+$/, '');
const [W, H] = opt.size.split('x').map(Number);
const N = Math.max(3, +opt.changes);
const args = chromiumArgs(opt.gpu);

const pct = (a, p) => [...a].sort((x, y) => x - y)[Math.min(a.length - 1, Math.floor(p * (a.length - 1) + 0.5))];

// N windows on codes lo..hi and N colour sets for c channels, the same
// for every run.
function sequence(lo, hi, c) {
    const wins = [], cols = [];
    let s = 12345;
    const rnd = () => (s = (s * 1103515245 + 12345) % 2147483648) / 2147483648;
    for (let i = 0; i < N; i++) {
        const b = Math.floor(lo + (hi - lo) * 0.3 * rnd());
        const w = Math.max(b + 1, Math.floor(hi - (hi - lo) * 0.3 * rnd()));
        wins.push([{ black: b, white: w, gammaMilli: 500 + Math.floor(1500 * rnd()) }]);
        cols.push(Array.from({ length: c }, () => Math.floor(rnd() * 0xffffff).toString(16).padStart(6, '0')).join(';'));
    }
    return { wins, cols };
}

async function run(id, renderer, hash) {
    const profile = mkdtempSync(join(tmpdir(), 'gv-bench-'));
    const ctx = await chromium.launchPersistentContext(profile, {
        executablePath: opt.chromium, headless: true, viewport: { width: W, height: H },
        deviceScaleFactor: 1, timeout: 60000, args,
    });
    try {
        const pg = ctx.pages()[0] || await ctx.newPage();
        pg.setDefaultTimeout(300000);
        const errors = [];
        pg.on('pageerror', (e) => errors.push(e.message));
        let requests = 0;
        pg.on('request', () => requests++);
        await pg.goto(`${base}/?renderer=${renderer}#image=${id}${hash}`);
        await pg.evaluate(() => window.gigaview.ready);
        await pg.waitForFunction((id) => window.gigaview.viewer.image && window.gigaview.viewer.image.id === id, id);
        await pg.evaluate(() => window.gigaview.viewer.settled());
        const info = await pg.evaluate(() => {
            const v = window.gigaview.viewer;
            const s = v.image.info.samples;
            return { c: v.image.info.channels, lo: s ? s.code_min : 0, hi: s ? s.code_max : 255,
                samples: !!s, kind: v.backend.kind, renderer: v.stats.renderer };
        });
        const seq = sequence(info.lo, info.hi, info.c);
        const out = { kind: info.kind, renderer: info.renderer };
        for (const what of ['window', 'colours']) {
            if (what === 'colours' && (info.c < 2 || !info.samples))
                continue;
            const ms = [];
            const r0 = requests;
            for (let i = 0; i < N; i++)
                ms.push(await pg.evaluate(async ([what, w, col]) => {
                    const v = window.gigaview.viewer, t0 = performance.now();
                    if (what === 'window')
                        v.setWindow(w);
                    else
                        v.setColours(col);
                    await v.settled();
                    return performance.now() - t0;
                }, [what, seq.wins[i], seq.cols[i]]));
            out[what] = { median: pct(ms, 0.5), p90: pct(ms, 0.9), requests: requests - r0 };
        }
        if (info.kind === 'webgl2')
            out.draw = await pg.evaluate(() => {
                const v = window.gigaview.viewer, b = v.backend, gl = b.gl, px = new Uint8Array(4), ms = [];
                for (let i = 0; i < 10; i++) {
                    const t0 = performance.now();
                    b.frame(v.deviceView(), v.canvas.width, v.canvas.height, true, null);
                    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
                    ms.push(performance.now() - t0);
                }
                return ms.sort((a, b) => a - b)[4];
            });
        if (errors.length)
            out.errors = errors;
        return out;
    } finally {
        await ctx.close();
        rmSync(profile, { recursive: true, force: true });
    }
}

for (const id of opt.images.split(',').filter(Boolean)) {
    const doc = await (await fetch(`${base}/v1/images/${id}`)).json();
    const centre = `&x=${Math.floor(doc.width / 2)}&y=${Math.floor(doc.height / 2)}&z=0&r=0`;
    for (const [name, hash] of [['whole image', ''], ['1:1 level 0', centre]]) {
        const gpu = await run(id, 'webgl2', hash);
        const reg = await run(id, 'region', hash);
        for (const what of ['window', 'colours']) {
            if (!gpu[what])
                continue;
            const g = gpu[what], r = reg[what];
            console.log(`RESULT ${what} ${id} "${name}" ${W}x${H}: WebGL2 median ${g.median.toFixed(1)} ms ` +
                `(p90 ${g.p90.toFixed(1)}, ${g.requests} requests) | server regions median ${r.median.toFixed(1)} ms ` +
                `(p90 ${r.p90.toFixed(1)}, ${r.requests} requests) | ratio ${(r.median / g.median).toFixed(2)}x faster ` +
                `| ${N} changes; ${gpu.renderer}`);
        }
        console.log(`RESULT draw ${id} "${name}" ${W}x${H}: one frame drawn and flushed, median ${gpu.draw.toFixed(1)} ms`);
        for (const o of [gpu, reg])
            if (o.errors)
                console.log(`# errors (${o.kind}): ${o.errors.slice(0, 3).join(' | ')}`);
    }
}
