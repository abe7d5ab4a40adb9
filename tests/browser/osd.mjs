// osd.mjs - OpenSeadragon (from npm) shows an image through gigaviewd's
// IIIF Image API endpoint, in headless Chromium driven by playwright-core.
//
//   node osd.mjs --base http://127.0.0.1:PORT --id ID [--width W --height H]
//                [--out DIR] [--chromium /usr/bin/chromium]
//
// The page is served by this script from a second origin (its own HTTP
// server on 127.0.0.1, port 0), so every IIIF request is cross-origin: the
// info.json XHR and the tile images (crossOriginPolicy "Anonymous") load
// only if gigaviewd sends Access-Control-Allow-Origin.  The viewer is
// W x H CSS pixels at device scale 1 with the image's aspect ratio, so at
// its home zoom the image fills it exactly and the expected picture is
// the IIIF rendering full/W,H/0/default.png.
//
// Checks, printed one a line as "PASS text" or "FAIL text" (detail lines
// start with "#"; tests/browser_osd.sh turns them into TAP):
//   - the viewer opened and every tile it wanted loaded (fully-loaded);
//   - every IIIF response was 200 and carried Access-Control-Allow-Origin;
//   - the screenshot of the canvas is not blank: the standard deviation of
//     its luma is above MIN_STDDEV;
//   - it matches the reference: per channel, the mean absolute difference
//     is below MAX_MAD and the PSNR above MIN_PSNR;
//   - sensitivity (negative controls, so a lax metric cannot pass by
//     accident): the same metric, against the reference moved by SHIFT
//     pixels and against the reference mirrored, must fail the thresholds.
//
// Negative controls of the whole pipeline (tests/browser_osd.sh runs them
// and expects the match to FAIL): --tiles-from OTHER rewrites every image
// request of the viewer to store OTHER (a black or a different picture of
// the same size) while info.json and the reference stay those of ID;
// --shift-tiles PX asks for every tile region PX image pixels to the left
// (where it stays inside the image), so tiles land misplaced.
// Exit status 0 when everything passed, 1 otherwise, 2 on a usage error.
import { createServer } from 'node:http';
import { readFileSync, mkdirSync, writeFileSync, mkdtempSync, rmSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';
import { launchChromium, PATIENCE_MS } from './chromium.mjs';
import { pass, fail, note, failed } from './report.mjs';

// Thresholds (see tests/browser_osd.sh for why these values).
const MIN_STDDEV = 10;  // luma standard deviation, 8-bit units
const MAX_MAD = 4;      // mean absolute difference per channel, 8-bit units
const MIN_PSNR = 30;    // dB, per channel, peak 255
const SHIFT = 1;        // pixels, for the shifted negative control

const here = dirname(fileURLToPath(import.meta.url));
const opt = { width: 825, height: 525, chromium: '/usr/bin/chromium', out: '',
    'tiles-from': '', 'shift-tiles': 0 };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i += 2) {
    const k = argv[i].replace(/^--/, ''), v = argv[i + 1];
    if (v === undefined || !(k in opt || k === 'base' || k === 'id')) {
        console.error('usage: node osd.mjs --base URL --id ID [--width W] [--height H] [--out DIR]'
            + ' [--chromium PATH] [--tiles-from ID] [--shift-tiles PX]');
        process.exit(2);
    }
    opt[k] = k === 'width' || k === 'height' || k === 'shift-tiles' ? parseInt(v, 10) : v;
}
if (!opt.base || !opt.id) {
    console.error('osd.mjs: --base and --id are required');
    process.exit(2);
}
const base = opt.base.replace(/\/+$/, '');
const infoUrl = `${base}/iiif/3/${encodeURIComponent(opt.id)}/info.json`;
const W = opt.width, H = opt.height;


// ------------------------------------------------------------ page server
const osdDir = join(here, 'node_modules', 'openseadragon', 'build', 'openseadragon');
const osdJs = readFileSync(join(osdDir, 'openseadragon.min.js'));
const page = `<!doctype html>
<html><head><meta charset="utf-8"><title>gigaview OSD test</title>
<style>html,body{margin:0;padding:0;background:#000}
#v{width:${W}px;height:${H}px;background:#000}</style>
<script src="/openseadragon.min.js"></script></head>
<body><div id="v"></div>
<script>
window.gv = { tilesLoaded: 0, tilesFailed: [], fullyLoaded: false, opened: false, error: null };
const viewer = OpenSeadragon({
  id: 'v',
  prefixUrl: '/images/',
  tileSources: ${JSON.stringify(infoUrl)},
  crossOriginPolicy: 'Anonymous',
  showNavigationControl: false,
  animationTime: 0,
  blendTime: 0,
  immediateRender: false,
  springStiffness: 100
});
window.viewer = viewer;
viewer.addHandler('open', () => {
  window.gv.opened = true;
  const ti = viewer.world.getItemAt(0);
  const check = () => { if (ti.getFullyLoaded()) window.gv.fullyLoaded = true; };
  ti.addHandler('fully-loaded-change', check);
  check();
});
viewer.addHandler('open-failed', (e) => { window.gv.error = 'open-failed: ' + e.message; });
viewer.addHandler('tile-loaded', () => { window.gv.tilesLoaded++; });
viewer.addHandler('tile-load-failed', (e) => { window.gv.tilesFailed.push(e.message + ' ' + (e.tile && e.tile.getUrl ? e.tile.getUrl() : '')); });
</script></body></html>`;

const server = createServer((req, res) => {
    const u = req.url.split('?')[0];
    if (u === '/') {
        res.writeHead(200, { 'Content-Type': 'text/html; charset=utf-8' });
        res.end(page);
    } else if (u === '/blank') {
        res.writeHead(200, { 'Content-Type': 'text/html; charset=utf-8' });
        res.end('<!doctype html><title>compare</title>');
    } else if (u === '/openseadragon.min.js') {
        res.writeHead(200, { 'Content-Type': 'text/javascript' });
        res.end(osdJs);
    } else if (u === '/favicon.ico') {
        res.writeHead(204);
        res.end();
    } else {
        res.writeHead(404);
        res.end();
    }
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const pageUrl = `http://127.0.0.1:${server.address().port}/`;

// ---------------------------------------------------------------- browser
const profile = mkdtempSync(join(tmpdir(), 'gv-chromium-'));
let browser;
try {
    browser = await launchChromium(profile, opt.chromium, W, H, ['--disable-gpu']);
    await run(browser);
} catch (e) {
    fail('browser run', String(e && e.stack || e));
} finally {
    if (browser) await browser.close().catch(() => {});
    server.close();
    rmSync(profile, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);

async function run(ctx) {
    const pg = ctx.pages()[0] || await ctx.newPage();
    pg.setDefaultTimeout(20000);
    const iiif = [];       // {url, status, acao}
    const reqFailed = [];
    pg.on('response', (r) => {
        if (r.url().startsWith(base + '/'))
            iiif.push({ url: r.url(), status: r.status(), acao: r.headers()['access-control-allow-origin'] });
    });
    pg.on('requestfailed', (r) => reqFailed.push(`${r.url()}: ${r.failure() && r.failure().errorText}`));
    pg.on('console', (m) => { if (m.type() === 'error') note(`console: ${m.text()}`); });
    pg.on('pageerror', (e) => note(`page error: ${e.message}`));
    if (opt['tiles-from'] || opt['shift-tiles']) {
        const prefix = `${base}/iiif/3/${encodeURIComponent(opt.id)}/`;
        await pg.route((u) => u.href.startsWith(prefix) && u.href !== infoUrl, (route) => {
            let rest = route.request().url().slice(prefix.length);
            const dx = opt['shift-tiles'];
            rest = rest.replace(/^(\d+),(\d+),(\d+),(\d+)\//, (all, x, y, w, h) =>
                +x >= dx ? `${+x - dx},${y},${w},${h}/` : all);
            const id = opt['tiles-from'] || opt.id;
            note(`sabotage: ${route.request().url().slice(base.length)} -> ${id}/${rest}`);
            route.continue({ url: `${base}/iiif/3/${encodeURIComponent(id)}/${rest}` });
        });
    }

    const t0 = Date.now();
    await pg.goto(pageUrl);
    try {
        await pg.waitForFunction(() => window.gv.fullyLoaded || window.gv.error, null, { timeout: PATIENCE_MS });
    } catch {
        // reported below
    }
    const gv = await pg.evaluate(() => window.gv);
    if (gv.opened && gv.fullyLoaded && !gv.error && gv.tilesFailed.length === 0)
        pass(`OpenSeadragon opened ${infoUrl} and loaded every tile (${gv.tilesLoaded} tiles, ${Date.now() - t0} ms)`);
    else
        fail('OpenSeadragon opened the IIIF image and loaded every tile',
            `opened=${gv.opened} fullyLoaded=${gv.fullyLoaded} error=${gv.error} tiles=${gv.tilesLoaded}`,
            ...gv.tilesFailed.slice(0, 5), ...reqFailed.slice(0, 5));
    // Let the drawer paint the last tiles: two animation frames.
    await pg.evaluate(() => new Promise((ok) => requestAnimationFrame(() => requestAnimationFrame(ok))));
    note(`OpenSeadragon ${await pg.evaluate(() => OpenSeadragon.version.versionStr)}, drawer ${await pg.evaluate(() => viewer.drawer.getType ? viewer.drawer.getType() : '?')}`);

    const info = iiif.filter((r) => r.url === infoUrl);
    const tiles = iiif.filter((r) => r.url !== infoUrl);
    const bad = iiif.filter((r) => r.status !== 200 || r.acao !== '*');
    if (info.length >= 1 && tiles.length >= 1 && bad.length === 0)
        pass(`every IIIF response (info.json and ${tiles.length} images) was 200 with Access-Control-Allow-Origin: *`);
    else
        fail('every IIIF response was 200 with Access-Control-Allow-Origin: *',
            `info.json responses ${info.length}, image responses ${tiles.length}`,
            ...bad.slice(0, 5).map((r) => `${r.status} acao=${r.acao} ${r.url}`));
    for (const t of tiles.slice(0, 8)) note(`tile ${t.url.slice(base.length)}`);

    // The canvas as the user sees it (composited), not the canvas's own
    // backing store: the WebGL drawer does not preserve it.
    const canvas = pg.locator('#v canvas').first();
    const shot = await canvas.screenshot({ type: 'png' });
    const box = await canvas.boundingBox();
    if (opt.out) {
        mkdirSync(opt.out, { recursive: true });
        writeFileSync(join(opt.out, 'osd.png'), shot);
    }
    if (!box || Math.round(box.width) !== W || Math.round(box.height) !== H) {
        fail(`the viewer canvas is ${W}x${H}`, `bounding box ${JSON.stringify(box)}`);
        return;
    }

    // Compare in a plain page: both images decoded by the browser (sRGB,
    // no colour profiles), read back with getImageData.
    const refUrl = `${base}/iiif/3/${encodeURIComponent(opt.id)}/full/${W},${H}/0/default.png`;
    const cmp = await ctx.newPage();
    await cmp.goto(pageUrl + 'blank');
    const m = await cmp.evaluate(async ({ shotB64, refUrl, W, H, SHIFT }) => {
        const load = (src) => new Promise((ok, ko) => {
            const im = new Image();
            im.crossOrigin = 'anonymous';
            im.onload = () => ok(im);
            im.onerror = () => ko(new Error('cannot load ' + src.slice(0, 80)));
            im.src = src;
        });
        const pixels = (im) => {
            const c = document.createElement('canvas');
            c.width = W; c.height = H;
            const g = c.getContext('2d', { willReadFrequently: true });
            g.drawImage(im, 0, 0);
            return g.getImageData(0, 0, W, H).data;
        };
        const a = pixels(await load('data:image/png;base64,' + shotB64));
        const refIm = await load(refUrl);
        const b = pixels(refIm);
        // Luma statistics of the screenshot.
        let s = 0, s2 = 0;
        for (let i = 0; i < a.length; i += 4) {
            const y = 0.299 * a[i] + 0.587 * a[i + 1] + 0.114 * a[i + 2];
            s += y; s2 += y * y;
        }
        const n = W * H;
        const mean = s / n, stddev = Math.sqrt(Math.max(0, s2 / n - mean * mean));
        // Per-channel MAD and PSNR of a against b sampled at (x+dx, y)
        // (mirror: b at (W-1-x, y)); compared over the columns both cover.
        const compare = (dx, mirror) => {
            const sad = [0, 0, 0], sse = [0, 0, 0];
            let cnt = 0;
            for (let y = 0; y < H; y++)
                for (let x = 0; x < W; x++) {
                    const bx = mirror ? W - 1 - x : x + dx;
                    if (bx < 0 || bx >= W) continue;
                    const i = 4 * (y * W + x), j = 4 * (y * W + bx);
                    for (let c = 0; c < 3; c++) {
                        const d = a[i + c] - b[j + c];
                        sad[c] += Math.abs(d); sse[c] += d * d;
                    }
                    cnt++;
                }
            return {
                mad: sad.map((v) => v / cnt),
                psnr: sse.map((v) => v === 0 ? 99 : 10 * Math.log10(255 * 255 / (v / cnt))),
            };
        };
        return { refW: refIm.naturalWidth, refH: refIm.naturalHeight, mean, stddev,
            same: compare(0, false), shifted: compare(SHIFT, false), mirrored: compare(0, true) };
    }, { shotB64: shot.toString('base64'), refUrl, W, H, SHIFT });
    await cmp.close();

    const f = (v) => v.map((x) => x.toFixed(2)).join('/');
    const within = (r) => r.mad.every((v) => v < MAX_MAD) && r.psnr.every((v) => v > MIN_PSNR);
    if (m.stddev > MIN_STDDEV)
        pass(`the canvas is not blank (luma mean ${m.mean.toFixed(1)}, stddev ${m.stddev.toFixed(1)} > ${MIN_STDDEV})`);
    else
        fail(`the canvas is not blank (luma stddev ${m.stddev.toFixed(2)}, wanted > ${MIN_STDDEV})`);
    if (m.refW !== W || m.refH !== H)
        fail(`the reference ${refUrl} is ${W}x${H}`, `got ${m.refW}x${m.refH}`);
    if (within(m.same))
        pass(`the canvas matches ${refUrl.slice(base.length)} (MAD R/G/B ${f(m.same.mad)} < ${MAX_MAD}, PSNR ${f(m.same.psnr)} dB > ${MIN_PSNR})`);
    else
        fail('the canvas matches the reference render',
            `MAD R/G/B ${f(m.same.mad)} (limit ${MAX_MAD}), PSNR ${f(m.same.psnr)} dB (limit ${MIN_PSNR})`);
    if (!within(m.shifted) && !within(m.mirrored))
        pass(`the metric rejects the reference moved by ${SHIFT} px (MAD ${f(m.shifted.mad)}, PSNR ${f(m.shifted.psnr)}) and mirrored (MAD ${f(m.mirrored.mad)})`);
    else
        fail('the metric rejects a shifted or mirrored reference (too lax for this image)',
            `shifted MAD ${f(m.shifted.mad)} PSNR ${f(m.shifted.psnr)}; mirrored MAD ${f(m.mirrored.mad)} PSNR ${f(m.mirrored.psnr)}`);
}
