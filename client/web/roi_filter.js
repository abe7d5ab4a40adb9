// roi_filter.js - running a filter graph on the server for the region of
// interest (thesis section 7.3; POST /v1/images/{id}/filter, docs/API.md)
// and handing the result to the viewer's backend, which draws it inside
// the ROI over the original image.
//
// The ROI is fixed on the screen (CSS pixels relative to the viewport
// centre, in the hash as roi=).  A request covers the bounding box of the
// ROI in the level the view is drawn from (its finer level; coarser while
// the box would exceed REGION_MAX pixels), with the ROI's size in device
// pixels as the graph's viewport.  The request is made again whenever
// that box, the graph or a parameter changes: after a pan or zoom once
// the view rests (REST_MS), after a parameter change once it stops
// (DEBOUNCE_MS).  A newer request aborts the older one (AbortController),
// and the previous result stays on screen, moving with the image, until
// the new one arrives.  ROI selection: the "select region" button arms a
// drag, and a drag with Shift always selects.

import { screenToImage } from './view.js';

const REST_MS = 200;
const DEBOUNCE_MS = 150;
const REGION_MAX = 3.5e6;     // pixels: under the default max_filter_pixels (4M) with room for padding
const MIN_ROI = 8;            // CSS pixels: a smaller drag clears the ROI

export class FilterRunner {
    constructor(viewer, els) {
        this.viewer = viewer;
        this.els = els;               // {box, canvas}
        this.filter = null;           // a graph id, or
        this.graph = null;            // an inline graph document (edited)
        this.params = {};             // "module.param" -> number
        this.lastKey = '';
        this.ctl = null;
        this.timer = 0;
        this.inflight = 0;
        this.result = null;           // {level, x, y, w, h, key, ms, gpuMs, workerMs}
        this.error = null;            // {message, module, line}
        this.runs = 0;
        this.listeners = [];
        viewer.on('frame', () => this.onFrame());
        viewer.on('open', () => this.reset());
        this.roiTool = this.makeRoiTool();
    }

    on(fn) {
        this.listeners.push(fn);
    }

    emit() {
        for (const f of this.listeners)
            f(this);
    }

    reset() {
        if (this.ctl)
            this.ctl.abort();
        this.lastKey = '';
        this.result = null;
        this.error = null;
        if (this.viewer.backend)
            this.viewer.backend.setFilterResult(null);
        this.viewer.filterShown = false;
        this.placeBox();
        this.schedule(0);
    }

    /** Use stored or stock graph `id` (null: no filter). */
    setFilter(id) {
        this.filter = id;
        this.graph = null;
        this.viewer.extra.filter = id;
        this.changed(0);
    }

    /** Run an edited graph document inline (not stored). */
    setGraph(doc) {
        this.graph = doc;
        this.changed(0);
    }

    setParams(p, delay = DEBOUNCE_MS) {
        this.params = { ...p };
        this.viewer.extra.params = { ...p };
        this.changed(delay);
    }

    /** roi: [x, y, w, h] CSS pixels relative to the viewport centre, or null. */
    setRoi(roi) {
        this.viewer.extra.roi = roi;
        if (!roi) {
            this.viewer.backend && this.viewer.backend.setFilterResult(null);
            this.viewer.filterShown = false;
            this.result = null;
        }
        this.placeBox();
        this.changed(0);
    }

    changed(delay) {
        this.lastKey = '';
        this.viewer.viewChanged();
        this.viewer.invalidate();
        this.schedule(delay);
    }

    // The request for the current view: {key, level, region, body} or null.
    request() {
        const v = this.viewer, roiCss = v.roiCss();
        if (!v.image || !v.backend || !roiCss || (!this.filter && !this.graph))
            return null;
        const k = v.canvas.width / v.cssW;
        const roi = roiCss.map((x) => x * k);
        const dv = v.deviceView(), w = v.canvas.width, h = v.canvas.height;
        const corners = [[roi[0], roi[1]], [roi[0] + roi[2], roi[1]], [roi[0] + roi[2], roi[1] + roi[3]],
            [roi[0], roi[1] + roi[3]]].map(([x, y]) => screenToImage(dv, w, h, x, y));
        const levels = v.image.levels;
        for (let L = Math.max(0, v.backend.levelOf(dv, w, h)); L < levels.length; L++) {
            const s = 2 ** L, lw = levels[L].w, lh = levels[L].h;
            const xs = corners.map((c) => c[0] / s), ys = corners.map((c) => c[1] / s);
            const x0 = Math.max(0, Math.floor(Math.min(...xs))), y0 = Math.max(0, Math.floor(Math.min(...ys)));
            const x1 = Math.min(lw, Math.ceil(Math.max(...xs))), y1 = Math.min(lh, Math.ceil(Math.max(...ys)));
            if (x1 <= x0 || y1 <= y0)
                return null;
            if ((x1 - x0) * (y1 - y0) > REGION_MAX && L + 1 < levels.length)
                continue;
            const params = {};
            for (const [mp, val] of Object.entries(this.params)) {
                const i = mp.lastIndexOf('.');
                (params[mp.slice(0, i)] ||= {})[mp.slice(i + 1)] = val;
            }
            const body = {
                ...(this.graph ? { graph: this.graph } : { filter: this.filter }),
                params, level: L, region: [x0, y0, x1 - x0, y1 - y0],
                viewport: [Math.max(1, Math.round(roi[2])), Math.max(1, Math.round(roi[3]))],
            };
            return { key: JSON.stringify([v.image.id, body]), level: L, region: body.region, body };
        }
        return null;
    }

    onFrame() {
        this.placeBox();
        const r = this.request();
        if (r && r.key !== this.lastKey && !this.timer)
            this.schedule(REST_MS);
    }

    schedule(delay) {
        clearTimeout(this.timer);
        this.timer = setTimeout(() => { this.timer = 0; this.run(); }, delay);
    }

    async run() {
        const r = this.request();
        if (!r) {
            this.lastKey = '';
            this.emit();
            return;
        }
        if (r.key === this.lastKey)
            return;
        // While the view still moves, wait for it to rest.
        if (this.viewer.goal) {
            this.schedule(REST_MS);
            return;
        }
        this.lastKey = r.key;
        if (this.ctl)
            this.ctl.abort();
        const ctl = this.ctl = new AbortController();
        const v = this.viewer, t0 = performance.now();
        this.inflight++;
        this.emit();
        try {
            const resp = await fetch(`${v.image.url}/filter`, {
                method: 'POST', headers: { 'Content-Type': 'application/json' },
                body: JSON.stringify(r.body), signal: ctl.signal,
            });
            if (!resp.ok) {
                let msg = `HTTP ${resp.status}`;
                try { msg = (await resp.json()).error.message; } catch (e) { /* the status */ }
                const m = /module '([^']+)' line (\d+): (.*)$/s.exec(msg);
                this.error = { message: msg, status: resp.status, module: m ? m[1] : null, line: m ? +m[2] : 0,
                    text: m ? m[3] : msg };
                this.lastKey = r.key;     // do not ask again for the same thing
                return;
            }
            const blob = await resp.blob();
            const bitmap = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
            if (ctl.signal.aborted || !v.backend) {
                bitmap.close();
                return;
            }
            const hdr = (n) => resp.headers.get(n);
            this.result = { level: r.level, x: r.region[0], y: r.region[1], w: bitmap.width, h: bitmap.height,
                key: r.key, ms: performance.now() - t0, bytes: blob.size,
                gpuMs: +hdr('X-Gigaview-Filter-Gpu-Ms'), workerMs: +hdr('X-Gigaview-Filter-Worker-Ms'),
                passes: +hdr('X-Gigaview-Filter-Passes'), textures: +hdr('X-Gigaview-Filter-Textures') };
            this.error = null;
            this.runs++;
            v.backend.setFilterResult({ bitmap, level: r.level, x: r.region[0], y: r.region[1],
                w: bitmap.width, h: bitmap.height });
            v.filterShown = true;
            v.invalidate();
        } catch (e) {
            if (e.name !== 'AbortError')
                this.error = { message: e.message, module: null, line: 0, text: e.message };
        } finally {
            this.inflight--;
            if (this.ctl === ctl)
                this.ctl = null;
            this.emit();
        }
    }

    /** Resolves once no request waits or runs and the result (or error)
     * belongs to the current view (tests). */
    idle() {
        return new Promise((resolve) => {
            const check = () => {
                const r = this.request();
                if (!this.timer && !this.inflight && (!r || r.key === this.lastKey)) {
                    resolve(this.result);
                    return true;
                }
                return false;
            };
            if (check())
                return;
            const poll = () => { if (!check()) setTimeout(poll, 30); };
            poll();
        });
    }

    // ---------------------------------------------------------- ROI tool

    placeBox() {
        const r = this.viewer.roiCss(), b = this.els.box;
        if (!r || this.roiTool.dragging) {
            if (!this.roiTool.dragging)
                b.hidden = true;
            return;
        }
        b.hidden = false;
        b.style.left = `${r[0]}px`;
        b.style.top = `${r[1]}px`;
        b.style.width = `${r[2]}px`;
        b.style.height = `${r[3]}px`;
    }

    makeRoiTool() {
        const runner = this, box = this.els.box;
        let start = null;
        const rect = (a, b) => [Math.min(a[0], b[0]), Math.min(a[1], b[1]), Math.abs(a[0] - b[0]), Math.abs(a[1] - b[1])];
        const show = (r) => {
            box.hidden = false;
            box.style.left = `${r[0]}px`;
            box.style.top = `${r[1]}px`;
            box.style.width = `${r[2]}px`;
            box.style.height = `${r[3]}px`;
        };
        return {
            active: false,
            dragging: false,
            down(e, p) {
                if (!this.active && !e.shiftKey)
                    return false;
                start = p;
                this.dragging = true;
                runner.els.canvas.setPointerCapture(e.pointerId);
                show([p[0], p[1], 0, 0]);
                return true;
            },
            move(e, p) {
                show(rect(start, p));
            },
            up(e, p) {
                this.dragging = false;
                this.active = false;
                runner.els.canvas.classList.remove('selecting');
                const r = rect(start, p), v = runner.viewer;
                runner.setRoi(r[2] >= MIN_ROI && r[3] >= MIN_ROI ?
                    [r[0] - v.cssW / 2, r[1] - v.cssH / 2, r[2], r[3]] : null);
                runner.emit();
            },
            arm() {
                this.active = true;
                runner.els.canvas.classList.add('selecting');
            },
        };
    }
}
