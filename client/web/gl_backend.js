// gl_backend.js - the WebGL2 picture of a view: tiles fetched in batches
// (fetcher.js), decoded on the GPU by the shared decode shaders
// (gpu_decode.js for image stores, codes_decode.js for the 16-bit codes of
// sample and height stores), cached (tile_cache.js) and drawn as textured quads
// (renderer.js) through the store's look (looks.js): a window or a sample
// store's colours change the look, never a tile.  The viewer (viewer.js) owns the view and calls
// frame() once per animation frame; the backend says whether the picture
// is complete and whether it has more work.

import { CodesDecoder } from './codes_decode.js';
import { Fetcher } from './fetcher.js';
import { fetchText } from './gl_util.js';
import { GpuDecoder } from './gpu_decode.js';
import { CodesLook, ImageLook } from './looks.js';
import { tilesInCircle } from './pyramid.js';
import { Renderer } from './renderer.js';
import { RoiLayer } from './roi_layer.js';
import { TileCache } from './tile_cache.js';

let sources = null;   // the GLSL files, fetched once per page

/** A WebGL2 context for the canvas, or null where there is none. */
export function webgl2(canvas) {
    try {
        return canvas.getContext('webgl2', {
            alpha: false, antialias: false, depth: false, stencil: false,
            premultipliedAlpha: false, preserveDrawingBuffer: false,
            powerPreference: 'high-performance',
        });
    } catch (e) {
        return null;
    }
}

/** The renderer string (unmasked where the browser allows). */
export function rendererString(gl) {
    const ext = gl.getExtension('WEBGL_debug_renderer_info');
    return ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
}

export class GlBackend {
    /**
     * gl: the context; image: {id, info (metadata), url (absolute),
     * levels, root: {px, w, h}} (a sample or height store's root px: its
     * codes, a Uint16Array); opts: {cacheMiB, workers, budgetMs, onChange,
     * onUnauthorized} (TileCache's).
     */
    static async create(gl, image, opts) {
        if (!sources) {
            const names = ['fullscreen.vert.glsl', 'tile_decode.frag.glsl', 'display.vert.glsl',
                'display.frag.glsl', 'roi.frag.glsl', 'height_decode.frag.glsl', 'display_codes.frag.glsl'];
            const [vert, decode, dvert, dfrag, rfrag, hdecode, cfrag] = await Promise.all(names.map(fetchText));
            sources = { vert, decode, dvert, dfrag, rfrag, hdecode, cfrag };
        }
        return new GlBackend(gl, image, opts);
    }


    constructor(gl, image, opts) {
        this.gl = gl;
        this.image = image;
        this.kind = 'webgl2';
        this.renderer = rendererString(gl);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
        gl.pixelStorei(gl.PACK_ALIGNMENT, 1);
        const info = image.info;
        const codes = !!(info.samples || info.elevation);
        if (codes) {
            this.decoder = new CodesDecoder(gl, info.channels, sources.vert, sources.hdecode);
            this.look = new CodesLook(gl, info);
        } else {
            this.decoder = new GpuDecoder(gl, info.channels, sources.vert, sources.decode);
            this.look = new ImageLook(gl);
        }
        this.draw = new Renderer(gl, sources.dvert, codes ? sources.cfrag : sources.dfrag,
            image.levels, info.width, info.height, this.look);
        this.roiLayer = new RoiLayer(gl, sources.dvert, sources.rfrag);
        this.fetcher = new Fetcher(opts.workers);
        this.cache = new TileCache({
            decoder: this.decoder, info, imageUrl: image.url, levels: image.levels,
            fetcher: this.fetcher, budget: opts.cacheMiB * 1048576, onChange: opts.onChange,
            onUnauthorized: opts.onUnauthorized,
        });
        this.cache.setRoot(image.root.px, image.root.w, image.root.h);
        this.budgetMs = opts.budgetMs;
        this.prefetch = opts.prefetch !== false;
        this.last = null;
    }

    /** Fetch tiles again after a login (TileCache resume). */
    resume() {
        this.cache.resume();
    }

    /** An image store's display window: its tables (window.js lutBytes)
     * or null.  The next frame redraws from the tiles already decoded.
     * Other stores take setDisplay. */
    setLut(bytes) {
        if (this.look.setLut) {
            this.look.setLut(bytes);
            this.last = null;
        }
    }

    /** A sample or height store's window and colours, as texts (looks.js
     * CodesLook set: null for the store's own, window 'none' for none).
     * The next frame redraws from the tiles already decoded. */
    setDisplay(win, colours) {
        if (this.look.set) {
            this.look.set(win, colours);
            this.last = null;
        }
    }

    /** The filter result to draw in the ROI ({bitmap, level, x, y, w, h})
     * or null. */
    setFilterResult(res) {
        this.roiLayer.set(res);
    }

    /**
     * One frame for device view v (view.js, device pixels) on a w x h
     * drawing buffer.  redraw: the view changed; roi: [x, y, w, h] device
     * pixels where the filter result shows, or null.  Returns {complete,
     * busy, pending, level, t}: busy when another frame would make
     * progress without new input (decodes waiting).
     */
    frame(v, w, h, redraw, roi) {
        const plan = this.draw.plan(v, w, h);
        const needed = [...plan.coarse, ...plan.fine];
        // Prefetch circle (section 7.5): tiles of the fine level whose
        // centres lie within 1.5 view half-diagonals of the view centre.
        const half = Math.hypot(w, h) / 2 * 2 ** v.zoom;
        const circle = !this.prefetch ? [] : tilesInCircle(this.image.levels, this.image.info.width,
            this.image.info.height, plan.f, v.cx, v.cy, 1.5 * half + 512 * 2 ** plan.f);
        const u = this.cache.update(needed, circle, this.budgetMs);
        let r = this.last;
        if (redraw || u.visible || !r) {
            r = this.last = this.draw.draw(plan, v, w, h, this.cache);
            this.roiLayer.draw(v, w, h, roi);
        }
        return {
            complete: r.complete, busy: u.decoded > 0, pending: u.pending,
            inflight: this.cache.inflightCount, level: plan.f, t: plan.t, drawn: r.drawn,
        };
    }

    /** The level a view's picture is drawn from (its finer level). */
    levelOf(v, w, h) {
        return this.draw.plan(v, w, h).f;
    }

    /** Draw again now and read the drawing buffer back: RGBA rows, top
     * first (tests and benchmarks). */
    snapshot(v, w, h, roi) {
        const gl = this.gl;
        const plan = this.draw.plan(v, w, h);
        this.draw.draw(plan, v, w, h, this.cache);
        this.roiLayer.draw(v, w, h, roi);
        const px = new Uint8Array(w * h * 4);
        gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
        const out = new Uint8Array(w * h * 4);
        for (let y = 0; y < h; y++)
            out.set(px.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
        return out;
    }

    /** A decoded tile's pixels (channels bytes each, or a sample store's
     * codes, 513 x 513), or null. */
    readTile(k, tx, ty) {
        const tex = this.cache.get(k, tx, ty);
        return tex ? this.decoder.read(tex, 513, 513) : null;
    }

    /** Decoded tiles now resident: [{level, tx, ty, entropy, dct}]. */
    tiles() {
        const out = [];
        for (const [kk, e] of this.cache.tex)
            if (!e.fixed) {
                const [level, tx, ty] = kk.split('/').map(Number);
                out.push({ level, tx, ty, entropy: e.entropy, dct: e.dct });
            }
        return out;
    }

    get stats() {
        const c = this.cache;
        return { ...c.stats, resident: c.tex.size, textureBytes: c.texBytes, prepared: c.prep.size,
            fetchMode: this.fetcher.mode };
    }

    dispose() {
        this.roiLayer.dispose();
        this.cache.dispose();
        this.fetcher.dispose();
        this.draw.dispose();
        this.look.dispose();
        this.decoder.dispose();
    }
}
