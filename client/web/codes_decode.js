// codes_decode.js - the WebGL2 decoder of 16-bit codes: height stores
// (docs/FORMAT.md section 12) and sample stores (section 13, a height tile
// buffer per channel).  shaders/height_decode.frag.glsl, the very file
// that lib/gpu/gpu_height.c compiles, compiled here as GLSL ES 3.00 with
// GV_LAYERED: a decoded tile is one 513 x 513 x C R16UI array texture, a
// layer per channel, each layer made from the same layer of its parent's
// texture with texelFetch only, bit for bit the CPU decoder.  The
// residuals q are decoded on the CPU (heighttile.js prepareSampleTile, in
// a worker) and uploaded a channel at a time as a 513 x 513 R32I texture
// (the GV_GPU_PATH_WEBGL2 variant).
//
// The same interface as gpu_decode.js GpuDecoder (upload, decode, read,
// release, tileBytes), so tile_cache.js serves both kinds of store; the
// renderer draws these through looks.js CodesLook.

import { intTexture, program } from './gl_util.js';
import { SAMPLES, SIDE } from './heighttile.js';

export class CodesDecoder {
    /** gl: a WebGL2 context; channels: 1 to 8; vertSrc, decodeSrc:
     * shaders/fullscreen.vert.glsl and shaders/height_decode.frag.glsl.
     * Throws if they do not compile. */
    constructor(gl, channels, vertSrc, decodeSrc) {
        this.gl = gl;
        this.channels = channels;
        this.tileBytes = SIDE * SIDE * 2 * channels;
        this.prog = program(gl, vertSrc, `#define GV_LAYERED 1\n${decodeSrc}`, 'height_decode.frag.glsl');
        this.qtex = intTexture(gl, gl.R32I, SIDE, SIDE);
        this.fbo = gl.createFramebuffer();
        this.vao = gl.createVertexArray();
        gl.useProgram(this.prog.program);
        gl.uniform1i(this.prog.loc('u_parent'), 0);
        gl.uniform1i(this.prog.loc('u_q'), 1);
    }

    // An empty w x h texture of `channels` R16UI layers, bound to unit 0.
    texture(w, h) {
        const gl = this.gl, t = gl.createTexture();
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, t);
        gl.texStorage3D(gl.TEXTURE_2D_ARRAY, 1, gl.R16UI, w, h, this.channels);
        for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.NEAREST], [gl.TEXTURE_MAG_FILTER, gl.NEAREST],
            [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]])
            gl.texParameteri(gl.TEXTURE_2D_ARRAY, k, v);
        return t;
    }

    /** A texture of w x h pixels of `channels` interleaved codes (a
     * Uint16Array): the root tile and the root mips. */
    upload(codes, w, h) {
        const gl = this.gl, c = this.channels, t = this.texture(w, h);
        const plane = new Uint16Array(w * h);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 2);
        for (let k = 0; k < c; k++) {
            for (let i = 0; i < w * h; i++)
                plane[i] = codes[i * c + k];
            gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, k, w, h, 1, gl.RED_INTEGER,
                gl.UNSIGNED_SHORT, plane);
        }
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, null);
        return t;
    }

    /**
     * Decode one tile: prep from heighttile.prepareSampleTile ({q, e,
     * coded}), parent the decoded parent's texture, (qx, qy) = (tx & 1,
     * ty & 1).  Returns the new texture; the caller owns it (release()).
     */
    decode(prep, parent, qx, qy) {
        const gl = this.gl, p = this.prog;
        const tex = this.texture(SIDE, SIDE);
        gl.bindVertexArray(this.vao);
        gl.useProgram(p.program);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, parent);
        gl.uniform2i(p.loc('u_quadrant'), qx, qy);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        gl.viewport(0, 0, SIDE, SIDE);
        gl.disable(gl.BLEND);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, this.qtex);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
        for (let k = 0; k < this.channels; k++) {
            if (prep.coded[k])
                gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, SIDE, SIDE, gl.RED_INTEGER, gl.INT,
                    prep.q.subarray(k * SAMPLES, (k + 1) * SAMPLES));
            gl.uniform1i(p.loc('u_layer'), k);
            gl.uniform1i(p.loc('u_e'), prep.e[k]);
            gl.uniform1i(p.loc('u_coded'), prep.coded[k]);
            gl.framebufferTextureLayer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, tex, 0, k);
            gl.drawArrays(gl.TRIANGLES, 0, 3);
        }
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.activeTexture(gl.TEXTURE0);
        return tex;
    }

    /** The codes of a w x h texture (default a whole tile) as a
     * Uint16Array of `channels` interleaved codes a pixel, rows top
     * first (for tests: compare with the CPU decoder). */
    read(tex, w = SIDE, h = SIDE) {
        const gl = this.gl, c = this.channels;
        const rgba = new Uint32Array(4 * w * h), out = new Uint16Array(w * h * c);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        for (let k = 0; k < c; k++) {
            gl.framebufferTextureLayer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, tex, 0, k);
            gl.readPixels(0, 0, w, h, gl.RGBA_INTEGER, gl.UNSIGNED_INT, rgba);
            for (let i = 0; i < w * h; i++)
                out[i * c + k] = rgba[4 * i];
        }
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        return out;
    }

    release(tex) {
        this.gl.deleteTexture(tex);
    }

    dispose() {
        const gl = this.gl;
        gl.deleteProgram(this.prog.program);
        gl.deleteTexture(this.qtex);
        gl.deleteFramebuffer(this.fbo);
        gl.deleteVertexArray(this.vao);
    }
}
