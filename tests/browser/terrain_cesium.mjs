// terrain_cesium.mjs - CesiumJS (from npm, unchanged) loads gigaviewd's
// terrain service (GET /v1/images/{id}/terrain/layer.json and its
// quantized-mesh tiles) in headless Chromium, driven by playwright-core.
//
//   node terrain_cesium.mjs --base http://127.0.0.1:PORT --id ID [--lon0 L]
//        [--out DIR] [--chromium /usr/bin/chromium]
//
// The page and Cesium's Build/Cesium files are served by this script from
// a second origin (its own HTTP server on 127.0.0.1, port 0), so every
// terrain request is cross-origin.  No Ion token, no network imagery: the
// viewer has no base layer, and the globe is coloured by a material of
// the terrain height (blue deep, sand high), so that relief shows in
// pixels without lighting or imagery.  The camera looks straight down on
// the Himalaya and the Bay of Bengal from 3000 km (the globe fills the
// frame).
//
// Checks, one a line as "PASS text" or "FAIL text" (details start with "#";
// tests/browser_terrain.sh turns them into TAP):
//   - CesiumTerrainProvider.fromUrl opened layer.json, and the globe
//     finished loading its tiles (globe.tilesLoaded);
//   - terrain tiles were requested, and every answer from gigaviewd was
//     200 application/vnd.quantized-mesh (layer.json: 200 JSON), with no
//     failed request and nothing logged to the console as an error;
//   - Cesium parsed them: sampleTerrainMostDetailed gives Mount Everest
//     above 3000 m and the middle of the Pacific below -3000 m;
//   - no crack: the globe fills the frame and is drawn without Cesium's
//     skirts (the walls it hangs under tile edges to hide cracks), so a
//     crack between tiles would show the black background: no pixel may
//     be that dark;
//   - the screenshot shows terrain: the standard deviation of its luma is
//     above MIN_STDDEV and it has more than MIN_COLOURS colours, while the
//     same view with Cesium's EllipsoidTerrainProvider (the ellipsoid
//     alone, height 0 everywhere) is one flat colour (stddev below
//     MAX_FLAT_STDDEV): the relief comes from the tiles;
//   - lighting from the tiles' normals: the same view, white and lit by a
//     low sun from the west (globe.enableLighting), drawn twice, with
//     CesiumTerrainProvider's requestVertexNormals and without.  With it,
//     every tile request named octvertexnormals in its Accept header, the
//     tiles CesiumJS drew carry vertex normals (their mesh's encoding), and
//     Cesium shades by them (vertex lighting: luma stddev above
//     MIN_LIT_STDDEV, where without normals its day-night shading of the
//     ellipsoid is one shade, below MAX_FLAT_STDDEV).  That slopes tilt
//     the normals as they should is checked byte for byte in
//     tests/http_terrain.sh: at this scale the half-degree relief moves
//     the shading less than the normals' 8-bit quantisation would.
// Exit status 0 when everything passed, 1 otherwise, 2 on a usage error.
import { createServer } from 'node:http';
import { readFile } from 'node:fs/promises';
import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { dirname, extname, join, normalize } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';
import { launchChromium } from './chromium.mjs';
import { pass, fail, note, check, failed, parseArgs } from './report.mjs';

const MIN_STDDEV = 12;       // luma, 8-bit units, terrain
const MIN_COLOURS = 50;      // distinct RGB values, terrain
const MAX_FLAT_STDDEV = 3;   // luma, the ellipsoid alone
const MIN_LIT_STDDEV = 8;    // luma, lit through the tiles' normals
const W = 480, H = 320;

const here = dirname(fileURLToPath(import.meta.url));
const opt = { chromium: '/usr/bin/chromium', out: '', base: '', id: '', lon0: '' };
parseArgs(opt, 'usage: node terrain_cesium.mjs --base URL --id ID [--lon0 L] [--out DIR] [--chromium PATH]', 'terrain_cesium.mjs', ['base', 'id']);
const base = opt.base.replace(/\/+$/, '');
// CesiumTerrainProvider.fromUrl takes the directory of layer.json
const layerUrl = `${base}/v1/images/${encodeURIComponent(opt.id)}/terrain/` +
    (opt.lon0 ? `?lon0=${encodeURIComponent(opt.lon0)}` : '');


// ------------------------------------------------------------ page server
const cesiumDir = join(here, 'node_modules', 'cesium', 'Build', 'Cesium');
const types = {
    '.js': 'text/javascript', '.css': 'text/css', '.json': 'application/json',
    '.png': 'image/png', '.jpg': 'image/jpeg', '.svg': 'image/svg+xml',
    '.wasm': 'application/wasm', '.xml': 'application/xml', '.ktx2': 'image/ktx2',
};
const page = `<!doctype html>
<html><head><meta charset="utf-8">
<script>window.CESIUM_BASE_URL = '/cesium/';</script>
<script src="/cesium/Cesium.js"></script>
<link rel="stylesheet" href="/cesium/Widgets/widgets.css"><link rel="icon" href="data:,">
<style>html, body, #c { margin: 0; width: 100%; height: 100%; overflow: hidden; }</style>
</head><body><div id="c"></div>
<script>
window.run = async (layerUrl, lit) => {
    const terrain = layerUrl ? await Cesium.CesiumTerrainProvider.fromUrl(layerUrl,
        { requestVertexNormals: lit === 'normals' })
        : new Cesium.EllipsoidTerrainProvider();
    const viewer = new Cesium.Viewer('c', {
        baseLayer: false, terrainProvider: terrain, animation: false,
        timeline: false, baseLayerPicker: false, geocoder: false,
        homeButton: false, sceneModePicker: false, navigationHelpButton: false,
        fullscreenButton: false, infoBox: false, selectionIndicator: false,
        skyBox: false, skyAtmosphere: false,
        contextOptions: { webgl: { preserveDrawingBuffer: true } },
    });
    const s = viewer.scene;
    s.fog.enabled = false;
    s.globe.showSkirts = false;   // a crack would show the black background
    s.globe.showGroundAtmosphere = false;
    s.globe.baseColor = Cesium.Color.BLACK;
    s.globe.material = new Cesium.Material({ fabric: { type: 'GvHeight', source: \`
czm_material czm_getMaterial(czm_materialInput materialInput) {
    czm_material m = czm_getDefaultMaterial(materialInput);
    float t = clamp((materialInput.height + 6000.0) / 12000.0, 0.0, 1.0);
    m.diffuse = mix(vec3(0.0, 0.1, 0.5), vec3(1.0, 0.85, 0.5), t);
    return m;
}\` } });
    if (lit) {
        // white, lit by a sun 20 degrees above the western horizon
        s.globe.material = undefined;
        s.globe.baseColor = Cesium.Color.WHITE;
        s.globe.enableLighting = true;
        s.globe.dynamicAtmosphereLighting = false;
        const lo = Cesium.Math.toRadians(88), la = Cesium.Math.toRadians(24);
        const east = new Cesium.Cartesian3(-Math.sin(lo), Math.cos(lo), 0);
        const up = new Cesium.Cartesian3(Math.cos(la) * Math.cos(lo),
            Math.cos(la) * Math.sin(lo), Math.sin(la));
        const dir = Cesium.Cartesian3.add(Cesium.Cartesian3.multiplyByScalar(east,
            Math.cos(0.349), new Cesium.Cartesian3()), Cesium.Cartesian3.multiplyByScalar(
            up, -Math.sin(0.349), new Cesium.Cartesian3()), new Cesium.Cartesian3());
        s.light = new Cesium.DirectionalLight({ direction: Cesium.Cartesian3.normalize(dir, dir) });
    }
    viewer.camera.setView({
        destination: Cesium.Cartesian3.fromDegrees(88, 24, 3.0e6),
        orientation: { heading: 0, pitch: -Cesium.Math.PI_OVER_TWO, roll: 0 },
    });
    window.viewer = viewer;
    window.gvTerrain = terrain;
};
// Luma statistics and distinct colours of the canvas.
window.stats = () => {
    const src = window.viewer.scene.canvas;
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let n = 0, s = 0, s2 = 0, dark = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4) {
        const y = 0.299 * d[i] + 0.587 * d[i + 1] + 0.114 * d[i + 2];
        s += y; s2 += y * y; n++;
        if (d[i] + d[i + 1] + d[i + 2] < 60) dark++;
        colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
    }
    const mean = s / n;
    return { mean, dark, stddev: Math.sqrt(Math.max(0, s2 / n - mean * mean)), colours: colours.size,
        width: c.width, height: c.height };
};
// How many of the tiles drawn carry vertex normals, of how many.
window.normalsDrawn = () => {
    const tiles = window.viewer.scene.globe._surface._tilesToRender;
    const withNormals = tiles.filter((t) => t.data && t.data.mesh &&
        t.data.mesh.encoding.hasVertexNormals).length;
    return { tiles: tiles.length, withNormals };
};
window.sample = async (pts) => {
    const c = pts.map(([lon, lat]) => Cesium.Cartographic.fromDegrees(lon, lat));
    const r = await Cesium.sampleTerrainMostDetailed(window.gvTerrain, c);
    return r.map((p) => p.height);
};
</script></body></html>`;

const server = createServer(async (req, res) => {
    const u = new URL(req.url, 'http://x');
    if (u.pathname === '/') {
        res.writeHead(200, { 'Content-Type': 'text/html' });
        res.end(page);
        return;
    }
    if (u.pathname.startsWith('/cesium/')) {
        const rel = normalize(decodeURIComponent(u.pathname.slice(8)));
        if (!rel.startsWith('..') && !rel.startsWith('/')) {
            try {
                const body = await readFile(join(cesiumDir, rel));
                res.writeHead(200, { 'Content-Type': types[extname(rel)] || 'application/octet-stream' });
                res.end(body);
                return;
            } catch { /* 404 below */ }
        }
    }
    res.writeHead(404);
    res.end();
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const pageBase = `http://127.0.0.1:${server.address().port}`;

// ------------------------------------------------------------ browser
const scratch = mkdtempSync(join(tmpdir(), 'gv-cesium-'));
const consoleErrors = [], failedRequests = [], answers = [], accepts = [];
let ctx;

async function render(layer, name, lit) {
    const pg = await ctx.newPage();
    pg.setDefaultTimeout(45000);
    pg.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(`${name}: ${m.text()}`); });
    pg.on('pageerror', (e) => consoleErrors.push(`${name}: page error: ${e.message}`));
    pg.on('requestfailed', (r) => failedRequests.push(`${r.url()}: ${r.failure() && r.failure().errorText}`));
    pg.on('request', (r) => {
        if (/\.terrain(\?|$)/.test(r.url()))
            accepts.push({ name, accept: r.headers()['accept'] || '' });
    });
    pg.on('response', (r) => {
        if (r.url().startsWith(base))
            answers.push({ url: r.url(), status: r.status(), type: r.headers()['content-type'] || '' });
        else if (r.status() >= 400)
            failedRequests.push(`${r.url()}: HTTP ${r.status()}`);
    });
    await pg.goto(`${pageBase}/`);
    await pg.evaluate(([u, l]) => window.run(u, l), [layer, lit || '']);
    // a complete picture: every tile the view wants is loaded and drawn
    await pg.waitForFunction(() => {
        const s = window.viewer.scene;
        return s.globe.tilesLoaded && (window.frames_ = (window.frames_ || 0) + 1) > 3;
    }, null, { polling: 200 });
    const st = await pg.evaluate(() => window.stats());
    if (opt.out) {
        mkdirSync(opt.out, { recursive: true });
        writeFileSync(join(opt.out, `${name}.png`), await pg.screenshot());
    }
    return { pg, st };
}

try {
    ctx = await launchChromium(join(scratch, 'profile'), opt.chromium, W, H);
    const t0 = Date.now();
    const a = await render(layerUrl, 'terrain');
    pass(`CesiumTerrainProvider.fromUrl opened layer.json and the globe loaded its tiles (${Date.now() - t0} ms)`);
    const hs = await a.pg.evaluate(() => window.sample([[86.925, 27.988], [-150, 0]]));
    check(hs.every(Number.isFinite) && hs[0] > 3000 && hs[1] < -3000,
        `Cesium parsed the tiles: Everest ${Math.round(hs[0])} m, the Pacific ${Math.round(hs[1])} m`);
    const tiles = answers.filter((r) => /\.terrain(\?|$)/.test(r.url));
    const layers = answers.filter((r) => /layer\.json/.test(r.url));
    note(`${tiles.length} terrain tiles, e.g. ${tiles.slice(0, 3).map((r) => r.url.replace(base, '')).join(' ')}`);
    const bad = answers.filter((r) => r.status !== 200 ||
        (/\.terrain/.test(r.url) && r.type !== 'application/vnd.quantized-mesh') ||
        (/layer\.json/.test(r.url) && r.type !== 'application/json'));
    check(tiles.length >= 4 && layers.length >= 1 && bad.length === 0,
        `terrain tiles requested (${tiles.length}), every answer 200 with its media type`,
        ...bad.slice(0, 5).map((r) => `${r.url}: ${r.status} ${r.type}`));
    const e = await render('', 'ellipsoid');
    note(`terrain: luma mean ${a.st.mean.toFixed(1)} stddev ${a.st.stddev.toFixed(1)}, ${a.st.colours} colours; ` +
        `ellipsoid: mean ${e.st.mean.toFixed(1)} stddev ${e.st.stddev.toFixed(1)}, ${e.st.colours} colours`);
    check(a.st.width === W && a.st.stddev > MIN_STDDEV && a.st.colours > MIN_COLOURS,
        `the screenshot shows terrain (luma stddev ${a.st.stddev.toFixed(1)} > ${MIN_STDDEV}, ` +
        `${a.st.colours} colours > ${MIN_COLOURS})`);
    check(a.st.dark === 0 && e.st.dark === 0,
        `no crack: without Cesium's skirts no pixel shows the black background (${a.st.dark})`);
    check(e.st.stddev < MAX_FLAT_STDDEV,
        `the ellipsoid alone is flat (stddev ${e.st.stddev.toFixed(1)} < ${MAX_FLAT_STDDEV}): the relief is the tiles'`);
    const ln = await render(layerUrl, 'lit-normals', 'normals');
    const drawn = await ln.pg.evaluate(() => window.normalsDrawn());
    const lf = await render(layerUrl, 'lit-flat', 'flat');
    const asked = accepts.filter((a) => a.name === 'lit-normals');
    const askedNot = accepts.filter((a) => a.name === 'lit-flat');
    check(asked.length >= 4 && asked.every((a) => /extensions=[^,]*octvertexnormals/.test(a.accept)) &&
        askedNot.every((a) => !/octvertexnormals/.test(a.accept)),
        `with requestVertexNormals every tile request asks for octvertexnormals (${asked.length}), without none`,
        ...asked.slice(0, 2).map((a) => `Accept: ${a.accept}`));
    check(drawn.tiles > 0 && drawn.withNormals === drawn.tiles,
        `CesiumJS decoded the normals: ${drawn.withNormals} of the ${drawn.tiles} tiles drawn carry them`);
    note(`lit: with normals luma mean ${ln.st.mean.toFixed(1)} stddev ${ln.st.stddev.toFixed(1)}; ` +
        `without mean ${lf.st.mean.toFixed(1)} stddev ${lf.st.stddev.toFixed(1)}`);
    check(ln.st.stddev > MIN_LIT_STDDEV && lf.st.stddev < MAX_FLAT_STDDEV,
        `Cesium lights the globe through the tiles' normals: luma stddev ${ln.st.stddev.toFixed(1)} > ` +
        `${MIN_LIT_STDDEV}; without normals one shade (${lf.st.stddev.toFixed(1)} < ${MAX_FLAT_STDDEV})`);
    check(failedRequests.length === 0, 'no failed request', ...failedRequests.slice(0, 5));
    check(consoleErrors.length === 0, 'nothing logged to the console as an error', ...consoleErrors.slice(0, 5));
} catch (e) {
    fail('browser run', String(e && e.stack || e));
} finally {
    if (ctx) await ctx.close().catch(() => {});
    server.close();
    rmSync(scratch, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
