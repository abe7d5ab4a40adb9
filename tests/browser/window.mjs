// window.mjs - the display window in the browser viewer (client/web/,
// window.js, window_panel.js, display.frag.glsl), run by
// tests/browser_window.sh against a gigaviewd serving "picos" (a colour
// photograph) and "gray" (a gray store):
//   1. a link with window= opens with that window, and the canvas at a 1:1
//      view of level 0 equals the server's region with the same window,
//      bit for bit (every pixel identical: at 1:1 the display shader's
//      bilinear weights are 0 and 1, so no tolerance is needed);
//   2. changing the window (per channel, then through the panel's auto
//      button) makes no request at all, and the canvas again equals the
//      server's windowed region bit for bit;
//   3. the hash carries the window, and a new page opened at that hash
//      shows the same pixels;
//   4. a gray store likewise (one table for its one channel);
//   5. negative control: the display tables with red shifted by one must
//      FAIL the match (so the comparison can see a wrong table);
//   6. "dflt" (picos encoded with `gigaview encode --window`): a link with
//      no window opens with the store's default, its first frame equal to
//      the server's region with that window (and to the plain store's
//      region with it); a link with window=none opens with no window, the
//      canvas equal to the plain region, and the hash keeps window=none;
//   7. "s16" (a 16-bit RGB sample store, drawn from its codes on the GPU:
//      codes_decode.js, looks.js, display_codes.frag.glsl): a link's window
//      on its 16-bit codes opens with it, the canvas at 1:1 equal to the
//      server's region with that window bit for bit; a new window (per
//      channel) and new colours make no request at all and match too; the
//      panel's sliders reach 65535; colours from the link and from the
//      panel's colour inputs equal the server's region with them, and the
//      hash carries them; the store's default window and the codes' range
//      (window=none) likewise, and a five-channel store ("c5"); without WebGL2 (renderer=region) the
//      server's regions carry the window, fetched again when it changes,
//      and equal the same region; a height store ("dem") likewise, its
//      window on the server's gray of its codes; negative control: tables for a black
//      point one code off must fail the match;
//   8. no console errors.
// Exit status 0 when everything passed, 1 otherwise.
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launchChromium, PATIENCE_MS } from './chromium.mjs';
import { check, fail, failed, note, parseArgs } from './report.mjs';

const W = 800, H = 500;
const opt = { chromium: '/usr/bin/chromium', base: '' };
parseArgs(opt, 'usage: node window.mjs --base URL [--chromium PATH]', 'window.mjs', ['base']);
const base = opt.base.replace(/\/+$/, '');
const consoleErrors = [];

async function newPage(c) {
    const pg = await c.newPage();
    pg.setDefaultTimeout(60000);
    pg.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    pg.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
    return pg;
}

async function open(pg, h) {
    await pg.goto(`${base}/${h}`);
    await pg.evaluate(() => window.gigaview.ready);
    const id = new URLSearchParams(h.slice(h.indexOf('#') + 1)).get('image');
    await pg.waitForFunction((id) => window.gigaview.viewer.image && window.gigaview.viewer.image.id === id &&
        window.gigaview.viewer.view, id);
    return pg.evaluate(() => window.gigaview.viewer.settled());
}

// The canvas against the region (level 0, x, y, W x H) with window text
// win: {n, same, max}; win null: the region with no window asked (the
// store's default, if any).  lut: display tables to force (negative control).
function compare(pg, id, x, y, win, lut = null, extra = '') {
    const url = `${base}/v1/images/${id}/region?level=0&x=${x}&y=${y}&w=${W}&h=${H}&format=png` +
        (win === null ? '' : `&window=${encodeURIComponent(win)}`) + extra;
    return pg.evaluate(async ({ url, W, H, lut }) => {
        const v = window.gigaview.viewer;
        if (lut) v.backend.setLut(new Uint8Array(lut));
        const a = v.snapshot();
        const r = await fetch(url);
        if (!r.ok) return { error: `${url}: HTTP ${r.status}` };
        const b = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
        const c = new OffscreenCanvas(b.width, b.height);
        const g = c.getContext('2d', { willReadFrequently: true });
        g.drawImage(b, 0, 0);
        const ref = g.getImageData(0, 0, W, H).data;
        let same = 0, max = 0;
        for (let i = 0; i < W * H; i++) {
            let eq = true;
            for (let k = 0; k < 3; k++) {
                const d = Math.abs(a[4 * i + k] - ref[4 * i + k]);
                if (d) eq = false;
                if (d > max) max = d;
            }
            same += eq;
        }
        return { n: W * H, same, max };
    }, { url, W, H, lut });
}

async function match(pg, label, id, x, y, win, extra = '') {
    const r = await compare(pg, id, x, y, win, null, extra);
    if (r.error) return fail(`${label}`, r.error);
    check(r.same === r.n, `${label}: the canvas equals ${win === null ? 'the region with no window asked' : `region&window=${win}`}${extra} bit for bit (${r.same}/${r.n} pixels identical)`,
        `${r.same}/${r.n} pixels identical, largest difference ${r.max}`);
}

// Requests the page makes while fn runs and the picture settles.
async function requestsDuring(pg, fn) {
    const seen = [];
    const on = (r) => seen.push(r.url());
    pg.on('request', on);
    await fn();
    await pg.evaluate(() => new Promise((res) => requestAnimationFrame(() => requestAnimationFrame(res))));
    await pg.evaluate(() => window.gigaview.viewer.settled());
    pg.off('request', on);
    return seen;
}

async function run(c) {
    const pg = await newPage(c);
    // 1. picos, level 0 at 1:1 centred on (550, 350): canvas (i, j) is (150 + i, 100 + j).
    const r0 = await open(pg, '#image=picos&x=550&y=350&z=0&r=0&window=30,200,0.7');
    check(r0.complete && r0.level === 0, 'picos opens complete at level 0 with a window from the link', JSON.stringify(r0));
    const w0 = await pg.evaluate(() => window.gigaview.viewer.extra.window);
    check(w0 === '30,200,0.700', `the link's window is set (${w0})`, String(w0));
    await match(pg, 'picos level 0 1:1, window 30,200,0.7', 'picos', 150, 100, '30,200,0.7');

    // 2. per-channel window, then auto: no request at all.
    const per = '10,250,1;50,150,0.5;0,100,3.333';
    const reqs = await requestsDuring(pg, () => pg.evaluate((t) => {
        const g = window.gigaview;
        g.viewer.setWindow(t.split(';').map((s) => {
            const [b, w, gm] = s.split(',');
            return { black: +b, white: +w, gammaMilli: Math.round(+gm * 1000) };
        }));
    }, per));
    check(reqs.length === 0, `changing the window makes no request (${reqs.length})`, reqs.slice(0, 5).join(' '));
    await match(pg, 'picos level 0 1:1, per-channel window', 'picos', 150, 100, per);
    await pg.click('#window-btn');
    await pg.click('#w-linked');             // one set of sliders per channel
    const reqs2 = await requestsDuring(pg, () => pg.click('#w-auto'));
    const auto = await pg.evaluate(() => window.gigaview.viewer.extra.window);
    check(reqs2.length === 0 && /^[0-9]+,[0-9]+,1\.000;/.test(auto || ''),
        `the auto button sets a window per channel from the root's histogram (${auto}) without a request (${reqs2.length})`,
        `window ${auto}, requests ${reqs2.join(' ')}`);
    await match(pg, 'picos level 0 1:1, auto window', 'picos', 150, 100, auto);
    const sliders = await pg.locator('#w-channels input[type=range]').count();
    check(sliders === 9, `the panel shows black, white and gamma for each of the 3 channels (${sliders} sliders)`);
    // Moving a slider changes the window (no request either).
    const reqs3 = await requestsDuring(pg, () => pg.locator('#w-channels input[type=range]').nth(2).fill('500'));
    const slid = await pg.evaluate(() => window.gigaview.viewer.extra.window);
    check(reqs3.length === 0 && slid && slid.split(';')[0].endsWith(',3.162'),
        `the red gamma slider sets gamma 3.162 (${slid}) without a request`, `${slid}; ${reqs3.join(' ')}`);
    await match(pg, 'picos level 0 1:1, after the slider', 'picos', 150, 100, slid);

    // 3. the hash carries the window; a new page at that hash shows the same.
    await pg.waitForFunction((w) => decodeURIComponent(location.hash).includes(`window=${w}`), slid, { timeout: PATIENCE_MS })
        .catch(() => {});
    const hash = await pg.evaluate(() => location.hash);
    check(new URLSearchParams(hash.slice(1)).get('window') === slid, `the hash carries the window (${hash})`, hash);
    const pg2 = await newPage(c);
    await open(pg2, hash);
    await match(pg2, 'a new page at that hash', 'picos', 150, 100, slid);
    await pg2.close();

    // 4. a gray store.
    await open(pg, '#image=gray&x=550&y=350&z=0&r=0&window=20,180,1.8');
    await match(pg, 'gray level 0 1:1, window 20,180,1.8', 'gray', 150, 100, '20,180,1.8');

    // 5. negative control: red's table shifted by one must fail the match.
    const bad = await pg.evaluate(() => {
        const t = new Uint8Array(1024);
        for (let v = 0; v < 256; v++) {
            const y = Math.min(255, Math.max(0, Math.floor(255 * ((v - 20) / 160) ** (1 / 1.8) + 0.500000001)));
            t.set([Math.min(255, (v <= 20 ? 0 : v >= 180 ? 255 : y) + 1), 0, 0, 255], 4 * v);
        }
        return Array.from(t);
    });
    const r5 = await compare(pg, 'gray', 150, 100, '20,180,1.8', bad);
    check(r5.same < r5.n, `negative control: a table off by one fails the match (${r5.same}/${r5.n} pixels identical)`,
        JSON.stringify(r5));

    // 6. the store's default window, and window=none.
    const D = '30,200,0.7', DF = '30,200,0.700';
    const pg3 = await newPage(c);
    const r6 = await open(pg3, '#image=dflt&x=550&y=350&z=0&r=0');
    const w6 = await pg3.evaluate(() => window.gigaview.viewer.extra.window);
    check(r6.complete && w6 === DF, `a link with no window opens with the store's default (${w6})`, `${w6} ${JSON.stringify(r6)}`);
    await match(pg3, 'dflt level 0 1:1, the first frame against the server\'s region', 'dflt', 150, 100, null);
    await match(pg3, 'dflt level 0 1:1, against picos with the same window', 'picos', 150, 100, D);
    await pg3.close();
    const pg4 = await newPage(c);
    const r7 = await open(pg4, '#image=dflt&x=550&y=350&z=0&r=0&window=none');
    const w7 = await pg4.evaluate(() => [window.gigaview.viewer.window, window.gigaview.viewer.extra.window]);
    check(r7.complete && w7[0] === null && w7[1] === 'none', `window=none opens with no window (${JSON.stringify(w7)})`,
        `${JSON.stringify(w7)} ${JSON.stringify(r7)}`);
    await match(pg4, 'dflt level 0 1:1 with window=none', 'dflt', 150, 100, 'none');
    await pg4.waitForFunction(() => location.hash.includes('window=none'), null, { timeout: PATIENCE_MS }).catch(() => {});
    const h7 = await pg4.evaluate(() => location.hash);
    check(new URLSearchParams(h7.slice(1)).get('window') === 'none', `the hash keeps window=none (${h7})`, h7);
    await pg4.close();

    // 7. a sample store: windows on 16-bit codes, drawn on the GPU.
    const pg5 = await newPage(c);
    const S1 = '5000,60000,0.8';
    const r8 = await open(pg5, `#image=s16&x=550&y=350&z=0&r=0&window=${S1}`);
    const k8 = await pg5.evaluate(() => [window.gigaview.viewer.backend.kind, window.gigaview.viewer.extra.window]);
    check(r8.complete && k8[0] === 'webgl2' && k8[1] === '5000,60000,0.800',
        `a sample store opens in WebGL2 with the link's 16-bit window (${JSON.stringify(k8)})`,
        `${JSON.stringify(k8)} ${JSON.stringify(r8)}`);
    await match(pg5, `s16 level 0 1:1, window ${S1}`, 's16', 150, 100, S1);
    const S2 = '0,30000,1;20000,65535,2;1000,40000,0.5';
    const reqs8 = await requestsDuring(pg5, () => pg5.evaluate((t) => {
        window.gigaview.viewer.setWindow(t.split(';').map((s) => {
            const [b, w, gm] = s.split(',');
            return { black: +b, white: +w, gammaMilli: Math.round(+gm * 1000) };
        }));
    }, S2));
    check(reqs8.length === 0, `a new window on the codes makes no request (${reqs8.length})`, reqs8.slice(0, 4).join(' '));
    await match(pg5, 's16 level 0 1:1, a window per channel', 's16', 150, 100, S2);
    // Negative control: the GPU's tables for a black point one code off
    // must fail the match with the server's window.
    await pg5.evaluate(() => window.gigaview.viewer.backend.setDisplay('5001,60000,0.8', null));
    const off = await compare(pg5, 's16', 150, 100, S1);
    check(!off.error && off.same < off.n, `negative control: a black point one code off differs from the server's region (${off.n - off.same} pixels)`,
        JSON.stringify(off));
    await pg5.click('#window-btn');
    const maxes = await pg5.locator('#w-channels input[type=range]').evaluateAll((l) => l.map((e) => e.max));
    check(maxes.includes('65535'), `the sliders reach 65535 (${maxes.join(',')})`, maxes.join(','));
    // The codes' range (window=none) and a zoomed-out level, drawn alike.
    const reqsNone = await requestsDuring(pg5, () => pg5.evaluate(() => window.gigaview.viewer.setWindow(null, true)));
    check(reqsNone.length === 0, `window=none makes no request (${reqsNone.length})`, reqsNone.slice(0, 4).join(' '));
    await match(pg5, 's16 level 0 1:1, window=none (the codes\' range)', 's16', 150, 100, 'none');
    await pg5.close();
    // Colours: from the link, then a colour input; the hash carries them.
    const pg6 = await newPage(c);
    const C1 = '0000ff;00ff00;ff8000';
    const r9 = await open(pg6, `#image=s16&x=550&y=350&z=0&r=0&window=${S1}&colours=${encodeURIComponent(C1)}`);
    const k9 = await pg6.evaluate(() => window.gigaview.viewer.colours);
    check(r9.complete && k9 === C1, `the link's colours are set (${k9})`, `${k9} ${JSON.stringify(r9)}`);
    await match(pg6, 's16 level 0 1:1, the link\'s colours', 's16', 150, 100, S1, `&colours=${encodeURIComponent(C1)}`);
    await pg6.click('#window-btn');
    await pg6.click('#w-linked');            // one set per channel, with its colour
    const nColour = await pg6.locator('#w-channels input[type=color]').count();
    check(nColour === 3, `the panel shows a colour for each of the 3 channels (${nColour})`);
    const reqs10 = await requestsDuring(pg6, () => pg6.locator('#w-channels input[type=color]').nth(1).fill('#ff00ff'));
    const C2 = '0000ff;ff00ff;ff8000';
    const k10 = await pg6.evaluate(() => window.gigaview.viewer.colours);
    check(k10 === C2 && reqs10.length === 0,
        `the colour input sets the second channel's colour (${k10}) without a request (${reqs10.length})`,
        `${k10}; ${reqs10.slice(0, 4).join(' ')}`);
    const w10 = await pg6.evaluate(() => window.gigaview.viewer.extra.window);
    await match(pg6, 's16 level 0 1:1, after the colour input', 's16', 150, 100, w10, `&colours=${encodeURIComponent(C2)}`);
    await pg6.waitForFunction((t) => decodeURIComponent(location.hash).includes(`colours=${t}`), C2, { timeout: PATIENCE_MS })
        .catch(() => {});
    const h10 = await pg6.evaluate(() => location.hash);
    check(new URLSearchParams(h10.slice(1)).get('colours') === C2, `the hash carries the colours (${h10})`, h10);
    await pg6.close();
    // A store's default window and colours (gigaview encode --window
    // --colours), with no window in the link: the GPU's first frame is the
    // server's default region.
    const pg7 = await newPage(c);
    const r11 = await open(pg7, '#image=s16d&x=550&y=350&z=0&r=0');
    const k11 = await pg7.evaluate(() => [window.gigaview.viewer.backend.kind, window.gigaview.viewer.extra.window]);
    check(r11.complete && k11[0] === 'webgl2' && k11[1] === '2000,50000,1.500',
        `a sample store with a default window opens in WebGL2 with it (${JSON.stringify(k11)})`, JSON.stringify(k11));
    await match(pg7, 's16d level 0 1:1, the store\'s window and colours', 's16d', 150, 100, null);
    await pg7.close();
    // Five channels, a window and a colour each.
    const pg9 = await newPage(c);
    const S5 = '7000,60000,1;10000,50000,0.6;5000,65535,2;0,40000,1;20000,62000,1.3';
    const C5 = 'ff0000;00ff00;0000ff;ffff00;808080';
    const r13 = await open(pg9, `#image=c5&x=550&y=350&z=0&r=0&window=${encodeURIComponent(S5)}&colours=${encodeURIComponent(C5)}`);
    const k13 = await pg9.evaluate(() => window.gigaview.viewer.backend.kind);
    check(r13.complete && k13 === 'webgl2', `a five-channel sample store opens in WebGL2 (${k13})`, JSON.stringify(r13));
    await match(pg9, 'c5 level 0 1:1, five windows and colours', 'c5', 150, 100, S5, `&colours=${encodeURIComponent(C5)}`);
    // The overview is the server's 8-bit picture of the root (not codes
    // clamped to white): compare it with the root region it was made from.
    const mini = await pg9.evaluate(async () => {
        const v = window.gigaview.viewer, info = v.image.info, pic = v.image.root.picture;
        const r = await fetch(`${v.image.url}/region?level=${info.root.level}&x=0&y=0&w=${info.root.width}&h=${info.root.height}&format=png`);
        const b = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
        const cv = new OffscreenCanvas(b.width, b.height), g = cv.getContext('2d');
        g.drawImage(b, 0, 0);
        const ref = g.getImageData(0, 0, b.width, b.height).data;
        let same = 0;
        for (let i = 0; i < b.width * b.height; i++)
            same += pic[3 * i] === ref[4 * i] && pic[3 * i + 1] === ref[4 * i + 1] && pic[3 * i + 2] === ref[4 * i + 2];
        return { same, n: b.width * b.height, len: pic.length, hidden: document.getElementById('mini').hidden };
    });
    check(mini.same === mini.n && mini.len === 3 * mini.n && !mini.hidden,
        `the overview of a five-channel store is its root's 8-bit picture (${mini.same}/${mini.n} pixels)`, JSON.stringify(mini));
    await pg9.click('#window-btn');
    const reqs16 = await requestsDuring(pg9, () => pg9.click('#w-auto'));
    const auto16 = await pg9.evaluate(() => window.gigaview.viewer.extra.window);
    check(reqs16.length === 0 && !!auto16, `auto on a sample store reads the codes it holds, without a request (${auto16}; ${reqs16.length})`,
        reqs16.join(' '));
    await match(pg9, 'c5 level 0 1:1, auto window', 'c5', 150, 100, auto16, `&colours=${encodeURIComponent(C5)}`);
    await pg9.close();
    // A height store: its codes on the GPU, the server's gray through an
    // 8-bit window.
    const pg10 = await newPage(c);
    const r14 = await open(pg10, '#image=dem&x=550&y=350&z=0&r=0');
    const k14 = await pg10.evaluate(() => window.gigaview.viewer.backend.kind);
    check(r14.complete && k14 === 'webgl2', `a height store opens in WebGL2 (${k14})`, JSON.stringify(r14));
    await match(pg10, 'dem level 0 1:1, no window (the server\'s gray)', 'dem', 150, 100, null);
    const reqs14 = await requestsDuring(pg10, () => pg10.evaluate(() =>
        window.gigaview.viewer.setWindow([{ black: 40, white: 200, gammaMilli: 700 }])));
    check(reqs14.length === 0, `a window on a height store makes no request (${reqs14.length})`, reqs14.slice(0, 4).join(' '));
    await match(pg10, 'dem level 0 1:1, window 40,200,0.7 on its gray', 'dem', 150, 100, '40,200,0.7');
    await pg10.click('#window-btn');
    const reqs15 = await requestsDuring(pg10, () => pg10.click('#w-auto'));
    const auto15 = await pg10.evaluate(() => window.gigaview.viewer.extra.window);
    check(reqs15.length === 0 && /^[0-9]+,[0-9]+,0\.700$/.test(auto15 || '') && auto15 !== '0,255,0.700',
        `auto on a height store sets black and white from its gray root (${auto15}) without a request (${reqs15.length})`,
        `${auto15}; ${reqs15.join(' ')}`);
    await match(pg10, 'dem level 0 1:1, auto window', 'dem', 150, 100, auto15);
    await pg10.close();
    // A slide's scale bar in microns (metadata slide.mpp_x 0.2527): at a
    // 1:1 view about 100 CSS px, a round 20 or 25 µm.
    const slide = await fetch(`${base}/v1/images/slide`);
    if (slide.ok) {
        const pg11 = await newPage(c);
        await open(pg11, '#image=slide&x=750&y=550&z=0&r=0');
        const bar = await pg11.evaluate(() => [document.getElementById('scale-text').textContent,
            parseFloat(document.getElementById('scale').style.width)]);
        check(bar[0] === '20 µm' && Math.abs(bar[1] - 20 / 0.2527) < 0.1,
            `a slide's scale bar is in microns at 1:1 (${bar[0]} over ${bar[1]} px)`, JSON.stringify(bar));
        await pg11.evaluate(() => window.gigaview.viewer.setView({ ...window.gigaview.viewer.view, zoom: 3 }));
        await pg11.evaluate(() => window.gigaview.viewer.settled());
        const bar3 = await pg11.evaluate(() => document.getElementById('scale-text').textContent);
        check(bar3 === '200 µm', `... and at zoom 3 (${bar3})`, bar3);
        await pg11.close();
    } else {
        note('no slide store (built without OpenSlide): the microns scale bar is not checked');
    }
    // Without WebGL2: the server's regions, fetched again for a new window.
    const pg8 = await newPage(c);
    const r12 = await open(pg8, `?renderer=region#image=s16&x=550&y=350&z=0&r=0&window=${S1}`);
    const k12 = await pg8.evaluate(() => window.gigaview.viewer.backend.kind);
    check(r12.complete && k12 === 'region', `renderer=region draws a sample store from the server's regions (${k12})`, k12);
    const reqs12 = await requestsDuring(pg8, () => pg8.evaluate((t) => {
        window.gigaview.viewer.setWindow(t.split(';').map((s) => {
            const [b, w, gm] = s.split(',');
            return { black: +b, white: +w, gammaMilli: Math.round(+gm * 1000) };
        }));
    }, S2));
    check(reqs12.some((u) => u.includes('/region?') && u.includes('window=')),
        `there a new window fetches the view again with it (${reqs12.length} requests)`, reqs12.slice(0, 4).join(' '));
    await match(pg8, 's16 level 0 1:1 from regions, a window per channel', 's16', 150, 100, S2);
    await pg8.close();

    check(consoleErrors.length === 0, 'no console errors', consoleErrors.join('\n'));
}

const profile = mkdtempSync(join(tmpdir(), 'gv-window-'));
const c = await launchChromium(profile, opt.chromium, W, H);
try {
    await run(c);
} catch (e) {
    fail('window.mjs ran', e.stack || String(e));
} finally {
    await c.close();
    rmSync(profile, { recursive: true, force: true });
}
note(`${failed} failed`);
process.exit(failed ? 1 : 0);
