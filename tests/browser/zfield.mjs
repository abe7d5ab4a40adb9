// zfield.mjs - z-field simplification in the browser (client/web/zfield.js,
// zfield_gl.js) in headless Chromium with WebGL2 on SwiftShader, driven by
// playwright-core, against gigaviewd serving a height store.
//
//   node zfield.mjs --base http://127.0.0.1:PORT --id HEIGHT_ID
//        [--helper tests/zfield_states] [--chromium /usr/bin/chromium] [--out DIR]
//
// Checks, one a line as "PASS text" or "FAIL text" (details start with
// "#"; tests/browser_terrain.sh turns them into TAP):
//   1. the WebGL2 sweep (the shaders/zfield_*.glsl that gigaviewd serves)
//      on a 257 x 257 grid of the store (/region?format=png16) in the
//      vertical mode gives gigaviewd's own CPU mesh (GET /mesh?
//      method=zfield, lib/mesh/zfield.c) triangle for triangle: the same
//      vertices in the same order, the same triangles in the same order,
//      at two thresholds;
//   2. in the view-dependent mode (screen-space error in pixels) for
//      three cameras, the GPU's enabled states equal the CPU's: those of
//      lib/mesh/zfield.c itself through the helper tests/zfield_states
//      (--helper; without it the check says so and is skipped) and those
//      of zfieldEnableCpu (the float32 port of zfield.c's sweep); the
//      meshes differ between the cameras;
//   3. the terrain mode with `&refine=zfield` draws the refined mesh: the
//      mesh drawn equals the CPU's for the camera of that frame, and
//      orbiting (a drag) refines it again (more frames) with a different
//      triangle count; the `z` key goes back to the server's mesh; and
//      nothing was logged to the console as an error.
// Exit status 0 when everything passed, 1 otherwise, 2 on a usage error.
import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { execFileSync } from 'node:child_process';
import { launchChromium } from './chromium.mjs';
import { pass, fail, note, check, failed, parseArgs } from './report.mjs';

const W = 480, H = 320;
const GRID = { level: 0, x: 100, y: 50, side: 256 };   // inside a 720 x 361 store

const opt = { chromium: '/usr/bin/chromium', out: '', base: '', id: '', helper: '' };
parseArgs(opt, 'usage: node zfield.mjs --base URL --id ID [--helper PATH] [--out DIR] [--chromium PATH]', 'zfield.mjs', ['base', 'id']);
const base = opt.base.replace(/\/+$/, '');


const scratch = mkdtempSync(join(tmpdir(), 'gv-zfield-'));
const consoleErrors = [];
let ctx;

try {
    ctx = await launchChromium(join(scratch, 'profile'), opt.chromium, W, H);
    const pg = await ctx.newPage();
    pg.setDefaultTimeout(45000);
    pg.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(`${m.text()} (${m.location().url})`); });
    pg.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));

    // 1 and 2: the sweep alone, on the page's origin
    await pg.goto(`${base}/`);
    const r = await pg.evaluate(async ({ id, g }) => {
        const zf = await import(new URL('web/zfield.js', document.baseURI).href);
        const { parseGlb } = await import(new URL('web/terrain_gl.js', document.baseURI).href);
        const img = `v1/images/${encodeURIComponent(id)}`;
        const el = (await (await fetch(img)).json()).elevation;
        const n = g.side + 1;
        const pr = await fetch(`${img}/region?level=${g.level}&x=${g.x}&y=${g.y}&w=${n}&h=${n}&format=png16`);
        const png = await zf.decodePng16(await pr.arrayBuffer());
        const z = zf.heightsOf(png.codes, el.scale, el.offset);
        const gl = document.createElement('canvas').getContext('webgl2');
        const sweep = new zf.ZFieldSweep(gl, await zf.loadZfieldSources());
        sweep.heights(z, n);
        const out = { n, png: [png.width, png.height], range: [el.min, el.max], vertical: [], screen: [] };
        const same = (a, b) => a.length === b.length && a.every((v, i) => v === b[i]);
        for (const thr of [(el.max - el.min) / 500, (el.max - el.min) / 50]) {
            const t = Math.fround(thr);
            const en = sweep.enable({ mode: 'vertical', threshold: t });
            const m = zf.zfieldMesh(z, n, en);
            const url = `${img}/mesh?level=${g.level}&region=${g.x},${g.y},${g.side},${g.side}&method=zfield&max_error=${t}&format=glb`;
            const mr = await fetch(url);
            const cpu = parseGlb(await mr.arrayBuffer());
            // the server's vertices (x0 + vx, z, y0 + vy) and triangles
            // (a, c, b: glTF's winding) in gv_zfield_mesh's order
            const nv = cpu.pos.length / 3;
            let vok = nv === m.vx.length;
            for (let i = 0; vok && i < nv; i++)
                vok = cpu.pos[3 * i] === g.x + m.vx[i] && cpu.pos[3 * i + 2] === g.y + m.vy[i] &&
                    cpu.pos[3 * i + 1] === m.vz[i];
            const tris = [];
            for (let i = 0; i < cpu.idx.length; i += 3)
                tris.push(cpu.idx[i], cpu.idx[i + 2], cpu.idx[i + 1]);
            out.vertical.push({ thr: t, status: mr.status, gpuTris: m.tris.length / 3, cpuTris: cpu.idx.length / 3,
                gpuVerts: m.vx.length, cpuVerts: nv, sameVerts: vok, sameTris: same(tris, m.tris),
                sameAsJsCpu: same(en, zf.zfieldEnableCpu(z, n, { mode: 'vertical', threshold: t })) });
        }
        // view-dependent: three cameras over the grid (its frame: x, y
        // in samples, z in the store's units)
        const zr = el.max - el.min, k = zf.zfieldK(320, Math.PI / 4);
        const cams = [[50 * n, -100 * n, zr], [-50 * n, 50 * n, zr / 2], [50 * n, 50 * n, 3 * zr]];
        for (const eye of cams) {
            const p = { mode: 'screen', threshold: 1.5, eye: eye.map(Math.fround), k, xyScale: 100 };
            const en = sweep.enable(p), ref = zf.zfieldEnableCpu(z, n, p);
            let diff = 0, on = 0;
            for (let i = 0; i < en.length; i++) {
                diff += en[i] !== ref[i];
                on += en[i];
            }
            const t0 = performance.now();
            const tris = zf.zfieldMesh(z, n, sweep.enable(p)).tris.length / 3;
            out.screen.push({ p, enabled: on, diff, tris, ms: performance.now() - t0,
                en: Array.from(en) });
        }
        const zb = new Uint8Array(z.buffer);
        let s = '';
        for (let i = 0; i < zb.length; i += 8192)
            s += String.fromCharCode(...zb.subarray(i, i + 8192));
        out.z = btoa(s);
        return out;
    }, { id: opt.id, g: GRID });
    note(`grid ${r.n} x ${r.n} (png16 ${r.png.join('x')}), heights ${r.range.join('..')}`);
    for (const v of r.vertical) {
        note(`vertical ${v.thr}: GPU ${v.gpuTris} triangles ${v.gpuVerts} vertices, CPU (GET /mesh, HTTP ${v.status}) ${v.cpuTris} triangles ${v.cpuVerts} vertices`);
        check(v.status === 200 && v.gpuTris > 2 && v.gpuTris === v.cpuTris && v.sameVerts && v.sameTris,
            `vertical mode, threshold ${v.thr}: the WebGL2 mesh is gigaviewd's CPU mesh triangle for triangle (${v.gpuTris} triangles)`);
        check(v.sameAsJsCpu, `vertical mode, threshold ${v.thr}: the float32 CPU port decides the same states`);
    }
    const zbuf = Buffer.from(r.z, 'base64');
    for (const s of r.screen) {
        const p = s.p;
        note(`screen eye ${p.eye.map((x) => x.toFixed(0)).join(',')}: ${s.enabled} enabled, ${s.tris} triangles, ` +
            `${s.diff} states differ from the float32 port; sweep and mesh ${s.ms.toFixed(1)} ms`);
        if (opt.helper) {
            const c = execFileSync(opt.helper, [String(r.n), 'screen', String(p.threshold),
                ...p.eye.map(String), String(p.k), String(p.xyScale)], { input: zbuf, maxBuffer: 1 << 26 });
            let d = c.length === s.en.length ? 0 : -1;
            for (let i = 0; d >= 0 && i < c.length; i++)
                d += c[i] !== s.en[i];
            s.diffC = d;
            note(`  lib/mesh/zfield.c (${opt.helper}): ${d} states differ`);
        }
    }
    check(r.screen.every((s) => s.diff === 0 && s.enabled > 4),
        'view-dependent mode: the WebGL2 states equal the float32 CPU port\'s for three cameras');
    if (opt.helper)
        check(r.screen.every((s) => s.diffC === 0),
            'view-dependent mode: the WebGL2 states equal lib/mesh/zfield.c\'s for three cameras');
    else
        note('SKIP no --helper: the view-dependent states are not compared with lib/mesh/zfield.c');
    check(new Set(r.screen.map((s) => s.tris)).size === 3,
        `view-dependent mode: the cameras give different meshes (${r.screen.map((s) => s.tris).join(', ')} triangles)`);

    // 3. the terrain mode
    await pg.goto(`${base}/#image=${encodeURIComponent(opt.id)}&terrain=hillshade&refine=zfield`);
    await pg.evaluate(() => window.gigaview.ready);
    await pg.waitForFunction(() => window.gigaview.terrain.active);
    const ready = () => pg.evaluate(() => window.gigaview.terrain.ready());
    // the mesh drawn against the CPU's for the current camera
    const drawnVsCpu = () => pg.evaluate(async () => {
        const t = window.gigaview.terrain, zf = await import(new URL('web/zfield.js', document.baseURI).href);
        const g = t.zf.grid, p = t.zf.params(t.az, t.el, t.dist);
        const m = zf.zfieldMesh(g.z, g.n, zf.zfieldEnableCpu(g.z, g.n, p));
        const d = t.zf.mesh.tris;
        return { same: d.length === m.tris.length && d.every((v, i) => v === m.tris[i]),
            triangles: t.info.triangles, frames: t.info.frames, method: t.info.method, url: t.info.url,
            n: g.n, az: t.az, el: t.el };
    });
    const i1 = await ready();
    const a = await drawnVsCpu();
    note(`refine=zfield: grid ${a.n} from ${a.url && a.url.replace(base, '')}, ${a.triangles} triangles after ${a.frames} frames`);
    check(i1 && a.method === 'zfield' && /format=png16/.test(a.url) && a.frames >= 1 && a.triangles > 100 && a.same,
        `&refine=zfield draws the view-dependent mesh (${a.triangles} triangles), the CPU's for that camera`);
    if (opt.out) {
        mkdirSync(opt.out, { recursive: true });
        writeFileSync(join(opt.out, 'terrain-zfield.png'), await pg.screenshot());
    }
    await pg.mouse.move(W / 2, H / 2);
    await pg.mouse.down();
    await pg.mouse.move(W / 2 + 150, H / 2 + 60, { steps: 3 });
    await pg.mouse.up();
    const b = await drawnVsCpu();
    note(`after orbiting to azimuth ${b.az.toFixed(0)}, elevation ${b.el.toFixed(0)}: ${b.triangles} triangles after ${b.frames} frames`);
    check(b.frames > a.frames && b.triangles !== a.triangles && b.same,
        `orbiting refines per frame (${b.frames - a.frames} frames): ${a.triangles} -> ${b.triangles} triangles, the CPU's`);
    await pg.keyboard.press('z');
    await pg.waitForFunction(() => !window.gigaview.terrain.refine);
    const i3 = await ready();
    check(i3 && i3.method !== 'zfield' && /\/mesh\?/.test(i3.url),
        `the z key goes back to the server's mesh (${i3 && i3.triangles} triangles)`);
    check(consoleErrors.length === 0, 'nothing logged to the console as an error', ...consoleErrors.slice(0, 5));
} catch (e) {
    fail('browser run', String(e && e.stack || e), ...consoleErrors.slice(0, 5));
} finally {
    if (ctx) await ctx.close().catch(() => {});
    rmSync(scratch, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
