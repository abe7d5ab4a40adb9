// terrain.js - the viewer's 3D terrain mode: the TIN of the part of a
// height store in view, drawn in WebGL2 (terrain_gl.js) with orbit
// controls, shaded by a hillshade or draped with an image store.
//
// The mode is in the link: `&terrain=hillshade` or `&terrain=ID` (drape
// image store ID, mapped onto the height store's rectangle in proportion
// to their sizes); the 3D button and the `t` key toggle it.  The mesh is
// the one GET /v1/images/{id}/mesh?format=glb makes (docs/MESHES.md): the
// region the 2D view shows (its bounding box, clamped to the image), at
// the level where that region is at most GRID samples a side, with an
// error bound of 1/500 of the store's height range (read from its
// terrain/layer.json).  When the 2D view moves or zooms (the wheel in 3D zooms it),
// the region and level follow once it rests: the mesh is refined as the
// view zooms in.  Orbit: drag turns (horizontal: azimuth, vertical:
// elevation), the wheel zooms the view, `t` or the button leaves.
//
// window.gigaview.terrain is this object (tests, console): ready()
// resolves once the mesh for the current view is drawn; info holds the
// last mesh request ({level, region, triangles, maxError, url}).
//
// `refine=zfield` in the link (read when the mode turns on) or the `z` key
// in 3D switches to view-dependent refinement on the client's GPU
// (zfield_gl.js): the height grid of the view is fetched once (a
// (2^k+1)-square, k <= 8, of codes from /region?format=png16) and
// simplified again in every frame as the camera orbits; info then has
// method 'zfield', triangles and frames (the refinements so far).

import { TerrainGl, parseGlb } from './terrain_gl.js';
import { decodePng16, heightsOf, loadZfieldSources } from './zfield.js';
import { ZFieldTerrain } from './zfield_gl.js';

const GRID = 256;             // samples a side, at most, of a mesh
const REST_MS = 200;          // the view rests this long before a refetch

export class TerrainMode {
    /** viewer: the 2D viewer (viewer.js); canvas: the 3D view's canvas
     * (hidden until the mode is on); button: the toggle. */
    constructor(viewer, canvas, button) {
        this.viewer = viewer;
        this.canvas = canvas;
        this.button = button;
        this.source = null;          // 'hillshade' or a drape image's id
        this.az = 0;
        this.el = 40;
        this.dist = 1.3;
        this.info = null;
        this.gl = null;
        this.key = '';               // the mesh request shown or under way
        this.seq = 0;
        this.waiters = [];
        this.timer = 0;
        this.lastView = '';
        this.refine = /[#&]refine=zfield(&|$)/.test(location.hash) ? 'zfield' : null;
        this.zf = null;
        viewer.on('frame', () => this.viewMoved());
        button.addEventListener('click', () => this.toggle());
        window.addEventListener('keydown', (e) => {
            if (e.target && /^(INPUT|TEXTAREA|SELECT)$/.test(e.target.tagName))
                return;
            if (e.key === 't' && this.viewer.image)
                this.toggle();
            else if (e.key === 'z' && this.source)
                this.setRefine(this.refine ? null : 'zfield');
        });
        this.attachOrbit();
        new ResizeObserver(() => this.resize()).observe(canvas);
    }

    get active() { return !!this.source; }

    /** Turn the mode on with `source` ('hillshade' or an image id) or off
     * (null), and say so in the link. */
    set(source) {
        if (source && !this.refine && /[#&]refine=zfield(&|$)/.test(location.hash))
            this.setRefine('zfield');
        if ((source || null) === this.source)
            return;
        this.source = source || null;
        this.canvas.hidden = !this.source;
        this.button.classList.toggle('on', !!this.source);
        this.viewer.extra = { ...this.viewer.extra, terrain: this.source };
        if (this.viewer.image)
            this.viewer.writeHash();
        this.key = '';
        if (this.source) {
            this.resize();
            this.refresh();
        }
    }

    /** View-dependent refinement: 'zfield' or null (the server's mesh). */
    setRefine(mode) {
        this.refine = mode || null;
        this.key = '';
        if (this.source)
            this.refresh();
    }

    toggle() {
        this.set(this.source ? null : 'hillshade');
    }

    /** Resolves once the mesh for the current view is drawn. */
    ready() {
        if (!this.source || (this.key === this.wantKey() && !this.busy))
            return Promise.resolve(this.info);
        return new Promise((resolve, reject) => this.waiters.push({ resolve, reject }));
    }

    resize() {
        const r = this.canvas.getBoundingClientRect(), d = window.devicePixelRatio || 1;
        const w = Math.max(1, Math.round(r.width * d)), h = Math.max(1, Math.round(r.height * d));
        if (this.canvas.width !== w || this.canvas.height !== h) {
            this.canvas.width = w;
            this.canvas.height = h;
        }
        this.draw();
    }

    draw() {
        if (!this.gl || !this.source)
            return;
        if (this.zf && this.zf.active && this.info) {
            try {
                this.info.triangles = this.zf.refine(this.az, this.el, this.dist);
                this.info.frames = this.zf.frames;
            } catch (e) {
                console.error(`gigaview: terrain: ${e.message}`);
                this.zf.active = false;
            }
        }
        this.gl.draw(this.az, this.el, this.dist);
    }

    /** Orbit by daz degrees of azimuth and del of elevation (clamped to
     * 5..89), and draw. */
    orbit(daz, del) {
        this.az = (this.az + daz) % 360;
        this.el = Math.min(89, Math.max(5, this.el + del));
        this.draw();
    }

    attachOrbit() {
        let last = null;
        const c = this.canvas;
        c.addEventListener('pointerdown', (e) => {
            last = [e.clientX, e.clientY];
            c.setPointerCapture(e.pointerId);
        });
        c.addEventListener('pointermove', (e) => {
            if (!last)
                return;
            this.orbit(-(e.clientX - last[0]) * 0.4, (e.clientY - last[1]) * 0.3);
            last = [e.clientX, e.clientY];
        });
        const up = () => { last = null; };
        c.addEventListener('pointerup', up);
        c.addEventListener('pointercancel', up);
        c.addEventListener('wheel', (e) => {
            e.preventDefault();
            this.viewer.zoomAbout(e.deltaY > 0 ? 0.25 : -0.25);
        }, { passive: false });
    }

    // The 2D view changed: refetch once it rests.
    viewMoved() {
        if (!this.source || !this.viewer.view)
            return;
        const v = JSON.stringify(this.viewer.view);
        if (v === this.lastView)
            return;
        this.lastView = v;
        clearTimeout(this.timer);
        this.timer = setTimeout(() => this.refresh(), REST_MS);
    }

    /** The mesh request for the current view: {level, region, url, key}. */
    request() {
        const vw = this.viewer, im = vw.image, v = vw.view;
        if (!im || !v)
            return null;
        const W = im.info.width, H = im.info.height;
        const s0 = 2 ** v.zoom, rad = v.rot ? Math.hypot(vw.cssW, vw.cssH) / 2 : 0;
        const hw = (rad || vw.cssW / 2) * s0, hh = (rad || vw.cssH / 2) * s0;
        const x0 = Math.max(0, v.cx - hw), x1 = Math.min(W, v.cx + hw);
        const y0 = Math.max(0, v.cy - hh), y1 = Math.min(H, v.cy + hh);
        const levels = im.levels;
        let L = Math.max(0, Math.ceil(Math.log2(Math.max(x1 - x0, y1 - y0, 1) / GRID)));
        L = Math.min(L, levels.length - 1);
        while (L > 0 && (levels[L].w < 3 || levels[L].h < 3))
            L--;
        const s = 2 ** L, lw = levels[L].w, lh = levels[L].h;
        const rx = Math.min(Math.floor(x0 / s), lw - 2), ry = Math.min(Math.floor(y0 / s), lh - 2);
        const rw = Math.max(1, Math.min(Math.ceil(x1 / s), lw - 1) - rx);
        const rh = Math.max(1, Math.min(Math.ceil(y1 / s), lh - 1) - ry);
        const region = [rx, ry, rw, rh];
        const key = `${im.id} ${L} ${region.join(',')} ${this.source} ${this.refine || ''}`;
        return { level: L, region, key };
    }

    wantKey() {
        const r = this.request();
        return r ? r.key : '';
    }

    async refresh() {
        const rq = this.request();
        if (!this.source || !rq || rq.key === this.key)
            return this.settle();
        const seq = ++this.seq;
        this.busy = true;
        this.key = rq.key;
        try {
            if (!this.gl)
                this.gl = new TerrainGl(this.canvas);
            const im = this.viewer.image;
            const base = new URL(`v1/images/${encodeURIComponent(im.id)}`, document.baseURI).href;
            // the error bound: 1/500 of the store's height range (from its
            // terrain layer.json, which also says it is a height store)
            if (!this.range || this.range.id !== im.id) {
                const lr = await fetch(`${base}/terrain/layer.json`);
                if (!lr.ok)
                    throw new Error(`terrain: '${im.id}' is not a height store`);
                const g = (await lr.json()).gigaview;
                this.range = { id: im.id, min: g.heightMin, max: g.heightMax };
            }
            if (this.refine === 'zfield')
                return await this.refreshZfield(rq, base, seq);
            if (this.zf)
                this.zf.active = false;
            const err = Math.max((this.range.max - this.range.min) / 500, 1e-6);
            const url = `${base}/mesh?level=${rq.level}&region=${rq.region.join(',')}&max_error=${err}&format=glb`;
            const r = await fetch(url);
            if (!r.ok) {
                let msg = `HTTP ${r.status}`;
                try { msg = (await r.json()).error.message; } catch (e) { /* the status */ }
                throw new Error(`terrain: ${msg}`);
            }
            const mesh = parseGlb(await r.arrayBuffer());
            let drape = null;
            if (this.source !== 'hillshade')
                drape = await this.fetchDrape(this.source, im.info, rq);
            if (seq !== this.seq)
                return;                         // a later view won
            this.gl.setMesh(mesh, rq.level);
            this.gl.setDrape(drape && drape.bitmap, drape && drape.rect);
            this.info = { level: rq.level, region: rq.region, triangles: mesh.idx.length / 3,
                maxError: +r.headers.get('X-Mesh-Max-Error'), url, drape: drape ? drape.url : null };
            this.draw();
            this.busy = false;
            this.settle();
        } catch (e) {
            if (seq !== this.seq)
                return;
            this.busy = false;
            this.key = '';
            console.error(`gigaview: ${e.message}`);
            for (const w of this.waiters.splice(0))
                w.reject(e);
        }
    }

    /** refresh() for refine=zfield: the grid of the view, refined per
     * frame from now on (draw()). */
    async refreshZfield(rq, base, seq) {
        const im = this.viewer.image, lv = im.levels[rq.level];
        const k = Math.floor(Math.log2(Math.min(GRID, lv.w - 1, lv.h - 1)));
        if (!(k >= 1))
            throw new Error(`terrain: level ${rq.level} is too small for refine=zfield`);
        const side = 2 ** k, [rx, ry, rw, rh] = rq.region;
        const x0 = Math.max(0, Math.min(Math.round(rx + rw / 2 - side / 2), lv.w - 1 - side));
        const y0 = Math.max(0, Math.min(Math.round(ry + rh / 2 - side / 2), lv.h - 1 - side));
        const url = `${base}/region?level=${rq.level}&x=${x0}&y=${y0}&w=${side + 1}&h=${side + 1}&format=png16`;
        let el = im.info.elevation;
        if (!el)
            el = (await (await fetch(base)).json()).elevation;
        const r = await fetch(url);
        if (!r.ok)
            throw new Error(`terrain: height grid: HTTP ${r.status}`);
        const png = await decodePng16(await r.arrayBuffer());
        const grid = { level: rq.level, region: [x0, y0, side, side] };
        let drape = null;
        if (this.source !== 'hillshade')
            drape = await this.fetchDrape(this.source, im.info, grid);
        const src = this.zf ? null : await loadZfieldSources();
        if (seq !== this.seq)
            return;                         // a later view won
        if (!this.zf)
            this.zf = new ZFieldTerrain(this.gl, src);
        this.zf.setGrid(heightsOf(png.codes, el.scale, el.offset), side + 1, x0, y0, rq.level);
        this.gl.setDrape(drape && drape.bitmap, drape && drape.rect);
        this.info = { level: rq.level, region: grid.region, triangles: 0, maxError: -1, url,
            drape: drape ? drape.url : null, method: 'zfield', tau: this.zf.tau, frames: 0 };
        this.draw();
        this.busy = false;
        this.settle();
    }

    settle() {
        if (this.busy || this.key !== this.wantKey())
            return;
        for (const w of this.waiters.splice(0))
            w.resolve(this.info);
    }

    /** The drape: image store `id`'s region over the mesh's rectangle (in
     * proportion to the two images' sizes), at most 1024 pixels a side. */
    async fetchDrape(id, hinfo, rq) {
        const base = new URL(`v1/images/${encodeURIComponent(id)}`, document.baseURI).href;
        const ir = await fetch(base);
        if (!ir.ok)
            throw new Error(`terrain: no drape image '${id}' (HTTP ${ir.status})`);
        const di = await ir.json();
        const s = 2 ** rq.level, [rx, ry, rw, rh] = rq.region;
        const fx = di.width / hinfo.width, fy = di.height / hinfo.height;
        // the mesh's level-0 rectangle, in the drape's level-0 pixels
        const X0 = rx * s * fx, Y0 = ry * s * fy, X1 = (rx + rw) * s * fx, Y1 = (ry + rh) * s * fy;
        let L = Math.max(0, Math.ceil(Math.log2(Math.max(X1 - X0, Y1 - Y0, 1) / 1024)));
        const lw = (k) => Math.ceil(di.width / 2 ** k), lh = (k) => Math.ceil(di.height / 2 ** k);
        const t = 2 ** L;
        const x = Math.max(0, Math.floor(X0 / t)), y = Math.max(0, Math.floor(Y0 / t));
        const w = Math.max(1, Math.min(Math.ceil(X1 / t), lw(L)) - x);
        const h = Math.max(1, Math.min(Math.ceil(Y1 / t), lh(L)) - y);
        const url = `${base}/region?level=${L}&x=${x}&y=${y}&w=${w}&h=${h}&format=png`;
        const r = await fetch(url);
        if (!r.ok)
            throw new Error(`terrain: drape region: HTTP ${r.status}`);
        const bitmap = await createImageBitmap(await r.blob(), { colorSpaceConversion: 'none' });
        // the texture's rectangle back in the height store's level-0 pixels
        return { bitmap, url, rect: [x * t / fx, y * t / fy, w * t / fx, h * t / fy] };
    }
}
