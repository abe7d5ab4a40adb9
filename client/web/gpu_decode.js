// gpu_decode.js - the WebGL2 tile decoder: shaders/tile_decode.frag.glsl,
// the very text that gigaviewd, the native client and tests/test_gpu_decode
// compile (its #include "dct_matrix.glsl" expanded at build time by
// shaders/glsl_include.sh, in gigaviewd's copy as in theirs), fetched from
// the server and compiled here as GLSL ES 3.00 (the GV_GPU_PATH_WEBGL2
// variant of lib/gpu/gpu_decode.c).
//
// A decoded tile is a 513 x 513 RGBA8UI texture (gray replicated, alpha
// 255) rendered in one pass from its parent's texture (texelFetch only, no
// filtering: integer arithmetic bit for bit as the CPU decoder) and the
// tile buffer, uploaded as an R32UI texture 1024 words wide; an
// entropy-coded tile's indices, decoded on the CPU (tilebuf.js), go in a
// 257 x 257 R16UI texture (u_indices); a layout-D tile's dequantized
// coefficients, unpacked on the CPU too (tile_dct.js), in a 520 x 520
// RGBA16I texture (u_coefs, channel c in component c, a block's bounds in
// its first texel's fourth, as dct_decode.comp.glsl has them), from which the
// shader does the inverse transform and colour transform.  Both textures
// stay bound for every tile; a tile of another layout leaves their old
// contents there, which its shader path never reads.  Unlike lib/gpu/gpu_decode.c no second mip level
// (the parent quarter) is made: the viewer blends two levels by drawing
// the parent tile itself (renderer.js), which it keeps anyway.

import { intTexture, program } from './gl_util.js';
import { DCT_SIDE } from './tile_dct.js';
import { BLOCKS, TILE, WORDS_ROWS_MAX, WORDS_WIDTH } from './tilebuf.js';

/** GPU bytes of one decoded tile. */
export const TILE_BYTES = TILE * TILE * 4;

export class GpuDecoder {
    /**
     * gl: a WebGL2 context; channels: 1 or 3; vertSrc, decodeSrc: the
     * contents of shaders/fullscreen.vert.glsl and
     * shaders/tile_decode.frag.glsl as gigaviewd serves them (web/, its
     * #include expanded).  Throws if they do not compile.
     */
    constructor(gl, channels, vertSrc, decodeSrc) {
        this.gl = gl;
        this.channels = channels;
        this.tileBytes = TILE_BYTES;
        this.prog = program(gl, vertSrc, decodeSrc, 'tile_decode.frag.glsl');
        this.words = intTexture(gl, gl.R32UI, WORDS_WIDTH, WORDS_ROWS_MAX);
        this.indices = intTexture(gl, gl.R16UI, BLOCKS, BLOCKS);
        this.coefs = intTexture(gl, gl.RGBA16I, DCT_SIDE, DCT_SIDE);
        this.fbo = gl.createFramebuffer();
        this.vao = gl.createVertexArray();
        const p = this.prog;
        gl.useProgram(p.program);
        gl.uniform1i(p.loc('u_parent'), 0);
        gl.uniform1i(p.loc('u_words'), 1);
        gl.uniform1i(p.loc('u_indices'), 2);
        gl.uniform1i(p.loc('u_coefs'), 3);
        gl.uniform1i(p.loc('u_words_width'), WORDS_WIDTH);
        gl.uniform1i(p.loc('u_channels'), channels);
    }

    /**
     * Decode one tile: prep from tilebuf.prepareTile, parent the decoded
     * parent's texture (513 x 513), (qx, qy) = (tx & 1, ty & 1).  Returns
     * the new texture; the caller owns it (release()).
     */
    decode(prep, parent, qx, qy) {
        const gl = this.gl, p = this.prog;
        gl.bindVertexArray(this.vao);
        gl.useProgram(p.program);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, this.words);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, WORDS_WIDTH, prep.rows, gl.RED_INTEGER,
            gl.UNSIGNED_INT, prep.words);
        gl.activeTexture(gl.TEXTURE2);
        gl.bindTexture(gl.TEXTURE_2D, this.indices);
        if (prep.indices)
            gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, BLOCKS, BLOCKS, gl.RED_INTEGER,
                gl.UNSIGNED_SHORT, prep.indices);
        gl.activeTexture(gl.TEXTURE3);
        gl.bindTexture(gl.TEXTURE_2D, this.coefs);
        if (prep.coefs)
            gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, DCT_SIDE, DCT_SIDE, gl.RGBA_INTEGER,
                gl.SHORT, prep.coefs);
        gl.activeTexture(gl.TEXTURE0);
        // The target first: making it binds it to the active unit.
        const tex = intTexture(gl, gl.RGBA8UI, TILE, TILE);
        gl.bindTexture(gl.TEXTURE_2D, parent);
        gl.uniform2i(p.loc('u_quadrant'), qx, qy);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        gl.viewport(0, 0, TILE, TILE);
        gl.disable(gl.BLEND);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        return tex;
    }

    /** A texture holding w x h pixels of `channels` interleaved bytes
     * (RGBA8UI, gray replicated): the root tile and the root mips. */
    upload(pixels, w, h) {
        const gl = this.gl, c = this.channels;
        const rgba = new Uint8Array(w * h * 4);
        for (let i = 0, j = 0; i < w * h; i++, j += c) {
            rgba[4 * i] = pixels[j];
            rgba[4 * i + 1] = pixels[j + (c === 3 ? 1 : 0)];
            rgba[4 * i + 2] = pixels[j + (c === 3 ? 2 : 0)];
            rgba[4 * i + 3] = 255;
        }
        const tex = intTexture(gl, gl.RGBA8UI, w, h);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, gl.RGBA_INTEGER, gl.UNSIGNED_BYTE, rgba);
        return tex;
    }

    /** The pixels of a w x h RGBA8UI texture as `channels` bytes each, rows
     * top first (for tests: compare with the CPU decoder). */
    read(tex, w, h) {
        const gl = this.gl, c = this.channels;
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
        const px = new Uint32Array(w * h * 4);
        gl.readPixels(0, 0, w, h, gl.RGBA_INTEGER, gl.UNSIGNED_INT, px);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        const out = new Uint8Array(w * h * c);
        for (let i = 0; i < w * h; i++)
            for (let k = 0; k < c; k++)
                out[i * c + k] = px[4 * i + k];
        return out;
    }

    release(tex) {
        this.gl.deleteTexture(tex);
    }

    dispose() {
        const gl = this.gl;
        gl.deleteProgram(this.prog.program);
        gl.deleteTexture(this.words);
        gl.deleteTexture(this.indices);
        gl.deleteTexture(this.coefs);
        gl.deleteFramebuffer(this.fbo);
        gl.deleteVertexArray(this.vao);
    }
}
