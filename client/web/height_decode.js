// height_decode.js - the WebGL2 height tile decoder (docs/FORMAT.md
// section 12): shaders/height_decode.frag.glsl, the very file that
// lib/gpu/gpu_height.c compiles, compiled here as GLSL ES 3.00 with the
// residuals q decoded on the CPU (heighttile.js) and uploaded as a
// 513 x 513 R32I texture (the GV_GPU_PATH_WEBGL2 variant).  A decoded
// tile is a 513 x 513 R16UI texture of codes, made from its parent's
// texture with texelFetch only: bit for bit the CPU decoder.

import { intTexture, program } from './gl_util.js';
import { SIDE, heightResiduals } from './heighttile.js';

export class HeightDecoder {
    /** gl: a WebGL2 context; vertSrc, decodeSrc: shaders/fullscreen.vert.glsl
     * and shaders/height_decode.frag.glsl.  Throws if they do not compile. */
    constructor(gl, vertSrc, decodeSrc) {
        this.gl = gl;
        this.prog = program(gl, vertSrc, decodeSrc, 'height_decode.frag.glsl');
        this.qtex = intTexture(gl, gl.R32I, SIDE, SIDE);
        this.fbo = gl.createFramebuffer();
        this.vao = gl.createVertexArray();
        gl.useProgram(this.prog.program);
        gl.uniform1i(this.prog.loc('u_parent'), 0);
        gl.uniform1i(this.prog.loc('u_q'), 1);
    }

    /** A texture of 513 x 513 codes (the root tile, a Uint16Array). */
    upload(codes) {
        const gl = this.gl, t = intTexture(gl, gl.R16UI, SIDE, SIDE);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 2);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, SIDE, SIDE, gl.RED_INTEGER,
            gl.UNSIGNED_SHORT, codes);
        return t;
    }

    /** Decode tile buffer buf (Uint8Array) against the parent's texture at
     * quadrant (qx, qy): a new texture (the caller deletes it). */
    decode(buf, parent, qx, qy) {
        const gl = this.gl, p = this.prog;
        const { e, coded, q } = heightResiduals(buf);
        const tex = intTexture(gl, gl.R16UI, SIDE, SIDE);
        gl.bindVertexArray(this.vao);
        gl.useProgram(p.program);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, this.qtex);
        if (coded) {
            gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
            gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, SIDE, SIDE, gl.RED_INTEGER, gl.INT, q);
        }
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, parent);
        gl.uniform2i(p.loc('u_quadrant'), qx, qy);
        gl.uniform1i(p.loc('u_e'), e);
        gl.uniform1i(p.loc('u_coded'), coded);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        gl.viewport(0, 0, SIDE, SIDE);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        return tex;
    }

    /** The codes of a decoded tile: a Uint16Array(513 * 513). */
    read(tex) {
        const gl = this.gl, rgba = new Uint32Array(4 * SIDE * SIDE);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        gl.readPixels(0, 0, SIDE, SIDE, gl.RGBA_INTEGER, gl.UNSIGNED_INT, rgba);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        const out = new Uint16Array(SIDE * SIDE);
        for (let i = 0; i < out.length; i++) out[i] = rgba[4 * i];
        return out;
    }
}
