// main.js - the viewer page (served by gigaviewd at /): the image list,
// the URL hash as the source of truth for what is shown, and the wiring
// of viewer, input and overlays.
//
// Query options (not part of a shared link): renderer=webgl2|region
// (default: WebGL2 where the browser has it, else the server's region
// endpoint), cache=MiB of decoded tiles (default 256), workers=N (tile
// preparation threads, default 2; 0: the main thread), prefetch=0 (no
// prefetching around the view: for measurements).
//
// window.gigaview exposes the viewer to the console, tests and benchmarks.

import { AuthDialog, obtainAccess } from './auth.js';
import { FilterPanel } from './filter_panel.js';
import { attachInput } from './input.js';
import { Overlay } from './overlay.js';
import { formatHash, imageToScreen, parseHash, screenToImage } from './view.js';
import { FilterRunner } from './roi_filter.js';
import { TerrainMode } from './terrain.js';
import { Viewer } from './viewer.js';
import { formatWindow, parseWindow } from './window.js';
import { WindowPanel } from './window_panel.js';

const $ = (id) => document.getElementById(id);
const q = new URLSearchParams(location.search);
const num = (k, d) => (q.has(k) && Number.isFinite(+q.get(k)) ? +q.get(k) : d);

const viewer = new Viewer($('view'), {
    renderer: q.get('renderer') || 'auto',
    cacheMiB: Math.max(16, num('cache', 256)),
    workers: Math.max(0, Math.min(8, num('workers', 2))),
    prefetch: q.get('prefetch') !== '0',
});
const runner = new FilterRunner(viewer, { box: $('roi-box'), canvas: $('view') });
const panel = new FilterPanel(viewer, runner);
const windowPanel = new WindowPanel(viewer, {
    box: $('window'), linked: $('w-linked'), auto: $('w-auto'), reset: $('w-reset'), channels: $('w-channels'),
});
const modes = { roi: runner.roiTool };
const terrain = new TerrainMode(viewer, $('terrain'), $('terrain-btn'));
attachInput(viewer, $('view'), modes);
new Overlay(viewer, {
    mini: $('mini'), zoom: $('zoom'), scale: $('scale'), scaleText: $('scale-text'),
    loading: $('loading'), loadingText: $('loading-text'),
});

let opening = null;
const errors = [];
const authDialog = new AuthDialog({
    box: $('auth'), heading: $('auth-heading'), note: $('auth-note'),
    confirm: $('auth-confirm'), cancel: $('auth-cancel'),
});
let loggingIn = false;
let auth = null;         // the last login's {token, expiresIn}

function showError(msg) {
    errors.push(msg);
    $('error').textContent = msg;
    $('error').hidden = !msg;
}

async function loadList() {
    try {
        const r = await fetch(new URL('v1/images', document.baseURI));
        const list = (await r.json()).images || [];
        const sel = $('picker');
        sel.replaceChildren(new Option('images…', ''));
        for (const im of list)
            sel.add(new Option(`${im.id} (${im.width} × ${im.height})`, im.id));
        sel.value = viewer.image ? viewer.image.id : '';
        return list;
    } catch (e) {
        showError(`cannot list the images: ${e.message}`);
        return [];
    }
}

// The filter part of the hash: ROI, graph and parameters.
async function routeFilter(st) {
    if (st.filter || st.roi)
        $('filters').hidden = false;
    if (JSON.stringify(st.roi) !== JSON.stringify(viewer.extra.roi))
        runner.setRoi(st.roi);
    if (st.filter !== panel.id)
        await panel.select(st.filter, st.params);
    else if (st.filter && JSON.stringify(st.params) !== JSON.stringify(runner.params))
        await panel.select(st.filter, st.params);
}

// Show what the hash says.
async function route() {
    const st = parseHash(location.hash);
    viewer.extra = { ...viewer.extra, roi: viewer.extra.roi, filter: panel.id, params: runner.params, terrain: terrain.source };
    // The display window of the link (none when absent or malformed;
    // window=none also keeps the store's default off).
    // (16-bit points are a sample store's; the viewer drops them for an
    // 8-bit image when it opens.)
    const win = st.window ? parseWindow(st.window, 65535) : null;
    const none = st.window === 'none';
    if ((win ? formatWindow(win) : null) !== (viewer.window ? formatWindow(viewer.window) : null) ||
        none !== viewer.windowNone) {
        viewer.setWindow(win, none);
        windowPanel.rebuild(win);
    }
    if ((st.colours || null) !== (viewer.colours || null))
        viewer.setColours(st.colours);
    $('status').hidden = !st.image;
    if (!st.image) {
        terrain.set(null);
        viewer.close();
        $('images').hidden = false;
        $('mini').hidden = true;
        $('picker').value = '';
        return;
    }
    $('images').hidden = true;
    if (viewer.image && viewer.image.id === st.image) {
        if (st.view && formatHash({ image: st.image, view: st.view }) !== formatHash({ image: st.image, view: viewer.view }))
            viewer.animateTo(st.view);
        terrain.set(st.terrain);
        await routeFilter(st);
        return;
    }
    showError('');
    const p = opening = viewer.open(st.image, st.view).then(() => {
        if (!viewer.image || viewer.image.id !== st.image)
            return;              // a later link won
        $('picker').value = st.image;
        $('renderer').textContent = $('renderer').title = viewer.backend.kind === 'webgl2' ?
            `WebGL2 · ${viewer.backend.renderer}` : 'no WebGL2: server-decoded regions';
        document.title = `${st.image} · gigaview`;
        $('view').focus({ preventScroll: true });
    }, async (e) => {
        if (e.status === 401 && !loggingIn) {
            // A restricted image: log in (IIIF Authorization Flow 2.0) and
            // open it again; the login's cookie goes with every request.
            loggingIn = true;
            const got = await obtainAccess(st.image, authDialog).catch((x) => ({ ok: false, message: x.message }));
            loggingIn = false;
            if (got.ok && parseHash(location.hash).image === st.image) {
                auth = got;
                await route();
                return;
            }
            if (!got.ok)
                e = new Error(got.message);
        }
        showError(e.message);
        $('images').hidden = false;
    });
    await p;
    if (opening === p)
        opening = null;
    if (viewer.image) {
        terrain.set(st.terrain);
        await routeFilter(st);
    }
}

// A login that expires while the image is open: its tile requests answer
// 401 and wait; log in again (the same flow as opening it) and carry on
// where the view is.
viewer.on('unauthorized', async (id) => {
    if (loggingIn || !viewer.image || viewer.image.id !== id)
        return;
    loggingIn = true;
    const got = await obtainAccess(id, authDialog).catch((x) => ({ ok: false, message: x.message }));
    loggingIn = false;
    if (got.ok) {
        auth = got;
        showError('');
        viewer.resume();
    } else {
        showError(`${got.message} (the login has expired)`);
    }
});

$('picker').addEventListener('change', (e) => {
    location.hash = e.target.value ? formatHash({ image: e.target.value }) : '';
});
$('help-btn').addEventListener('click', () => { $('help').hidden = !$('help').hidden; });
$('filter-btn').addEventListener('click', () => { $('filters').hidden = !$('filters').hidden; });
$('window-btn').addEventListener('click', () => { $('window').hidden = !$('window').hidden; });
window.addEventListener('keydown', (e) => {
    if (e.target && /^(INPUT|TEXTAREA|SELECT)$/.test(e.target.tagName))
        return;
    if (e.key === '?' || (e.key === 'Escape' && !$('help').hidden))
        $('help').hidden = !$('help').hidden;
});
window.addEventListener('hashchange', route);

window.gigaview = {
    viewer, modes, errors, terrain, parseHash, auth: () => auth, formatHash, screenToImage, imageToScreen, runner, panel, windowPanel,
    /** Resolves once the image named in the hash is open (or failed). */
    ready: (async () => { await Promise.all([loadList(), panel.load()]); await route(); })(),
};
