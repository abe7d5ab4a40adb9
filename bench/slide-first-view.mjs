// slide-first-view.mjs - how long a pathologist waits for the first
// complete view of a whole-slide image in the browser: the gigaview viewer
// (a store served by gigaviewd) against OpenSeadragon reading a static
// IIIF Image API 3 JPEG pyramid (vips dzsave --layout iiif3, 512-pixel
// tiles, no overlap, at the JPEG quality of equal level-0 PSNR).  Run by
// bench/slide-first-view.sh, which builds both from the same slide and
// starts gigaviewd; it prints "RESULT" lines and a table.
//
//   node slide-first-view.mjs --base URL --id ID --iiif DIR [--reps N]
//        [--size WxH] [--chromium PATH] [--gpu swiftshader|host]
//
// Two views, each opened directly, in a fresh browser profile (no HTTP
// cache), over loopback, at a viewport of --size:
//   whole slide   gigaview: the link #image=ID (its home view, the slide
//                 fitted to the window); OpenSeadragon: its home view
//   1:1 centre    level 0, one slide pixel a screen pixel, at the slide's
//                 centre; gigaview: the link #image=ID&x=..&y=..&z=0;
//                 OpenSeadragon: told that rectangle (fitBounds, at once)
//                 in its `open` handler, before its first update
// Timed from the navigation start (performance.timeOrigin) to:
//   gigaview       the first frame in which every tile of the view is
//                  drawn from its own decoded texture (viewer.timing, as
//                  in bench/browser-viewer.mjs: the viewer as shipped, two
//                  tile workers, prefetching on)
//   OpenSeadragon  the first frame drawn after its TiledImage turned
//                  fully loaded (every tile of the best level for the view
//                  loaded): the 'update-viewport' event that follows
//                  'fully-loaded-change' in the same animation frame
// Both stamps are performance.now() in the page after the frame's draw
// calls were issued.  REPS runs each, alternated (gigaview, then OSD, for
// each view), median.  Bytes: response bodies of the image data (gigaview:
// every /v1/ request: listing, metadata, root, tile batches, workers'
// included; OpenSeadragon: info.json and tiles) whose response had ended
// by the first complete view (Playwright's request timing and sizes);
// the pages and scripts are not counted.  The static IIIF server is a
// small node server in this process, as in bench/browser-bytes.mjs.
import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, normalize, sep } from 'node:path';
import { chromium, chromiumArgs, nodeModules as nm, parseOptions } from './browser_lib.mjs';

const opt = parseOptions({ base: '', id: '', iiif: '', reps: '3', size: '1280x800', chromium: '/usr/bin/chromium', gpu: 'swiftshader' },
    'node slide-first-view.mjs --base URL --id ID --iiif DIR [--reps N] [--size WxH] ' +
            '[--chromium PATH] [--gpu swiftshader|host]');
const base = opt.base.replace(/\/+$/, '');
const [W, H] = opt.size.split('x').map(Number);
const reps = Math.max(1, +opt.reps);
const iiifDir = normalize(opt.iiif) + sep;
const args = chromiumArgs(opt.gpu);

const info = await (await fetch(`${base}/v1/images/${opt.id}`)).json();
const IW = info.width, IH = info.height;
const views = [
    { name: 'whole slide', gv: `#image=${opt.id}`, osd: '' },
    { name: '1:1 centre', gv: `#image=${opt.id}&x=${IW / 2}&y=${IH / 2}&z=0&r=0`, osd: `?x=${IW / 2}&y=${IH / 2}&z=0` },
];

// ------------------------------------------- OpenSeadragon and its tiles
const osdJs = await readFile(join(nm, 'openseadragon', 'build', 'openseadragon', 'openseadragon.min.js'));
// OSD as a slide service would set it up, with its defaults; the stamps
// and the optional initial view are the benchmark's.
const osdPage = `<!doctype html><html><head><meta charset="utf-8"><title>osd first view</title>
<style>html,body{margin:0;background:#000;overflow:hidden}#v{width:100vw;height:100vh}</style>
<script src="/openseadragon.min.js"></script></head><body><div id="v"></div><script>
const q = new URLSearchParams(location.search);
const b = window.bench = { first: null, loadedAt: null, openAt: null, changes: [] };
const viewer = window.osd = OpenSeadragon({ id: 'v', prefixUrl: '/images/', showNavigationControl: false,
  tileSources: '/${opt.id}/info.json' });
viewer.addHandler('open', () => {
  const ti = viewer.world.getItemAt(0);
  if (q.has('z')) {
    const s = 2 ** Number(q.get('z')), w = viewer.container.clientWidth * s, h = viewer.container.clientHeight * s;
    viewer.viewport.fitBounds(ti.imageToViewportRectangle(q.get('x') - w / 2, q.get('y') - h / 2, w, h), true);
  }
  b.openAt = performance.now();
  ti.addHandler('fully-loaded-change', (e) => {
    b.changes.push([Math.round(performance.now()), e.fullyLoaded]);
    if (e.fullyLoaded && b.loadedAt === null)
      b.loadedAt = performance.now();
  });
});
viewer.addHandler('update-viewport', () => {
  if (b.loadedAt !== null && b.first === null)
    b.first = performance.now();
});
</script></body></html>`;
const server = createServer(async (req, res) => {
    const u = decodeURIComponent(req.url.split('?')[0]);
    try {
        if (u === '/') {
            res.writeHead(200, { 'Content-Type': 'text/html' });
            res.end(osdPage);
            return;
        }
        if (u === '/openseadragon.min.js') {
            res.writeHead(200, { 'Content-Type': 'text/javascript' });
            res.end(osdJs);
            return;
        }
        const f = normalize(join(iiifDir, u.slice(`/${opt.id}/`.length)));
        if (!u.startsWith(`/${opt.id}/`) || !f.startsWith(iiifDir))
            throw new Error('outside');
        let body = await readFile(f);
        if (u.endsWith('/info.json')) {
            const j = JSON.parse(body);
            j.id = `http://${req.headers.host}/${opt.id}`;
            body = Buffer.from(JSON.stringify(j));
        }
        res.writeHead(200, { 'Content-Type': u.endsWith('.json') ? 'application/json' : 'image/jpeg' });
        res.end(body);
    } catch {
        res.writeHead(404);
        res.end();
    }
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const iiifBase = `http://127.0.0.1:${server.address().port}`;

// ------------------------------------------------------------ one run
async function browser() {
    const profile = mkdtempSync(join(tmpdir(), 'gv-slide-view-'));
    const ctx = await chromium.launchPersistentContext(profile, {
        executablePath: opt.chromium, headless: true, viewport: { width: W, height: H },
        deviceScaleFactor: 1, timeout: 60000, args,
    });
    // Every finished request (the workers' too): URL, when its response
    // ended (ms since the epoch) and its body size.
    const reqs = [];
    ctx.on('requestfinished', (r) => reqs.push((async () => {
        const t = r.timing();
        const s = await r.sizes().catch(() => ({ responseBodySize: 0 }));
        return { url: r.url(), end: t.responseEnd >= 0 ? t.startTime + t.responseEnd : t.startTime,
            bytes: s.responseBodySize };
    })()));
    const pg = ctx.pages()[0] || await ctx.newPage();
    pg.setDefaultTimeout(300000);
    const errors = [];
    pg.on('pageerror', (e) => errors.push(e.message));
    return {
        pg, errors,
        // Image data received by `ms` after the navigation start.
        bytesBy: async (origin, ms, isData) => {
            const all = await Promise.all(reqs);
            const m = { bytes: 0, requests: 0, urls: [], lastMs: 0 };
            for (const r of all)
                if (isData(r.url) && r.end <= origin + ms + 1) {
                    m.bytes += r.bytes;
                    m.requests++;
                    m.urls.push(r.url);
                    m.lastMs = Math.max(m.lastMs, r.end - origin);
                }
            return m;
        },
        close: async () => { await ctx.close(); rmSync(profile, { recursive: true, force: true }); },
    };
}

async function runGigaview(view) {
    const b = await browser();
    try {
        await b.pg.goto(`${base}/${view.gv}`);
        await b.pg.evaluate(() => window.gigaview.ready);
        await b.pg.evaluate(() => window.gigaview.viewer.settled());
        const r = await b.pg.evaluate(() => {
            const v = window.gigaview.viewer, s = v.stats;
            return { origin: performance.timeOrigin, ms: s.openStart + s.firstCompleteMs, tiles: s.atFirstComplete.tiles,
                level: v.lastResult.level, renderer: s.renderer, kind: s.kind, openAt: s.openStart };
        });
        await b.pg.waitForTimeout(200);   // let the last responses' sizes arrive
        const m = await b.bytesBy(r.origin, r.ms, (u) => u.startsWith(`${base}/v1/`));
        return { ...r, bytes: m.bytes, requests: m.requests, dataMs: m.lastMs, what: `level ${r.level}, ${r.tiles} tiles`,
            errors: b.errors };
    } finally {
        await b.close();
    }
}

async function runOsd(view) {
    const b = await browser();
    try {
        await b.pg.goto(`${iiifBase}/${view.osd}`);
        await b.pg.waitForFunction(() => window.bench.first !== null);
        await b.pg.waitForTimeout(200);
        const r = await b.pg.evaluate(() => {
            const v = window.osd, bench = window.bench;
            const rect = v.viewport.viewportToImageRectangle(v.viewport.getBounds(true));
            return { origin: performance.timeOrigin, ms: bench.first, loadedAt: bench.loadedAt, changes: bench.changes,
                openAt: bench.openAt,
                drawer: v.drawer.getType ? v.drawer.getType() : '?',
                rect: [rect.x, rect.y, rect.width, rect.height].map(Math.round) };
        });
        const m = await b.bytesBy(r.origin, r.ms, (u) => u.startsWith(`${iiifBase}/${opt.id}/`));
        // Tiles by scale factor: region width over size width.
        const scales = {};
        for (const u of m.urls) {
            const t = /\/\d+,\d+,(\d+),\d+\/(\d+),\d*\/0\/default\.jpg$/.exec(u);
            if (t) {
                const s = Math.round(Number(t[1]) / Number(t[2]));
                scales[s] = (scales[s] || 0) + 1;
            }
        }
        const what = Object.keys(scales).sort((a, b) => b - a).map((s) => `${scales[s]} at 1/${s}`).join(', ');
        return { ...r, bytes: m.bytes, requests: m.requests, dataMs: m.lastMs, what: `tiles ${what}`, errors: b.errors };
    } finally {
        await b.close();
    }
}

// ------------------------------------------------------------ the runs
const median = (a) => [...a].sort((x, y) => x - y)[Math.floor((a.length - 1) / 2)];
const runs = views.map(() => ({ gv: [], osd: [] }));
for (let i = 0; i < reps; i++)
    for (const [k, v] of views.entries()) {
        runs[k].gv.push(await runGigaview(v));
        runs[k].osd.push(await runOsd(v));
    }
server.close();

const kib = (x) => `${(x / 1024).toFixed(0)} KiB`;
const pick = (rs) => { const m = median(rs.map((r) => r.ms)); return rs.find((r) => r.ms === m); };
const rows = [];
for (const [k, v] of views.entries()) {
    const g = pick(runs[k].gv), o = pick(runs[k].osd);
    const ratio = o.ms / g.ms;
    const verdict = ratio >= 1 ? `gigaview ${ratio.toFixed(2)}x faster` : `gigaview ${(1 / ratio).toFixed(2)}x slower`;
    rows.push([v.name, g, o, ratio, verdict]);
    const list = (rs) => rs.map((r) => r.ms.toFixed(0)).join(', ');
    console.log(`RESULT first-view ${opt.id} "${v.name}" ${W}x${H}: gigaview ${g.ms.toFixed(0)} ms, OpenSeadragon ` +
        `${o.ms.toFixed(0)} ms (medians of ${reps}); OSD/gigaview ${ratio.toFixed(2)} (${verdict})`);
    console.log(`#   gigaview runs ${list(runs[k].gv)} ms; ${g.what}; ${kib(g.bytes)} in ${g.requests} requests by then; ` +
        `opened at ${g.openAt.toFixed(0)} ms, last image data in at ${g.dataMs.toFixed(0)}; ${g.kind} on ${g.renderer}${g.errors.length ? `; page errors: ${g.errors.join('; ')}` : ''}`);
    console.log(`#   OpenSeadragon runs ${list(runs[k].osd)} ms; ${o.what}; ${kib(o.bytes)} in ${o.requests} requests by then; ` +
        `opened at ${o.openAt.toFixed(0)} ms, last image data in at ${o.dataMs.toFixed(0)}, fully loaded at ` +
        `${o.loadedAt.toFixed(0)}, drawn at ${o.ms.toFixed(0)}; ${o.drawer} drawer; ` +
        `view [x y w h] ${o.rect.join(' ')}; fully-loaded changes ${JSON.stringify(o.changes)}` +
        `${o.errors.length ? `; page errors: ${o.errors.join('; ')}` : ''}`);
}
console.log('');
console.log(`first complete view, ${W}x${H}, from navigation start (median of ${reps}):`);
console.log(`${'view'.padEnd(14)}${'gigaview'.padStart(10)}${'OSD'.padStart(10)}  ${'OSD/gv'.padStart(7)}  ${'verdict'.padEnd(26)}` +
    `${'gigaview bytes'.padStart(16)}${'OSD bytes'.padStart(16)}`);
for (const [name, g, o, ratio, verdict] of rows)
    console.log(`${name.padEnd(14)}${`${g.ms.toFixed(0)} ms`.padStart(10)}${`${o.ms.toFixed(0)} ms`.padStart(10)}  ` +
        `${ratio.toFixed(2).padStart(7)}  ${verdict.padEnd(26)}${kib(g.bytes).padStart(16)}${kib(o.bytes).padStart(16)}`);
