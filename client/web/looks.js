// looks.js - what turns a decoded tile into display colours: the
// textures and uniforms the tile renderer's fragment shader takes beside
// the tiles (renderer.js calls bind() once a draw, on texture unit 4).
// One look a kind of store, each with its shader:
//   - ImageLook (display.frag.glsl): 8-bit tiles, optionally through the
//     display window's 256-entry tables (window.js lutBytes);
//   - CodesLook (display_codes.frag.glsl): a sample store's 16-bit codes
//     through the window's tables on codes and the channels' colours,
//     resolved as gigaviewd resolves them for a region (docs/API.md,
//     "Sample stores").
// Changing a look uploads a small texture: no tile is fetched or decoded.

import { buildTable, channelWindow, defaultSampleWindow, parseWindow, sampleColours } from './window.js';

const UNIT = 4;   // the texture unit of a look's table

function tableTexture(gl, target, format, w, h, layers) {
    const t = gl.createTexture();
    gl.bindTexture(target, t);
    if (target === gl.TEXTURE_2D_ARRAY)
        gl.texStorage3D(target, 1, format, w, h, layers);
    else
        gl.texStorage2D(target, 1, format, w, h);
    for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.NEAREST], [gl.TEXTURE_MAG_FILTER, gl.NEAREST]])
        gl.texParameteri(target, k, v);
    return t;
}

export class ImageLook {
    constructor(gl) {
        this.gl = gl;
        this.target = gl.TEXTURE_2D;     // what a decoded tile is
        this.lut = null;
        this.on = false;
    }

    /** The display window's tables: bytes, 256 RGBA texels (window.js
     * lutBytes), or null for none.  An upload of 1 KiB. */
    setLut(bytes) {
        const gl = this.gl;
        this.on = !!bytes;
        if (!bytes)
            return;
        if (!this.lut)
            this.lut = tableTexture(gl, gl.TEXTURE_2D, gl.RGBA8UI, 256, 1);
        gl.bindTexture(gl.TEXTURE_2D, this.lut);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, 256, 1, gl.RGBA_INTEGER, gl.UNSIGNED_BYTE, bytes);
        gl.bindTexture(gl.TEXTURE_2D, null);
    }

    /** Set the uniforms and texture of program P (in use). */
    bind(gl, P) {
        gl.uniform1i(P.loc('u_lut'), UNIT);
        gl.uniform1i(P.loc('u_window'), this.on ? 1 : 0);
        if (this.on) {
            gl.activeTexture(gl.TEXTURE0 + UNIT);
            gl.bindTexture(gl.TEXTURE_2D, this.lut);
        }
    }

    dispose() {
        if (this.lut)
            this.gl.deleteTexture(this.lut);
    }
}

export class CodesLook {
    /** gl; info: the image document of a sample store. */
    constructor(gl, info) {
        this.gl = gl;
        this.info = info;
        this.channels = info.channels;
        this.target = gl.TEXTURE_2D_ARRAY;
        this.tables = tableTexture(gl, gl.TEXTURE_2D_ARRAY, gl.R8UI, 256, 256, this.channels);
        this.built = new Array(this.channels).fill('');   // each layer's window, as text
        this.colour = new Uint32Array(24);
        this.set(null, null);
    }

    /**
     * Show the codes through window text `win` (a `window` value; null:
     * the store's default, else the codes' range; 'none': the codes'
     * range) and colours text `colours` (null: the store's, else the
     * palette): what a region request with those parameters gets.
     * Returns the window and colours used: {window, colours}.
     */
    set(win, colours) {
        const gl = this.gl, info = this.info, c = this.channels;
        let w = win && win !== 'none' ? parseWindow(win, 65535) : null;
        if (!w && win !== 'none' && info.window)
            w = parseWindow(info.window, 65535);
        if (!w || (w.length !== 1 && w.length !== c))
            w = defaultSampleWindow(info.samples);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.tables);
        for (let k = 0; k < c; k++) {
            const ck = channelWindow(w, k), text = `${ck.black},${ck.white},${ck.gammaMilli}`;
            if (this.built[k] === text)
                continue;
            gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, k, 256, 256, 1, gl.RED_INTEGER,
                gl.UNSIGNED_BYTE, buildTable(ck, 65535));
            this.built[k] = text;
        }
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, null);
        const list = sampleColours(colours, info.metadata, c);
        this.colour.fill(0);
        list.forEach((hex, k) => {
            for (let j = 0; j < 3; j++)
                this.colour[3 * k + j] = parseInt(hex.slice(2 * j, 2 * j + 2), 16);
        });
        return { window: w, colours: list };
    }

    bind(gl, P) {
        gl.uniform1i(P.loc('u_tables'), UNIT);
        gl.uniform1i(P.loc('u_channels'), this.channels);
        gl.uniform3uiv(P.loc('u_colour[0]'), this.colour);
        gl.activeTexture(gl.TEXTURE0 + UNIT);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.tables);
    }

    dispose() {
        this.gl.deleteTexture(this.tables);
    }
}
