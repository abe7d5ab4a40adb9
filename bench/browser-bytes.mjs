// browser-bytes.mjs - bytes transferred along a scripted pan and zoom
// path: the gigaview viewer (compressed tiles from gigaviewd, decoded in
// the browser) against OpenSeadragon on static IIIF JPEG tiles (made by
// bench/browser-bytes.sh with vips dzsave at the JPEG quality of equal
// PSNR), and the native window client (`gigaview view`, the same tiles
// decoded by the local GPU) along the same path.  Run by
// bench/browser-bytes.sh; prints "RESULT" lines.
//
//   node browser-bytes.mjs --base URL --id ID --iiif DIR [--size WxH]
//        [--chromium PATH] [--gigaview PATH --access-log FILE]
//
// The path, for a W x H viewport (zoom z: one screen pixel shows 2^z
// level-0 pixels; `home` is the whole image):
//   1 home   2 z=1.2 at the centre (or 0.4 below home)   3 z=0.2
//   4 pan right half a screen   5 pan down half a screen   6 pan left one
//   screen   7 z=-0.8 (magnified)   8 home again
// Each viewer gets a fresh browser profile (no HTTP cache) and waits at
// every step until its picture is complete (gigaview: every tile of the
// view decoded; OpenSeadragon: fully-loaded).  Bytes are what the network
// layer received for the image data (Chrome DevTools Protocol
// encodedDataLength: bodies and headers): gigaview's metadata, root and
// tile batches; OpenSeadragon's info.json and tiles; not the pages and
// scripts.  gigaview runs twice: without prefetching (what the path
// needs) and as shipped (with the prefetch circle of thesis section 7.5).
//
// With --gigaview and --access-log (gigaviewd's access log, one line per
// request with its body bytes) the native viewer runs the same 8 views
// in a window of the same size, under SDL's offscreen driver, with
// `--no-cache` (no on-disk ETag cache: every tile comes over HTTP), also
// without and with prefetching (`--no-prefetch`; prefetching is on as
// shipped), through a --script of `view CX,CY,ZOOM` + `settle` + the same
// wait as the browser's.  So that the clients are counted alike, the
// servers count: the response bodies of gigaviewd's /v1/ requests during
// each gigaview run (browser and native), and those of the IIIF tiles and
// info.json that the static server below sends to OpenSeadragon.  The
// native viewer's own count (its --stats line: the bodies curl received)
// is printed beside the server's as a check.
import { createServer } from 'node:http';
import { spawn } from 'node:child_process';
import { createInterface } from 'node:readline';
import { mkdtempSync, readFileSync, rmSync, existsSync, statSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, normalize } from 'node:path';
import { chromium, nodeModules as nm, parseOptions } from './browser_lib.mjs';

const opt = parseOptions({ base: '', id: '', iiif: '', size: '1280x800', chromium: '/usr/bin/chromium', gigaview: '',
    'access-log': '' },
    'node browser-bytes.mjs --base URL --id ID --iiif DIR [--size WxH] [--chromium PATH] ' +
            '[--gigaview PATH --access-log FILE]');
const base = opt.base.replace(/\/+$/, '');
const [W, H] = opt.size.split('x').map(Number);
const info = await (await fetch(`${base}/v1/images/${opt.id}`)).json();
const IW = info.width, IH = info.height;
const home = { cx: IW / 2, cy: IH / 2, zoom: Math.log2(Math.max(IW / W, IH / H)), rot: 0 };

// The path, each step from the previous one.
const path = [['home', () => home]];
{
    // Zooms off the integers: at an integer zoom OpenSeadragon (its
    // default minPixelRatio 0.5) takes the next finer level, the viewer
    // the level itself; elsewhere both draw from the same level.
    // Pans of half a screen stay inside the image at these zooms for
    // images of 3 megapixels or more.
    let v = { ...home, zoom: Math.min(1.2, home.zoom - 0.4) };
    path.push([`z=${v.zoom.toFixed(2)} at the centre`, () => v]);
    const step = (name, f) => { const w = f(v); v = w; path.push([name, () => w]); };
    step('z=0.2', (u) => ({ ...u, zoom: 0.2 }));
    step('pan right half a screen', (u) => ({ ...u, cx: u.cx + W / 2 * 2 ** u.zoom }));
    step('pan down half a screen', (u) => ({ ...u, cy: u.cy + H / 2 * 2 ** u.zoom }));
    step('pan left one screen', (u) => ({ ...u, cx: u.cx - W * 2 ** u.zoom }));
    step('z=-0.8', (u) => ({ ...u, zoom: -0.8 }));
    path.push(['home again', () => home]);
}

// ------------------------------------------------- the static IIIF server
const osdJs = readFileSync(join(nm, 'openseadragon', 'build', 'openseadragon', 'openseadragon.min.js'));
let iiifBase = '';
const osdServed = { bytes: 0, requests: 0 }; // response bodies of the image data
const page = (infoUrl) => `<!doctype html><html><head><meta charset="utf-8"><title>osd bytes</title>
<style>html,body{margin:0;background:#000}#v{width:${W}px;height:${H}px}</style>
<script src="/openseadragon.min.js"></script></head><body><div id="v"></div><script>
window.osd = OpenSeadragon({ id: 'v', prefixUrl: '/images/', tileSources: ${JSON.stringify(infoUrl)},
  crossOriginPolicy: 'Anonymous', showNavigationControl: false, animationTime: 0, blendTime: 0,
  immediateRender: false, springStiffness: 100 });
window.osdOpen = new Promise((ok) => window.osd.addHandler('open', ok));
</script></body></html>`;
const server = createServer((req, res) => {
    const u = decodeURIComponent(req.url.split('?')[0]);
    if (u === '/') {
        res.writeHead(200, { 'Content-Type': 'text/html' });
        res.end(page(`${iiifBase}/${opt.id}/info.json`));
        return;
    }
    if (u === '/openseadragon.min.js') {
        res.writeHead(200, { 'Content-Type': 'text/javascript' });
        res.end(osdJs);
        return;
    }
    const prefix = `/${opt.id}/`;
    const f = normalize(join(opt.iiif, u.slice(prefix.length)));
    if (!u.startsWith(prefix) || !f.startsWith(normalize(opt.iiif)) || !existsSync(f)) {
        res.writeHead(404, { 'Access-Control-Allow-Origin': '*' });
        res.end();
        return;
    }
    let body = readFileSync(f);
    if (u.endsWith('/info.json')) {
        const j = JSON.parse(body);
        j.id = `${iiifBase}/${opt.id}`;
        body = Buffer.from(JSON.stringify(j));
    }
    res.writeHead(200, { 'Content-Type': u.endsWith('.json') ? 'application/json' : 'image/jpeg',
        'Access-Control-Allow-Origin': '*' });
    osdServed.bytes += body.length;
    osdServed.requests++;
    res.end(body);
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
iiifBase = `http://127.0.0.1:${server.address().port}`;

// Bytes of image data received, counted through the DevTools protocol.
async function meter(ctx, pg, isData) {
    const cdp = await ctx.newCDPSession(pg);
    await cdp.send('Network.enable');
    const urls = new Map();
    const m = { bytes: 0, requests: 0 };
    cdp.on('Network.responseReceived', (e) => urls.set(e.requestId, e.response.url));
    cdp.on('Network.loadingFinished', (e) => {
        const u = urls.get(e.requestId);
        if (u && isData(u)) {
            m.bytes += e.encodedDataLength;
            m.requests++;
        }
    });
    return m;
}

// Response bodies gigaviewd sent for /v1/ between two offsets of its
// access log ("... access: REMOTE \"METHOD PATH[?QUERY]\" STATUS BYTES USECus"):
// all of them, and the tiles (batches, single tiles) and the root apart.
const logAt = () => (opt['access-log'] ? statSync(opt['access-log']).size : 0);
function served(from, to) {
    const m = { bytes: 0, requests: 0, tiles: 0, tileRequests: 0, root: 0, other: 0, routes: {} };
    if (!opt['access-log'])
        return m;
    const text = readFileSync(opt['access-log']).subarray(from, to).toString();
    for (const line of text.split('\n')) {
        const r = / access: \S+ "(\S+) (\S+)" (\d+) (\d+) /.exec(line);
        if (!r || !r[2].startsWith('/v1/'))
            continue;
        const n = Number(r[4]);
        const route = `${r[1]} ${r[2].replace(`/images/${opt.id}`, '/images/ID').replace(/\?.*/, '')}`;
        m.routes[route] = (m.routes[route] || 0) + 1;
        m.bytes += n;
        m.requests++;
        if (/\/(batch|tiles\/)/.test(r[2])) {
            m.tiles += n;
            m.tileRequests++;
        } else if (/\/root(\?|$)/.test(r[2])) {   // every form: PNG, WebP, raw mips
            m.root += n;
        } else {
            m.other += n;
        }
    }
    return m;
}

async function launch() {
    const profile = mkdtempSync(join(tmpdir(), 'gv-bytes-'));
    const ctx = await chromium.launchPersistentContext(profile, {
        executablePath: opt.chromium, headless: true, viewport: { width: W, height: H }, deviceScaleFactor: 1,
        args: ['--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
            '--disable-background-networking', '--no-first-run', '--force-color-profile=srgb'],
    });
    return { ctx, done: async () => { await ctx.close(); rmSync(profile, { recursive: true, force: true }); } };
}

async function runGigaview(prefetch) {
    const b = await launch();
    const at0 = logAt();
    try {
        const pg = b.ctx.pages()[0] || await b.ctx.newPage();
        pg.setDefaultTimeout(300000);
        const m = await meter(b.ctx, pg, (u) => u.startsWith(`${base}/v1/`));
        const steps = [];
        let last = 0;
        // workers=0: the batches are fetched by the page itself, where the
        // protocol session sees them (a worker's requests are its own).
        await pg.goto(`${base}/?workers=0${prefetch ? '' : '&prefetch=0'}#image=${opt.id}`);
        await pg.evaluate(() => window.gigaview.ready);
        for (const [name, f] of path) {
            await pg.evaluate((v) => window.gigaview.viewer.setView(v), f());
            await pg.evaluate(() => window.gigaview.viewer.settled());
            // Let prefetching (when on) and late responses finish.
            await pg.waitForTimeout(prefetch ? 1500 : 300);
            steps.push([name, m.bytes - last]);
            last = m.bytes;
        }
        await b.done();
        return { ...m, steps, served: served(at0, logAt()) };
    } catch (e) {
        await b.done();
        throw e;
    }
}

// The native viewer along the same path: a --script of the same views,
// each followed by `settle` (every tile of the view drawn, as the
// browser's settled()) and the browser's wait; `print` marks each step
// on stdout, where the access log's offset is taken, and the viewer
// waits (`wait-file`) until it was, so no request of the next step is
// counted in this one.
async function runNative(prefetch) {
    const dir = mkdtempSync(join(tmpdir(), 'gv-view-bytes-'));
    try {
        const lines = [];
        path.forEach(([, f], i) => {
            const v = f();
            lines.push(`view ${v.cx},${v.cy},${v.zoom}`, 'settle 600000', `wait ${prefetch ? 1500 : 300}`,
                `print step ${i + 1}`, `wait-file ${join(dir, `ack${i + 1}`)} 600000`);
        });
        lines.push('quit');
        writeFileSync(join(dir, 'path.txt'), lines.join('\n') + '\n');
        const args = ['view', base, '--image', opt.id, '--size', `${W}x${H}`, '--no-cache', '--no-vsync',
            '--script', join(dir, 'path.txt'), '--stats', join(dir, 'frames.tsv')];
        if (!prefetch)
            args.push('--no-prefetch');
        const at0 = logAt();
        const marks = [];
        const child = spawn(opt.gigaview, args, {
            env: { ...process.env, SDL_VIDEODRIVER: 'offscreen', XDG_CACHE_HOME: join(dir, 'cache') },
            stdio: ['ignore', 'pipe', 'pipe'],
        });
        let err = '';
        child.stderr.on('data', (d) => { err += d; });
        createInterface({ input: child.stdout }).on('line', (l) => {
            if (/^step \d+ /.test(l)) {
                marks.push(logAt());
                writeFileSync(join(dir, `ack${marks.length}`), '');
            }
        });
        const code = await new Promise((ok) => child.on('close', ok));
        if (code !== 0 || marks.length !== path.length)
            throw new Error(`gigaview view exited ${code} after ${marks.length} steps: ${err.slice(-600)}`);
        const own = /http: (\d+) requests, (\d+) bytes/.exec(err);
        const s = served(at0, logAt());
        const steps = marks.map((at, i) => [path[i][0], served(i ? marks[i - 1] : at0, at).bytes]);
        return { ...s, steps, own: own ? { requests: Number(own[1]), bytes: Number(own[2]) } : null,
            summary: (/^view: .*$/m.exec(err) || [''])[0] };
    } finally {
        rmSync(dir, { recursive: true, force: true });
    }
}

async function runOsd() {
    const b = await launch();
    try {
        const pg = b.ctx.pages()[0] || await b.ctx.newPage();
        pg.setDefaultTimeout(300000);
        const m = await meter(b.ctx, pg, (u) => u.startsWith(`${iiifBase}/${opt.id}/`));
        const steps = [];
        let last = 0;
        await pg.goto(`${iiifBase}/`);
        await pg.evaluate(() => window.osdOpen);
        for (const [name, f] of path) {
            const v = f();
            // The same image rectangle as the gigaview view.
            const w = W * 2 ** v.zoom, h = H * 2 ** v.zoom;
            await pg.evaluate(({ x, y, w, h, IW }) => {
                window.osd.viewport.fitBounds(new OpenSeadragon.Rect(x / IW, y / IW, w / IW, h / IW), true);
            }, { x: v.cx - w / 2, y: v.cy - h / 2, w, h, IW });
            // OSD decides what to load on its next update: let two frames
            // pass before asking whether everything is loaded.
            for (let i = 0; i < 2; i++) {
                await pg.evaluate(() => new Promise((ok) => requestAnimationFrame(() => requestAnimationFrame(ok))));
                await pg.waitForFunction(() => window.osd.world.getItemAt(0).getFullyLoaded());
                await pg.waitForTimeout(300);
            }
            steps.push([name, m.bytes - last]);
            last = m.bytes;
        }
        return { ...m, steps };
    } finally {
        await b.done();
    }
}

const kib = (x) => `${(x / 1024).toFixed(0)} KiB`;
const ratio = (a, b) => (a / b).toFixed(2);
const g0 = await runGigaview(false);
const g1 = await runGigaview(true);
const native = opt.gigaview !== '';
const n0 = native ? await runNative(false) : null;
const n1 = native ? await runNative(true) : null;
const o = await runOsd();
server.close();
console.log(`RESULT bytes ${opt.id} ${W}x${H}, path of ${path.length} views: gigaview ${kib(g0.bytes)} in ${g0.requests} requests ` +
    `(with prefetching ${kib(g1.bytes)} in ${g1.requests}); OpenSeadragon on IIIF JPEG tiles ${kib(o.bytes)} in ${o.requests} requests; ` +
    `ratio gigaview/OSD ${(g0.bytes / o.bytes).toFixed(2)} (with prefetching ${(g1.bytes / o.bytes).toFixed(2)})`);
for (let i = 0; i < path.length; i++)
    console.log(`# step ${i + 1} ${path[i][0]}: gigaview ${kib(g0.steps[i][1])}, with prefetching ${kib(g1.steps[i][1])}, OSD ${kib(o.steps[i][1])}` +
        (native ? `; native viewer ${kib(n0.steps[i][1])}, with prefetching ${kib(n1.steps[i][1])}` : ''));
if (native) {
    const b0 = g0.served, b1 = g1.served;
    const cell = (m) => `${kib(m.bytes)} in ${m.requests}`.padEnd(22);
    console.log('# response bodies as the servers sent them (gigaviewd\'s access log, /v1/ requests; the IIIF server):');
    console.log(`#   ${'client'.padEnd(30)}${'no prefetch'.padEnd(22)}with prefetch (as shipped)`);
    console.log(`#   ${'gigaview view (native)'.padEnd(30)}${cell(n0)}${cell(n1)}`);
    console.log(`#   ${'gigaview browser viewer'.padEnd(30)}${cell(b0)}${cell(b1)}`);
    console.log(`#   ${'OpenSeadragon, IIIF JPEG'.padEnd(30)}${cell(osdServed.bytes ? { bytes: osdServed.bytes, requests: osdServed.requests } : o)}(none)`);
    for (const [name, a, b] of [['native', n0, n1], ['browser', b0, b1]])
        console.log(`#   ${name}: tiles ${kib(a.tiles)} in ${a.tileRequests} requests, root ${kib(a.root)}, metadata ${kib(a.other)}` +
            ` (with prefetching: tiles ${kib(b.tiles)} in ${b.tileRequests}, root ${kib(b.root)}, metadata ${kib(b.other)})`);
    const routes = (m) => Object.entries(m.routes).map(([k, v]) => `${k} x${v}`).join(', ');
    console.log(`#   native requests: ${routes(n0)}`);
    console.log(`#   browser requests: ${routes(b0)}`);
    for (const [name, n] of [['no prefetch', n0], ['prefetch', n1]])
        console.log(`#   native, ${name}, its own count (curl's bodies, --stats): ` +
            (n.own ? `${n.own.bytes} bytes in ${n.own.requests} requests` : 'none') +
            ` against the server's ${n.bytes} in ${n.requests} (root and tiles ${n.root + n.tiles}); ${n.summary}`);
    const ob = osdServed.bytes;
    console.log(`RESULT native ${opt.id} ${W}x${H}, path of ${path.length} views (bodies, server-side): gigaview view ` +
        `${kib(n0.bytes)} in ${n0.requests} requests (with prefetching ${kib(n1.bytes)} in ${n1.requests}); browser viewer ` +
        `${kib(b0.bytes)} in ${b0.requests} (with prefetching ${kib(b1.bytes)} in ${b1.requests}); OpenSeadragon ${kib(ob)} in ` +
        `${osdServed.requests}; ratio native/browser ${ratio(n0.bytes, b0.bytes)} (with prefetching ${ratio(n1.bytes, b1.bytes)}), ` +
        `native/OSD ${ratio(n0.bytes, ob)} (${ratio(n1.bytes, ob)}), browser/OSD ${ratio(b0.bytes, ob)} (${ratio(b1.bytes, ob)})`);
}
