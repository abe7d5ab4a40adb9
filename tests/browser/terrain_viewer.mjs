// terrain_viewer.mjs - the browser viewer's 3D terrain mode
// (client/web/terrain.js, terrain_gl.js) in headless Chromium with WebGL2
// on SwiftShader, driven by playwright-core.
//
//   node terrain_viewer.mjs --base http://127.0.0.1:PORT --id HEIGHT_ID
//        --drape IMAGE_ID [--chromium /usr/bin/chromium] [--out DIR]
//
// Checks, one a line as "PASS text" or "FAIL text" (details start with
// "#"; tests/browser_terrain.sh turns them into TAP):
//   1. `#image=ID&terrain=hillshade` opens the 3D view: it fetched a GLB
//      mesh of the view's region from /mesh and drew it, the 3D canvas is
//      shown, and the picture is not flat: the luma of the canvas has a
//      standard deviation above MIN_STDDEV and more than MIN_GRAYS levels
//      (a hillshade of real relief; a flat mesh would be one gray);
//   2. orbiting (a mouse drag on the 3D canvas) changes the picture: mean
//      absolute difference above MIN_ORBIT_MAD against the first one;
//   3. zooming in (the wheel on the 3D canvas zooms the 2D view) refines
//      the mesh: once the view rests it is fetched again at a finer level
//      for a smaller region;
//   4. `&terrain=IMAGE_ID` drapes that image store: its region endpoint is
//      fetched and the mesh has colour (mean |R-G| + |G-B| over its
//      pixels above MIN_CHROMA, where the hillshade is gray: below 0.5);
//   5. the `t` key leaves the mode (the hash loses `terrain`), and nothing
//      was logged to the console as an error.
// Exit status 0 when everything passed, 1 otherwise, 2 on a usage error.
import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launchChromium } from './chromium.mjs';
import { pass, fail, note, check, failed, parseArgs } from './report.mjs';

const MIN_STDDEV = 20;       // luma, 8-bit units
const MIN_GRAYS = 40;        // distinct luma values
const MIN_ORBIT_MAD = 8;     // 8-bit units, per pixel, RGB mean
const MIN_CHROMA = 5;        // 8-bit units, over the mesh's pixels
const W = 480, H = 320;

const opt = { chromium: '/usr/bin/chromium', out: '', base: '', id: '', drape: '' };
parseArgs(opt, 'usage: node terrain_viewer.mjs --base URL --id ID --drape ID [--out DIR] [--chromium PATH]', 'terrain_viewer.mjs', ['base', 'id', 'drape']);
const base = opt.base.replace(/\/+$/, '');

const t0 = Date.now();
const lap = (t) => note(`time: ${t} at ${Date.now() - t0} ms`);

const scratch = mkdtempSync(join(tmpdir(), 'gv-terrain-'));
const consoleErrors = [], requests = [];
let ctx;

// The 3D canvas's pixels (RGBA) and statistics.
const grab = (pg) => pg.evaluate(() => {
    const src = document.getElementById('terrain');
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const g = c.getContext('2d');
    g.drawImage(src, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    let s = 0, s2 = 0, chroma = 0, drawn = 0;
    const grays = new Set();
    for (let i = 0; i < d.length; i += 4) {
        const y = 0.299 * d[i] + 0.587 * d[i + 1] + 0.114 * d[i + 2];
        s += y; s2 += y * y;
        grays.add(Math.round(y));
        // colour, over the pixels of the mesh (not the background, 8,8,8)
        if (Math.abs(d[i] - 8) + Math.abs(d[i + 1] - 8) + Math.abs(d[i + 2] - 8) > 6) {
            chroma += Math.abs(d[i] - d[i + 1]) + Math.abs(d[i + 1] - d[i + 2]);
            drawn++;
        }
    }
    const n = d.length / 4, mean = s / n;
    return { px: Array.from(d), mean, stddev: Math.sqrt(Math.max(0, s2 / n - mean * mean)),
        grays: grays.size, chroma: chroma / Math.max(1, drawn), drawn: drawn / n, w: c.width, h: c.height };
});
const mad = (a, b) => {
    let s = 0, n = 0;
    for (let i = 0; i < a.length; i += 4) {
        s += Math.abs(a[i] - b[i]) + Math.abs(a[i + 1] - b[i + 1]) + Math.abs(a[i + 2] - b[i + 2]);
        n += 3;
    }
    return s / n;
};
async function shot(pg, name) {
    if (!opt.out)
        return;
    mkdirSync(opt.out, { recursive: true });
    writeFileSync(join(opt.out, `${name}.png`), await pg.screenshot());
}
const ready = (pg) => pg.evaluate(() => window.gigaview.terrain.ready());

try {
    ctx = await launchChromium(join(scratch, 'profile'), opt.chromium, W, H);
    const pg = await ctx.newPage();
    pg.setDefaultTimeout(45000);
    pg.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(`${m.text()} (${m.location().url})`); });
    pg.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
    pg.on('request', (r) => requests.push(r.url()));

    // 1. hillshade
    await pg.goto(`${base}/#image=${encodeURIComponent(opt.id)}&terrain=hillshade`);
    await pg.evaluate(() => window.gigaview.ready);
    const info1 = await ready(pg);
    const shown = await pg.evaluate(() => !document.getElementById('terrain').hidden);
    const a = await grab(pg);
    await shot(pg, 'terrain-hillshade');
    note(`mesh ${info1 && info1.url.replace(base, '')}: ${info1 && info1.triangles} triangles`);
    note(`hillshade: luma mean ${a.mean.toFixed(1)} stddev ${a.stddev.toFixed(1)}, ${a.grays} grays, chroma ${a.chroma.toFixed(2)}`);
    check(shown && info1 && info1.triangles > 100 && /\/mesh\?.*format=glb/.test(info1.url),
        `terrain mode fetched a GLB mesh of the view (${info1 && info1.triangles} triangles) and shows the 3D canvas`);
    check(a.w === W && a.stddev > MIN_STDDEV && a.grays > MIN_GRAYS,
        `the hillshade is not flat (luma stddev ${a.stddev.toFixed(1)} > ${MIN_STDDEV}, ${a.grays} grays > ${MIN_GRAYS})`);

    lap('orbit');
    // 2. orbit by a drag
    await pg.mouse.move(W / 2, H / 2);
    await pg.mouse.down();
    await pg.mouse.move(W / 2 + 150, H / 2 + 40, { steps: 2 });
    await pg.mouse.up();
    const orb = await pg.evaluate(() => ({ az: window.gigaview.terrain.az, el: window.gigaview.terrain.el }));
    const b = await grab(pg);
    await shot(pg, 'terrain-orbit');
    const m = mad(a.px, b.px);
    check(Math.abs(orb.az) > 10 && m > MIN_ORBIT_MAD,
        `a drag orbits (azimuth ${orb.az.toFixed(0)}, elevation ${orb.el.toFixed(0)}): the picture changes (MAD ${m.toFixed(1)} > ${MIN_ORBIT_MAD})`);

    lap('zoom');
    // 3. the wheel zooms the view in: a finer mesh of a smaller region
    for (let i = 0; i < 8; i++)
        await pg.mouse.wheel(0, -100);
    await pg.waitForFunction((l) => {
        const t = window.gigaview.terrain;
        return t.info && t.info.level < l && !t.busy;
    }, info1.level, { polling: 100 });
    const info2 = await ready(pg);
    note(`after zooming: ${info2.url.replace(base, '')}`);
    check(info2.level < info1.level && info2.region[2] * 2 ** info2.level < info1.region[2] * 2 ** info1.level,
        `zooming in refines the mesh: level ${info1.level} -> ${info2.level}, ` +
        `region ${info1.region.join(',')} -> ${info2.region.join(',')}`);

    lap('drape');
    // 4. drape an image store
    await pg.evaluate((d) => { location.hash = location.hash.replace(/terrain=[^&]*/, `terrain=${d}`); }, opt.drape);
    await pg.waitForFunction((d) => window.gigaview.terrain.source === d, opt.drape);
    const info3 = await ready(pg);
    const c = await grab(pg);
    await shot(pg, 'terrain-drape');
    note(`drape: ${info3.drape && info3.drape.replace(base, '')}, chroma ${c.chroma.toFixed(1)} over ${(100 * c.drawn).toFixed(0)}% of the canvas`);
    check(info3.drape && info3.drape.includes(`/v1/images/${opt.drape}/region?`) && c.chroma > MIN_CHROMA && a.chroma < 0.5,
        `&terrain=${opt.drape} drapes that image (chroma ${c.chroma.toFixed(1)} > ${MIN_CHROMA}; hillshade ${a.chroma.toFixed(2)})`);

    lap('leave');
    // 5. leave
    await pg.keyboard.press('t');
    await pg.waitForFunction(() => !window.gigaview.terrain.active && document.getElementById('terrain').hidden);
    await pg.waitForFunction(() => !location.hash.includes('terrain='));
    pass('the t key leaves the 3D mode, and the link follows');
    check(consoleErrors.length === 0, 'nothing logged to the console as an error', ...consoleErrors.slice(0, 5));
} catch (e) {
    fail('browser run', String(e && e.stack || e));
} finally {
    if (ctx) await ctx.close().catch(() => {});
    rmSync(scratch, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
