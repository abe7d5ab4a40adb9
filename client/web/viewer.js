// viewer.js - the viewer: one image, its view, the frame loop, animation
// and the URL hash.
//
// The view (view.js) is kept in CSS pixels; the backends get it in device
// pixels (zoom minus log2 of the pixel ratio), so the level of detail
// follows the real screen and a copied link shows the same part of the
// image on any screen.  Input (input.js) either moves the view at once
// (drag, pinch) or sets a goal that the view approaches exponentially
// (wheel, keys, gamepad buttons), keeping an anchor point under the
// cursor while zooming.  Frames are drawn only while something changes:
// input, animation, tiles arriving or waiting to be decoded.  The hash is
// rewritten (replaceState) once the view rests.  Events (on): 'open',
// 'frame', 'hash', and 'unauthorized' (id) when tile requests answer 401
// because a login has expired: they wait for resume().

import { GlBackend, webgl2 } from './gl_backend.js';
import { RegionBackend } from './fallback.js';
import { displayChannels, levelsOf } from './pyramid.js';
import { formatWindow, lutBytes, parseWindow } from './window.js';
import { anchored, clampView, formatHash, homeView, normRot, screenToImage } from './view.js';

const TAU_MS = 90;            // time constant of animated moves

/**
 * The root level's 8-bit picture ({px, w, h, via}, displayChannels bytes
 * a pixel): every decode of an image store starts from it, so it must be
 * exact.  Tried in order of size: the lossless WebP the store keeps
 * (root?format=webp; a gray root has three equal channels), the lossless
 * PNG, each decoded without colour management or premultiplication into a
 * canvas (exact for lossless images with no transparency), then the raw
 * samples.  `via` names the form used.  A height or sample store's root
 * holds 16-bit codes: its 8-bit picture (docs/API.md: a height store's
 * gray, a sample store's window and colours, gray or RGB) comes through
 * the region endpoint.
 */
async function loadPicture(url, info) {
    const w = info.root.width, h = info.root.height, c = displayChannels(info);
    const forms = info.elevation || info.samples
        ? [['region', `${url}/region?level=${info.root.level}&x=0&y=0&w=${w}&h=${h}&format=png`]]
        : [['webp', `${url}/root?format=webp`], ['png', `${url}/root`]];
    for (const [via, src] of forms) {
        try {
            const r = await fetch(src);
            if (!r.ok)
                throw new Error(`HTTP ${r.status}`);
            const b = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
            if (b.width !== w || b.height !== h) {
                b.close();
                throw new Error(`${b.width}x${b.height}`);
            }
            const cv = document.createElement('canvas');
            cv.width = w;
            cv.height = h;
            const g = cv.getContext('2d', { willReadFrequently: true });
            g.drawImage(b, 0, 0);
            b.close();
            const rgba = g.getImageData(0, 0, w, h).data, px = new Uint8Array(w * h * c);
            for (let i = 0; i < w * h; i++)
                for (let k = 0; k < c; k++)
                    px[i * c + k] = rgba[4 * i + k];
            return { px, w, h, via };
        } catch (e) {
            /* the next form */
        }
    }
    const rr = await fetch(`${url}/root?format=raw`);
    if (!rr.ok)
        throw new Error(`cannot load the root: HTTP ${rr.status}`);
    const px = new Uint8Array(await rr.arrayBuffer());
    if (px.length !== w * h * c)
        throw new Error(`root: ${px.length} bytes for ${w}x${h}x${c}`);
    return { px, w, h, via: 'raw' };
}

/**
 * The root level ({px, w, h, via, picture}): loadPicture's, and with
 * `codes` (the WebGL2 backend draws a height or sample store from its
 * codes) px holds the root's codes instead (root?format=raw, a
 * Uint16Array of info.channels a pixel) and picture the 8-bit picture
 * (the overview map and the window's auto points use it).
 */
async function loadRoot(url, info, codes) {
    const pic = await loadPicture(url, info);
    if (!codes)
        return { ...pic, picture: pic.px };
    const w = info.root.width, h = info.root.height;
    const rr = await fetch(`${url}/root?format=raw`);
    if (!rr.ok)
        throw new Error(`cannot load the root: HTTP ${rr.status}`);
    const buf = await rr.arrayBuffer();
    if (buf.byteLength !== w * h * info.channels * 2)
        throw new Error(`root: ${buf.byteLength} bytes for ${w}x${h}x${info.channels} codes`);
    return { px: new Uint16Array(buf), w, h, via: 'raw codes', picture: pic.px };
}

const HASH_REST_MS = 250;     // the view rests this long before the hash follows

export class Viewer {
    /**
     * canvas: the drawing surface (sized by CSS); opts: {renderer:
     * 'auto'|'webgl2'|'region', cacheMiB, workers, budgetMs, prefetch}.
     */
    constructor(canvas, opts) {
        this.canvas = canvas;
        this.opts = { renderer: 'auto', cacheMiB: 256, workers: 2, budgetMs: 8, ...opts };
        this.view = null;
        this.goal = null;
        this.image = null;
        this.backend = null;
        this.raf = 0;
        this.dirty = true;
        this.lastResult = null;
        this.listeners = [];
        this.hashTimer = 0;
        this.extra = {};              // roi, filter, params, window, colours: kept in the hash
        this.colours = null;          // a sample store's channel colours, "RRGGBB;..."
        this.window = null;           // the display window (window.js) or null
        this.windowNone = false;      // none, the store's default refused (link's window=none)
        this.filterShown = false;     // a filter result is set (roi_filter.js)
        this.timing = {};
        this.ro = new ResizeObserver(() => this.resize());
        this.ro.observe(canvas);
        // A lost WebGL context (driver reset, too many contexts) takes every
        // texture with it: reopen the image, at the same view, when it
        // comes back.
        canvas.addEventListener('webglcontextlost', (e) => {
            e.preventDefault();
            if (this.backend && this.backend.kind === 'webgl2') {
                this.lostImage = { id: this.image.id, view: this.view };
                this.close();
            }
        });
        canvas.addEventListener('webglcontextrestored', () => {
            const l = this.lostImage;
            this.lostImage = null;
            if (l)
                this.open(l.id, l.view).catch((err) => console.error(`gigaview: ${err.message}`));
        });
        this.resize();
    }

    // Drawing buffer to match the CSS size at the device pixel ratio.
    resize() {
        const r = this.canvas.getBoundingClientRect();
        const dpr = window.devicePixelRatio || 1;
        const w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
        this.cssW = Math.max(1, r.width);
        this.cssH = Math.max(1, r.height);
        if (this.canvas.width !== w || this.canvas.height !== h) {
            this.canvas.width = w;
            this.canvas.height = h;
        }
        this.invalidate();
    }

    /** The view in device pixels, for the backends. */
    deviceView(v = this.view) {
        return { ...v, zoom: v.zoom - Math.log2(this.canvas.width / this.cssW) };
    }

    /**
     * Open image `id`: fetch its metadata and root, make the backend, show
     * `view` (or the whole image).  Resolves once the image is open (its
     * first frame is scheduled; settled() waits for a complete picture);
     * rejects with a message for an unknown image.  A later open() wins
     * over one still under way, which then resolves without effect.
     */
    async open(id, view) {
        const t0 = performance.now();
        const seq = this.openSeq = (this.openSeq || 0) + 1;
        this.close();
        const url = new URL(`v1/images/${encodeURIComponent(id)}`, document.baseURI).href;
        const r = await fetch(url);
        if (!r.ok) {
            let msg = `HTTP ${r.status}`;
            try { msg = (await r.json()).error.message; } catch (e) { /* keep the status */ }
            const err = new Error(`cannot open '${id}': ${msg}`);
            err.status = r.status;   // 401: restricted (main.js logs in)
            throw err;
        }
        const info = await r.json();
        // Every store is drawn from its tiles on the GPU where there is
        // WebGL2, else from the server's 8-bit regions.
        let gl = null;
        if (this.opts.renderer !== 'region') {
            gl = this.gl || (this.gl = webgl2(this.canvas));
            if (!gl && this.opts.renderer === 'webgl2')
                throw new Error('this browser has no WebGL2');
        }
        const root = await loadRoot(url, info, gl && (info.samples || info.elevation));
        const image = { id, info, url, levels: levelsOf(info), root };
        this.timing = { openStart: t0, metaMs: performance.now() - t0, firstCompleteMs: null };
        const onChange = () => this.schedule();
        // A tile request answered 401: the login has expired (main.js logs
        // in again and calls resume()).
        const onUnauthorized = () => this.emit('unauthorized', id);
        let backend = gl ? await GlBackend.create(gl, image, { ...this.opts, onChange, onUnauthorized })
            : null;
        if (!backend) {
            const ctx = this.ctx2d || (this.ctx2d = this.canvas.getContext('2d', { alpha: false }));
            if (!ctx)
                throw new Error('this browser can draw neither WebGL2 nor a 2D canvas here');
            backend = new RegionBackend(ctx, image, onChange, onUnauthorized);
        }
        if (seq !== this.openSeq) {
            backend.dispose();
            return;
        }
        this.image = image;
        this.backend = backend;
        if (this.window && ((this.window.length !== 1 && this.window.length !== info.channels) ||
            (!info.samples && this.window.some((c) => c.white > 255))))
            this.window = null;       // one window a channel, or 16-bit points, for another image
        // No window from the link: the store's default (the image
        // document's "window", the one gigaviewd applies to regions),
        // unless the link says window=none.
        const dflt = !this.window && !this.windowNone && info.window
            ? parseWindow(info.window, info.samples ? 65535 : 255) : null;
        // Colours: a sample store's of several channels, one per channel.
        if (this.colours && !(info.samples && this.colours.split(';').length === info.channels && info.channels > 1)) {
            this.colours = null;
            this.extra = { ...this.extra, colours: null };
        }
        if (dflt && (dflt.length === 1 || dflt.length === info.channels)) {
            this.window = dflt;
            this.extra = { ...this.extra, window: formatWindow(dflt) };
        }
        this.applyWindow();
        this.view = clampView(view || this.home(), info.width, info.height, this.cssW, this.cssH);
        this.goal = null;
        this.invalidate();
        this.emit('open');
    }

    /**
     * Set the display window: [{black, white, gammaMilli}] (window.js), one
     * for every channel or one per channel, or null for none.  The WebGL2
     * picture changes at the next frame from the tiles already decoded
     * (no tile is fetched); the hash follows.  none: with no window, the
     * hash says window=none (so that the store's default stays off).
     */
    setWindow(w, none = false) {
        this.window = w && w.length ? w : null;
        this.windowNone = !this.window && none;
        this.applyWindow();
        this.invalidate();
        this.viewChanged();
    }

    /**
     * Set a sample store's channel colours: "RRGGBB;..." one per channel
     * (docs/API.md, "Sample stores"), or null for the store's own.  With
     * WebGL2 the next frame draws them from the tiles already decoded;
     * without, the server draws them and the view is fetched again.  The
     * hash follows.
     */
    setColours(text) {
        const ok = typeof text === 'string' && /^[0-9a-fA-F]{6}(;[0-9a-fA-F]{6}){0,7}$/.test(text);
        this.colours = ok ? text.toLowerCase() : null;
        this.extra = { ...this.extra, colours: this.colours };
        this.applyWindow();
        this.invalidate();
        this.viewChanged();
    }

    applyWindow() {
        this.extra = { ...this.extra, window: this.window ? formatWindow(this.window) : this.windowNone ? 'none' : null };
        if (this.backend && this.backend.setLut && !this.image.info.samples && !this.image.info.elevation)
            this.backend.setLut(this.window ? lutBytes(this.window, this.image.info.channels) : null);
        // A sample store's codes on the GPU, or the server's regions (with
        // each request): the window and colours as texts.
        if (this.backend && this.backend.setDisplay)
            this.backend.setDisplay(this.extra.window, this.colours);
    }

    close() {
        if (this.backend)
            this.backend.dispose();
        this.backend = null;
        this.image = null;
    }

    home() {
        return homeView(this.image ? this.image.info.width : 1, this.image ? this.image.info.height : 1,
            this.cssW, this.cssH);
    }

    // ------------------------------------------------------------ moves

    clamp(v) {
        return clampView(v, this.image.info.width, this.image.info.height, this.cssW, this.cssH);
    }

    /** Set the view at once (drag, pinch, tests). */
    setView(v) {
        if (!this.image)
            return;
        this.view = this.clamp(v);
        this.goal = null;
        this.invalidate();
    }

    /** Move towards view v, animated; anchor {p, s}: keep image point p
     * under screen point s (CSS pixels) meanwhile. */
    animateTo(v, anchor = null) {
        if (!this.image)
            return;
        this.goal = { view: this.clamp(v), anchor };
        this.invalidate();
    }

    /** The goal if animating, else the view: where the next relative move
     * starts from. */
    target() {
        return this.goal ? this.goal.view : this.view;
    }

    panBy(dx, dy) {
        const v = this.view, s = 2 ** v.zoom, th = v.rot * Math.PI / 180;
        const cs = Math.cos(th), sn = -Math.sin(th);
        this.setView({ ...v, cx: v.cx - (dx * cs - dy * sn) * s, cy: v.cy - (dx * sn + dy * cs) * s });
    }

    /** Pan the goal by (dx, dy) CSS pixels of the screen, animated. */
    panByAnimated(dx, dy) {
        const g = this.target(), s = 2 ** g.zoom, th = g.rot * Math.PI / 180;
        const cs = Math.cos(th), sn = -Math.sin(th);
        this.animateTo({ ...g, cx: g.cx + (dx * cs - dy * sn) * s, cy: g.cy + (dx * sn + dy * cs) * s });
    }

    /** Zoom by dz levels (negative: in) about screen point (sx, sy),
     * animated. */
    zoomAbout(dz, sx = this.cssW / 2, sy = this.cssH / 2) {
        const p = screenToImage(this.view, this.cssW, this.cssH, sx, sy);
        const g = this.target();
        const z = this.clamp({ ...g, zoom: g.zoom + dz }).zoom;
        const goal = anchored({ ...g, zoom: z }, this.cssW, this.cssH, p, [sx, sy]);
        this.animateTo(goal, { p, s: [sx, sy] });
    }

    /** Turn by ddeg degrees clockwise about the view centre, animated. */
    rotateBy(ddeg) {
        const g = this.target();
        this.animateTo({ ...g, rot: g.rot + ddeg });
    }

    /** A two-finger gesture: the image point under screen point `from`
     * moves to `to`, scaled by `scale` and turned by ddeg. */
    gesture(from, to, scale, ddeg) {
        const v = this.view;
        const p = screenToImage(v, this.cssW, this.cssH, from[0], from[1]);
        const w = this.clamp({ ...v, zoom: v.zoom - Math.log2(scale), rot: v.rot + ddeg });
        this.setView(anchored(w, this.cssW, this.cssH, p, to));
    }

    reset() {
        this.animateTo(this.home());
    }

    // ------------------------------------------------------------ frames

    invalidate() {
        this.dirty = true;
        this.schedule();
    }

    schedule() {
        if (!this.raf)
            this.raf = requestAnimationFrame((t) => this.frame(t));
    }

    // Advance the animation by dt ms; true if the view moved.
    animate(dt) {
        const g = this.goal;
        if (!g)
            return false;
        const k = 1 - Math.exp(-Math.max(dt, 0) / TAU_MS), v = this.view, gv = g.view;
        const dr = normRot(gv.rot - v.rot);
        let next = { ...v, zoom: v.zoom + (gv.zoom - v.zoom) * k, rot: v.rot + dr * k };
        if (g.anchor)
            next = anchored(next, this.cssW, this.cssH, g.anchor.p, g.anchor.s);
        else
            next = { ...next, cx: v.cx + (gv.cx - v.cx) * k, cy: v.cy + (gv.cy - v.cy) * k };
        const px = Math.hypot(next.cx - gv.cx, next.cy - gv.cy) / 2 ** next.zoom;
        if (Math.abs(gv.zoom - next.zoom) < 1e-3 && Math.abs(normRot(gv.rot - next.rot)) < 0.01 && px < 0.05) {
            this.view = gv;            // snap: the goal exactly
            this.goal = null;
        } else {
            this.view = next;
        }
        return true;
    }

    frame(now) {
        this.raf = 0;
        if (!this.backend || !this.view)
            return;
        const dt = this.lastFrame ? now - this.lastFrame : 16;
        this.lastFrame = now;
        let moved = this.animate(dt);
        for (const f of this.listeners)
            if (f.type === 'tick' && f.fn(dt))
                moved = true;
        const redraw = this.dirty || moved;
        this.dirty = false;
        const w = this.canvas.width, h = this.canvas.height;
        const r = this.backend.frame(this.deviceView(), w, h, redraw, this.roiDevice());
        this.lastResult = r;
        if (r.complete && !this.goal && this.timing.firstCompleteMs === null) {
            this.timing.firstCompleteMs = performance.now() - this.timing.openStart;
            const s = this.backend.stats;
            this.timing.atFirstComplete = { tiles: s.tilesFetched, batches: s.batches, bytes: s.bytes,
                decoded: s.decoded };
        }
        if (this.goal || r.busy || this.dirty || this.listeners.some((f) => f.type === 'tick' && f.active()))
            this.schedule();
        if (redraw)
            this.viewChanged();
        this.emit('frame', r);
    }

    // The view moved: the hash follows once it rests.
    viewChanged() {
        clearTimeout(this.hashTimer);
        this.hashTimer = setTimeout(() => {
            if (!this.goal && this.image)
                this.writeHash();
        }, HASH_REST_MS);
    }

    /** The state as a hash (view.js formatHash). */
    hash() {
        return formatHash({ image: this.image.id, view: this.view, ...this.extra });
    }

    writeHash() {
        const h = this.hash();
        if (location.hash !== h) {
            history.replaceState(null, '', h);
            this.emit('hash', h);
        }
    }

    // ------------------------------------------------------------ events

    /** Fetch tiles again after the 'unauthorized' event's login. */
    resume() {
        if (this.backend && this.backend.resume)
            this.backend.resume();
    }

    on(type, fn, active) {
        this.listeners.push({ type, fn, active: active || (() => false) });
    }

    emit(type, arg) {
        for (const f of this.listeners)
            if (f.type === type)
                f.fn(arg);
    }

    /** Resolves after a frame in which the picture is complete and the
     * view at rest (tests, benchmarks). */
    settled() {
        return new Promise((resolve) => {
            const check = () => {
                const r = this.lastResult;
                if (r && r.complete && !this.goal && !this.dirty) {
                    resolve(r);
                    return true;
                }
                return false;
            };
            if (check())
                return;
            const l = { type: 'frame', fn: () => { if (check()) this.listeners.splice(this.listeners.indexOf(l), 1); }, active: () => false };
            this.listeners.push(l);
            this.schedule();
        });
    }

    /** The drawn picture of the current view (RGBA, rows top first). */
    snapshot() {
        return this.backend.snapshot(this.deviceView(), this.canvas.width, this.canvas.height, this.roiDevice());
    }

    /** The ROI in CSS pixels of the canvas, [x, y, w, h] from its top
     * left, or null (extra.roi is relative to the centre). */
    roiCss() {
        const r = this.extra.roi;
        return r ? [this.cssW / 2 + r[0], this.cssH / 2 + r[1], r[2], r[3]] : null;
    }

    /** The ROI in device pixels where a filter result is to be drawn. */
    roiDevice() {
        const r = this.roiCss();
        if (!r || !this.filterShown)
            return null;
        const k = this.canvas.width / this.cssW;
        return r.map((x) => x * k);
    }

    get stats() {
        return { ...this.backend.stats, ...this.timing, renderer: this.backend.renderer, kind: this.backend.kind };
    }
}
