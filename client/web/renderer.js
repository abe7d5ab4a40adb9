// renderer.js - draws a view from decoded tiles: one textured quad per
// tile (thesis section 7.5), sampled bilinearly by display.frag.glsl.
//
// The level of detail of a view is Z = log2(level-0 pixels per device
// pixel).  Levels f = floor(Z) and f + 1 are drawn and blended by the
// fraction t = Z - f, like `gigaview render`: first the coarse level
// alone, then the fine level on top with the constant blend factor 1 - t.
// At an integer Z (t = 0) only level f is drawn, unblended.  A tile that
// is not resident yet is drawn from its nearest resident ancestor,
// upsampled over the same domain, so the picture never has a hole: the
// root is always resident.  Where a fine tile is missing the coarse level
// shows alone.  Tile domains (pyramid.js) share their edges exactly, so
// each pixel is drawn once per layer, and both taps of every sample lie
// inside the tile thanks to the one-pixel overlap; taps on the overlap
// come from the neighbour that owns those pixels when it is resident
// (display.frag.glsl), so the picture has no seams.
//
// What a tile's texels become on the screen is the look's (looks.js): an
// image store's pixels, optionally windowed, or a sample store's codes
// through the window and the channels' colours, each with its own
// fragment shader and the same sampling.

import { program, quadArrays } from './gl_util.js';
import { imageToScreen } from './view.js';
import { tileDomain, tilesIn, viewCorners } from './pyramid.js';
import { screenToImage } from './view.js';
import { STEP } from './tilebuf.js';

const FLOATS_PER_QUAD = 6 * 4;

export class Renderer {
    /** look: a looks.js look, fragSrc its shader. */
    constructor(gl, vertSrc, fragSrc, levels, W, H, look) {
        this.gl = gl;
        this.levels = levels;
        this.W = W;            // level-0 size of the image
        this.H = H;
        this.prog = program(gl, vertSrc, fragSrc, 'display');
        ({ vao: this.vao, vbo: this.vbo } = quadArrays(gl, this.prog));
        this.data = new Float32Array(FLOATS_PER_QUAD * 256);
        this.top = levels.length - 1;
        this.look = look;
    }

    /**
     * What a device-pixel view needs: {f, t, fine, coarse, poly}.  v is a
     * view in device pixels (view.js, zoom already corrected for the pixel
     * ratio), w x h the drawing buffer.
     */
    plan(v, w, h) {
        let f = Math.floor(v.zoom), t = v.zoom - f;
        if (f < 0) { f = 0; t = 0; }
        if (f >= this.top) { f = this.top; t = 0; }
        // Fractions too small to change a byte are not worth a second layer.
        if (t < 1 / 512) t = 0;
        const poly = viewCorners((x, y) => screenToImage(v, w, h, x, y), w, h);
        const fine = tilesIn(this.levels, this.W, this.H, f, poly, v.cx, v.cy);
        const coarse = t > 0 ? tilesIn(this.levels, this.W, this.H, f + 1, poly, v.cx, v.cy) : [];
        return { f, t, fine, coarse, poly };
    }

    // Six vertices of the quad over `dom` (level-0 rectangle) sampling tile
    // (a, sx, sy) into this.data at quad index q.
    quad(q, v, w, h, dom, a, sx, sy) {
        const s = 2 ** a, tiled = this.levels[a].tiled;
        const ox = tiled ? STEP * sx : 0, oy = tiled ? STEP * sy : 0;
        const need = (q + 1) * FLOATS_PER_QUAD;
        if (need > this.data.length) {
            const d = new Float32Array(this.data.length * 2);
            d.set(this.data);
            this.data = d;
        }
        const corner = (x, y) => {
            const [px, py] = imageToScreen(v, w, h, x, y);
            return [px / w * 2 - 1, 1 - py / h * 2, x / s - 0.5 - ox, y / s - 0.5 - oy];
        };
        const c00 = corner(dom[0], dom[1]), c10 = corner(dom[2], dom[1]);
        const c11 = corner(dom[2], dom[3]), c01 = corner(dom[0], dom[3]);
        let o = q * FLOATS_PER_QUAD;
        for (const c of [c00, c10, c11, c00, c11, c01])
            for (let i = 0; i < 4; i++)
                this.data[o++] = c[i];
    }

    // The last valid texel of level a in the texture of tile (a, sx, sy).
    limit(a, sx, sy) {
        const L = this.levels[a];
        if (!L.tiled)
            return [L.w - 1, L.h - 1];
        return [Math.min(STEP, L.w - 1 - STEP * sx), Math.min(STEP, L.h - 1 - STEP * sy)];
    }

    /**
     * Draw plan p of device view v into the default framebuffer (w x h).
     * cache: a TileCache.  Returns {complete, drawn, fallback}: complete
     * when every tile of the plan was drawn from its own texture (or has
     * failed for good).
     */
    draw(p, v, w, h, cache) {
        const gl = this.gl;
        const draws = [];     // [quad index, texture, limit, blend]
        let q = 0, fallback = 0, complete = true;
        const layer = (tiles, blend) => {
            for (const [k, tx, ty] of tiles) {
                const dom = tileDomain(this.levels, this.W, this.H, k, tx, ty);
                let src;
                if (blend) {
                    const tex = cache.get(k, tx, ty);
                    if (!tex) {
                        if (!cache.failedTile(k, tx, ty))
                            complete = false;
                        continue;      // the coarse layer shows here
                    }
                    src = [k, tx, ty, tex];
                } else {
                    src = cache.nearest(k, tx, ty);
                    if (src[0] !== k) {
                        fallback++;
                        if (!cache.settled([k, tx, ty]))
                            complete = false;
                    }
                }
                this.quad(q, v, w, h, dom, src[0], src[1], src[2]);
                const [a, sx, sy] = src;
                const nb = this.levels[a].tiled ?
                    [cache.get(a, sx + 1, sy), cache.get(a, sx, sy + 1), cache.get(a, sx + 1, sy + 1)] : [null, null, null];
                draws.push([q++, src[3], this.limit(a, sx, sy), blend, nb]);
            }
        };
        if (p.t > 0) {
            layer(p.coarse, false);
            layer(p.fine, true);
        } else {
            layer(p.fine, false);
        }
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.viewport(0, 0, w, h);
        gl.disable(gl.SCISSOR_TEST);
        gl.clearColor(0, 0, 0, 1);
        gl.clear(gl.COLOR_BUFFER_BIT);
        gl.useProgram(this.prog.program);
        gl.bindVertexArray(this.vao);
        gl.bindBuffer(gl.ARRAY_BUFFER, this.vbo);
        gl.bufferData(gl.ARRAY_BUFFER, this.data.subarray(0, q * FLOATS_PER_QUAD), gl.STREAM_DRAW);
        const P = this.prog;
        gl.uniform1i(P.loc('u_tile'), 0);
        gl.uniform1i(P.loc('u_right'), 1);
        gl.uniform1i(P.loc('u_below'), 2);
        gl.uniform1i(P.loc('u_diag'), 3);
        this.look.bind(gl, P);
        gl.blendColor(0, 0, 0, 1 - p.t);
        gl.blendFunc(gl.CONSTANT_ALPHA, gl.ONE_MINUS_CONSTANT_ALPHA);
        for (const [i, tex, lim, blend, nb] of draws) {
            if (blend)
                gl.enable(gl.BLEND);
            else
                gl.disable(gl.BLEND);
            gl.uniform1i(P.loc('u_round'), blend ? 0 : 1);
            gl.uniform2i(P.loc('u_max'), lim[0], lim[1]);
            gl.uniform3i(P.loc('u_has'), nb[0] ? 1 : 0, nb[1] ? 1 : 0, nb[2] ? 1 : 0);
            // Missing neighbours: the tile itself, never read (u_has 0).
            for (let u = 0; u < 4; u++) {
                gl.activeTexture(gl.TEXTURE0 + u);
                gl.bindTexture(this.look.target, u === 0 ? tex : nb[u - 1] || tex);
            }
            gl.drawArrays(gl.TRIANGLES, i * 6, 6);
        }
        gl.activeTexture(gl.TEXTURE0);
        gl.disable(gl.BLEND);
        gl.bindVertexArray(null);
        return { complete, drawn: draws.length, fallback };
    }

    dispose() {
        const gl = this.gl;
        gl.deleteProgram(this.prog.program);
        gl.deleteBuffer(this.vbo);
        gl.deleteVertexArray(this.vao);
    }
}
