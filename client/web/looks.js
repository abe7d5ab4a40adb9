// looks.js - what turns a decoded tile into display colours: the
// textures and uniforms the tile renderer's fragment shader takes beside
// the tiles (renderer.js calls bind() once a draw, on texture unit 4).
// One look a kind of store, each with its shader:
//   - ImageLook (display.frag.glsl): 8-bit tiles, optionally through the
//     display window's 256-entry tables (window.js lutBytes);
//   - CodesLook (display_codes.frag.glsl): 16-bit codes through a table
//     of 65,536 entries per channel, resolved as gigaviewd resolves a
//     region (docs/API.md): a sample store's window on its codes and its
//     channels' colours ("Sample stores"), or a height store's gray
//     (lib/render/height_region.c gv_height_gray) through the optional
//     8-bit window, composed into one table.
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

// A height store's gray for each code (gv_height_gray, the same double
// operations in the same order): e the image document's `elevation`.
function heightGray(e) {
    const t = new Uint8Array(65536);
    if (!(e.max > e.min))
        return t;
    for (let c = 0; c < 65536; c++) {
        const v = c * e.scale + e.offset;
        const g = Math.floor(255 * (v - e.min) / (e.max - e.min) + 0.5);
        t[c] = g < 0 ? 0 : g > 255 ? 255 : g;
    }
    return t;
}

export class CodesLook {
    /** gl; info: the image document of a sample or height store. */
    constructor(gl, info) {
        this.gl = gl;
        this.info = info;
        this.channels = info.channels;
        this.target = gl.TEXTURE_2D_ARRAY;
        this.gray = info.samples ? null : heightGray(info.elevation);
        this.tables = tableTexture(gl, gl.TEXTURE_2D_ARRAY, gl.R8UI, 256, 256, this.channels);
        this.built = new Array(this.channels).fill('');   // each layer's window, as text
        this.colour = new Uint32Array(24);
        this.set(null, null);
    }

    // Channel k's table for window channel ck (null: none).
    table(ck) {
        if (!this.gray)
            return buildTable(ck, 65535);
        if (!ck)
            return this.gray;
        const w8 = buildTable(ck), t = new Uint8Array(65536);
        for (let c = 0; c < 65536; c++)
            t[c] = w8[this.gray[c]];
        return t;
    }

    /**
     * Show the codes through window text `win` (a `window` value; null:
     * the store's default, else none; 'none': none) and colours text
     * `colours` (null: the store's, else the palette): what a region
     * request with those parameters gets.  A sample store's window is on
     * its codes (none: the codes' range), a height store's on its 8-bit
     * gray (none: the gray itself).
     */
    set(win, colours) {
        const gl = this.gl, info = this.info, c = this.channels, max = info.samples ? 65535 : 255;
        let w = win && win !== 'none' ? parseWindow(win, max) : null;
        if (!w && win !== 'none' && info.window)
            w = parseWindow(info.window, max);
        if (w && w.length !== 1 && w.length !== c)
            w = null;
        if (!w && info.samples)
            w = defaultSampleWindow(info.samples);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.tables);
        for (let k = 0; k < c; k++) {
            const ck = w ? channelWindow(w, k) : null;
            const text = ck ? `${ck.black},${ck.white},${ck.gammaMilli}` : 'none';
            if (this.built[k] === text)
                continue;
            gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, k, 256, 256, 1, gl.RED_INTEGER,
                gl.UNSIGNED_BYTE, this.table(ck));
            this.built[k] = text;
        }
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, null);
        this.colour.fill(0);
        sampleColours(colours, info.metadata, c).forEach((hex, k) => {
            for (let j = 0; j < 3; j++)
                this.colour[3 * k + j] = parseInt(hex.slice(2 * j, 2 * j + 2), 16);
        });
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
