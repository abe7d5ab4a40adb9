// fallback.js - the picture of a view for a browser without WebGL2: the
// server decodes (GET /v1/images/{id}/region, docs/API.md) and a 2D canvas
// draws.  The root image is always drawn first, so there is never a hole;
// over it the latest region image for the view, kept (stale, moved with
// the view) until the region for the new view arrives.  A region is asked
// for once the view has rested for a moment; it covers the view's
// bounding box at level floor(Z), or coarser while that would exceed
// MAX_PIXELS.  PNG up to a megapixel (exact), JPEG above.  A display
// window and a sample store's colours (setDisplay) go with each request,
// the root's included: the server applies them (a sample store's window
// to its 16-bit codes), so a change fetches the view again.

import { screenToImage } from './view.js';
import { displayChannels, viewCorners } from './pyramid.js';

const MAX_PIXELS = 4 << 20;
const REST_MS = 120;

export class RegionBackend {
    /** ctx: a 2D context; image as for GlBackend (info, url, levels, root);
     * onChange(): schedule a frame; onUnauthorized(): a region answered
     * 401 (an expired login), the view waits for resume(). */
    constructor(ctx, image, onChange, onUnauthorized) {
        this.ctx = ctx;
        this.image = image;
        this.kind = 'region';
        this.renderer = 'canvas 2d + server region endpoint';
        this.onChange = onChange;
        this.onUnauthorized = onUnauthorized || (() => {});
        this.held = false;        // after a 401, until resume()
        this.shown = null;        // {bitmap, level, x, y}
        this.want = '';
        this.timer = 0;
        this.ctl = null;
        this.stats = { regions: 0, bytes: 0, errors: 0, lastError: '' };
        this.winq = '';           // '&window=...&colours=...' of every request
        const { picture: px, w, h } = image.root, c = displayChannels(image.info);
        const rgba = new Uint8ClampedArray(w * h * 4);
        for (let i = 0; i < w * h; i++) {
            for (let k = 0; k < 3; k++)
                rgba[4 * i + k] = px[i * c + (c === 3 ? k : 0)];
            rgba[4 * i + 3] = 255;
        }
        this.root = { bitmap: null, level: image.info.levels_tiled, x: 0, y: 0 };
        createImageBitmap(new ImageData(rgba, w, h)).then((b) => {
            this.root.bitmap = b;
            onChange();
        });
    }

    // The region request for device view v: {level, x, y, w, h} or null.
    region(v, w, h) {
        const levels = this.image.levels;
        const poly = viewCorners((x, y) => screenToImage(v, w, h, x, y), w, h);
        const xs = poly.map((p) => p[0]), ys = poly.map((p) => p[1]);
        for (let k = Math.max(0, Math.min(Math.floor(v.zoom), levels.length - 1)); k < levels.length; k++) {
            const s = 2 ** k, L = levels[k];
            const x0 = Math.max(0, Math.floor(Math.min(...xs) / s) - 1), y0 = Math.max(0, Math.floor(Math.min(...ys) / s) - 1);
            const x1 = Math.min(L.w, Math.ceil(Math.max(...xs) / s) + 1), y1 = Math.min(L.h, Math.ceil(Math.max(...ys) / s) + 1);
            if (x1 <= x0 || y1 <= y0)
                return null;
            if ((x1 - x0) * (y1 - y0) <= MAX_PIXELS)
                return { level: k, x: x0, y: y0, w: x1 - x0, h: y1 - y0 };
        }
        return null;
    }

    async load(r) {
        if (this.ctl)
            this.ctl.abort();
        const ctl = this.ctl = new AbortController();
        const fmt = r.w * r.h <= 1 << 20 ? 'png' : 'jpeg';
        const url = `${this.image.url}/region?level=${r.level}&x=${r.x}&y=${r.y}&w=${r.w}&h=${r.h}&format=${fmt}${this.winq}`;
        try {
            const resp = await fetch(url, { signal: ctl.signal });
            if (resp.status === 401 && !this.held) {
                this.held = true;
                this.onUnauthorized();
            }
            if (!resp.ok)
                throw new Error(`region: HTTP ${resp.status}`);
            const blob = await resp.blob();
            this.stats.bytes += blob.size;
            const bitmap = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
            if (this.shown && this.shown.bitmap)
                this.shown.bitmap.close();
            this.shown = { bitmap, level: r.level, x: r.x, y: r.y, key: this.keyOf(r) };
            this.stats.regions++;
        } catch (e) {
            if (e.name !== 'AbortError') {
                this.stats.errors++;
                this.stats.lastError = e.message;
                console.warn(`gigaview: ${e.message}`);
            }
        } finally {
            if (this.ctl === ctl)
                this.ctl = null;
            this.onChange();
        }
    }

    // What region r shows: its rectangle and the display parameters.
    keyOf(r) {
        return `${r.level}/${r.x}/${r.y}/${r.w}/${r.h}${this.winq}`;
    }

    /** Window text (window.js formatWindow), 'none', or null for the
     * store's default, and a sample store's colours ("RRGGBB;...", or null
     * for its own): the view and the root are fetched again with them. */
    setDisplay(text, colours) {
        const q = (text ? `&window=${encodeURIComponent(text)}` : '') +
            (colours ? `&colours=${encodeURIComponent(colours)}` : '');
        if (q === this.winq)
            return;
        this.winq = q;
        this.want = '';
        const info = this.image.info, root = this.root;
        const w = info.root.width, h = info.root.height;
        fetch(`${this.image.url}/region?level=${info.root.level}&x=0&y=0&w=${w}&h=${h}&format=png${q}`)
            .then((r) => (r.ok ? r.blob() : Promise.reject(new Error(`root: HTTP ${r.status}`))))
            .then((b) => createImageBitmap(b, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' }))
            .then((b) => {
                if (this.winq !== q) {
                    b.close();
                    return;
                }
                if (root.bitmap)
                    root.bitmap.close();
                root.bitmap = b;
                this.onChange();
            })
            .catch((e) => { this.stats.errors++; this.stats.lastError = e.message; });
        this.onChange();
    }

    // Draw an image of level `k` pixels placed at (x, y) of that level.
    place(b, k, x, y, v, w, h) {
        const ctx = this.ctx, s = 2 ** k / 2 ** v.zoom, th = v.rot * Math.PI / 180;
        const cs = Math.cos(th), sn = Math.sin(th);
        // Level-0 point p goes to (w/2, h/2) + R(rot) (p - c) / 2^zoom.
        ctx.setTransform(cs * s, sn * s, -sn * s, cs * s,
            w / 2 - (cs * v.cx - sn * v.cy) / 2 ** v.zoom,
            h / 2 - (sn * v.cx + cs * v.cy) / 2 ** v.zoom);
        ctx.drawImage(b, x, y);
    }

    /** Load the view again after a login (the 401 that held it). */
    resume() {
        this.held = false;
        this.want = '';
        this.onChange();
    }

    setFilterResult(res) {
        if (this.filtered && this.filtered.bitmap && (!res || res.bitmap !== this.filtered.bitmap))
            this.filtered.bitmap.close();
        this.filtered = res;
    }

    levelOf(v) {
        return Math.max(0, Math.min(Math.floor(v.zoom), this.image.levels.length - 1));
    }

    frame(v, w, h, redraw, roi) {
        const r = this.region(v, w, h);
        const want = r ? this.keyOf(r) : '';
        if (want !== this.want) {
            this.want = want;
            clearTimeout(this.timer);
            if (r)
                this.timer = setTimeout(() => this.load(r), REST_MS);
        }
        const ctx = this.ctx;
        ctx.setTransform(1, 0, 0, 1, 0, 0);
        ctx.fillStyle = '#000';
        ctx.fillRect(0, 0, w, h);
        ctx.imageSmoothingEnabled = true;
        ctx.imageSmoothingQuality = 'high';
        if (this.root.bitmap)
            this.place(this.root.bitmap, this.root.level, 0, 0, v, w, h);
        if (this.shown)
            this.place(this.shown.bitmap, this.shown.level, this.shown.x, this.shown.y, v, w, h);
        const f = this.filtered;
        if (f && roi) {
            ctx.save();
            ctx.setTransform(1, 0, 0, 1, 0, 0);
            ctx.beginPath();
            ctx.rect(Math.round(roi[0]), Math.round(roi[1]), Math.round(roi[2]), Math.round(roi[3]));
            ctx.clip();
            this.place(f.bitmap, f.level, f.x, f.y, v, w, h);
            ctx.restore();
        }
        ctx.setTransform(1, 0, 0, 1, 0, 0);
        const complete = !!(this.shown && this.shown.key === want && !this.ctl);
        return { complete, busy: false, pending: complete ? 0 : 1, inflight: this.ctl ? 1 : 0,
            level: r ? r.level : 0, t: 0, drawn: this.shown ? 2 : 1 };
    }

    snapshot(v, w, h, roi) {
        this.frame(v, w, h, true, roi);
        return new Uint8Array(this.ctx.getImageData(0, 0, w, h).data.buffer);
    }

    dispose() {
        clearTimeout(this.timer);
        if (this.ctl)
            this.ctl.abort();
    }
}
