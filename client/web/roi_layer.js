// roi_layer.js - the filter result over the region of interest, in WebGL2.
//
// A result covers a rectangle of one pyramid level (the request's
// region); it is drawn where that rectangle lies in the current view, so
// after a pan or zoom the previous result moves with the image and stays
// visible (stale) until the new one arrives (thesis section 7.3: the
// original image shows outside the ROI, the filtered one inside).  The
// scissor test keeps it inside the ROI, which is fixed on the screen.

import { program, quadArrays } from './gl_util.js';
import { imageToScreen } from './view.js';

export class RoiLayer {
    constructor(gl, vertSrc, fragSrc) {
        this.gl = gl;
        this.prog = program(gl, vertSrc, fragSrc, 'roi');
        ({ vao: this.vao, vbo: this.vbo } = quadArrays(gl, this.prog));
        this.tex = null;
        this.res = null;
    }

    /** res: {bitmap (ImageBitmap), level, x, y, w, h} or null. */
    set(res) {
        const gl = this.gl;
        if (this.tex)
            gl.deleteTexture(this.tex);
        this.tex = null;
        this.res = res;
        if (!res)
            return;
        this.tex = gl.createTexture();
        gl.bindTexture(gl.TEXTURE_2D, this.tex);
        gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
        gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
        gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, res.bitmap);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    }

    /** Draw over the current framebuffer: device view v on a w x h buffer,
     * clipped to roi = [x, y, w, h] in device pixels (top-left origin). */
    draw(v, w, h, roi) {
        const r = this.res, gl = this.gl;
        if (!r || !this.tex || !roi)
            return;
        const s = 2 ** r.level;
        const corner = (lx, ly) => {
            const [px, py] = imageToScreen(v, w, h, lx * s, ly * s);
            return [px / w * 2 - 1, 1 - py / h * 2, lx - r.x - 0.5, ly - r.y - 0.5];
        };
        // The level rectangle's pixel areas: [x, x + w] in level units,
        // where texel i's centre is x + i + 0.5.
        const c00 = corner(r.x, r.y), c10 = corner(r.x + r.w, r.y);
        const c11 = corner(r.x + r.w, r.y + r.h), c01 = corner(r.x, r.y + r.h);
        const data = new Float32Array(24);
        let o = 0;
        for (const c of [c00, c10, c11, c00, c11, c01])
            for (let i = 0; i < 4; i++)
                data[o++] = c[i];
        const x0 = Math.max(0, Math.round(roi[0])), y0 = Math.max(0, Math.round(roi[1]));
        const x1 = Math.min(w, Math.round(roi[0] + roi[2])), y1 = Math.min(h, Math.round(roi[1] + roi[3]));
        if (x1 <= x0 || y1 <= y0)
            return;
        gl.enable(gl.SCISSOR_TEST);
        gl.scissor(x0, h - y1, x1 - x0, y1 - y0);
        gl.disable(gl.BLEND);
        gl.useProgram(this.prog.program);
        gl.bindVertexArray(this.vao);
        gl.bindBuffer(gl.ARRAY_BUFFER, this.vbo);
        gl.bufferData(gl.ARRAY_BUFFER, data, gl.STREAM_DRAW);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, this.tex);
        gl.uniform1i(this.prog.loc('u_img'), 0);
        gl.uniform2i(this.prog.loc('u_max'), r.w - 1, r.h - 1);
        gl.drawArrays(gl.TRIANGLES, 0, 6);
        gl.disable(gl.SCISSOR_TEST);
        gl.bindVertexArray(null);
    }

    dispose() {
        const gl = this.gl;
        if (this.tex)
            gl.deleteTexture(this.tex);
        gl.deleteProgram(this.prog.program);
        gl.deleteBuffer(this.vbo);
        gl.deleteVertexArray(this.vao);
    }
}
