// zfield.js - z-field simplification in the browser (docs/MESHES.md,
// "Z-field simplification"; lib/mesh/zfield.h is the reference): the level
// sweep of "GPU z-field simplification" (../shared/reference/
// gpu-zfield-simplification.md, sections 4 and 5) run in WebGL2 from the
// very GLSL ES 3.00 files that lib/gpu/gpu_zfield.c compiles for its
// fragment path (shaders/zfield_rules.glsl, zfield_points.vert.glsl,
// zfield_sweep.frag.glsl, fullscreen.vert.glsl, served by gigaviewd under
// /web/), the same GL sequence as its run_fragment(): one GL_POINTS draw
// per level into two alternating R8UI targets, then a packing pass into
// RGBA32UI, read back.  The mesh is built here from the enabled states by
// the bintree traversal of gv_zfield_mesh (section 5.3): same vertices,
// same triangles, same order.
//
// zfieldEnableCpu() is the CPU sweep of zfield.c (no coarse phase) in
// float32 arithmetic (Math.fround after each operation, as C11 rounds
// each), for checking the GPU where no server is asked; decodePng16()
// reads the 16-bit gray PNG of GET /region?format=png16 (the height
// codes), through the browser's own DecompressionStream.

import { fetchText, program } from './gl_util.js';

const f32 = Math.fround;

/** The GLSL files the sweep compiles (served under web/). */
export const ZFIELD_SHADERS = ['zfield_rules.glsl', 'zfield_points.vert.glsl',
    'zfield_sweep.frag.glsl', 'fullscreen.vert.glsl'];

/** The sources of ZFIELD_SHADERS, fetched: {rules, points, sweep, fullscreen}. */
export async function loadZfieldSources() {
    const [rules, points, sweep, fullscreen] = await Promise.all(ZFIELD_SHADERS.map(fetchText));
    return { rules, points, sweep, fullscreen };
}

/** 1 if n = 2^k + 1 with 1 <= k and n <= 32769 (gv_zfield_side_ok). */
export function sideOk(n) {
    return Number.isInteger(n) && n >= 3 && n <= 32769 && ((n - 1) & (n - 2)) === 0;
}

/** The levels of a grid of side n: 2k (gv_zfield_levels). */
export function levels(n) {
    let k = 0;
    while ((1 << k) < n - 1) k++;
    return 2 * k;
}

/** The vertices of level lev (gv_zfield_level_count). */
export function levelCount(n, lev) {
    const s = 1 << (lev >> 1), w = (n - 1) / (2 * s);
    return lev % 2 ? w * w : 2 * w * (w + 1);
}

/** K of a camera: viewport height in pixels over 2 tan(fovy / 2). */
export function zfieldK(viewportHeight, fovy) {
    return f32(viewportHeight / (2 * Math.tan(fovy / 2)));
}

// The float32 values the sweep works with (gpu_zfield.c set_uniforms()).
function uniformsOf(p) {
    const thr = f32(p.threshold), k = f32(p.k || 0), eye = p.eye || [0, 0, 0];
    return {
        mode: p.mode === 'screen' ? 1 : 0, thr2: f32(2 * thr), tau2: f32(thr * thr),
        halfk: f32(0.5 * k), xy: p.xyScale > 0 ? f32(p.xyScale) : 1,
        eye: eye.map(f32),
    };
}

function checkParams(n, p) {
    if (!sideOk(n))
        throw new Error(`zfield: the grid must be (2^k+1) x (2^k+1) samples, 3 to 32769, not ${n}`);
    if (!(p.threshold >= 0) || !Number.isFinite(p.threshold) ||
        (p.mode === 'screen' && !(p.k > 0 && Number.isFinite(p.k))))
        throw new Error('zfield: bad threshold or camera');
}

/**
 * The sweep on a WebGL2 context.  gl: the context (its state is left
 * with the default framebuffer bound); src: loadZfieldSources().  Throws
 * if the programs do not compile or the targets are not renderable.
 */
export class ZFieldSweep {
    constructor(gl, src) {
        this.gl = gl;
        this.sweep = program(gl, src.rules + src.points, src.rules + src.sweep, 'zfield_sweep.frag.glsl');
        this.pack = program(gl, src.fullscreen, `#define GV_ZFIELD_PACK 1\n${src.rules}${src.sweep}`,
            'zfield_sweep.frag.glsl (pack)');
        this.fbo = [gl.createFramebuffer(), gl.createFramebuffer(), gl.createFramebuffer()];
        this.vao = gl.createVertexArray();
        this.tex = null;
        this.n = 0;
    }

    /** Upload the heights: z (Float32Array) of n x n samples, row-major. */
    heights(z, n) {
        if (!sideOk(n) || z.length !== n * n)
            throw new Error(`zfield: the grid must be (2^k+1) x (2^k+1) samples, not ${n}`);
        const gl = this.gl;
        if (this.tex)
            for (const t of this.tex) gl.deleteTexture(t);
        const mk = (fmt, w, h) => {
            const t = gl.createTexture();
            gl.bindTexture(gl.TEXTURE_2D, t);
            gl.texStorage2D(gl.TEXTURE_2D, 1, fmt, w, h);
            gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
            gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
            return t;
        };
        const ztex = mk(gl.R32F, n, n);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, n, n, gl.RED, gl.FLOAT, z);
        const targets = [mk(gl.R8UI, n, n), mk(gl.R8UI, n, n), mk(gl.RGBA32UI, (n + 127) >> 7, n)];
        for (let i = 0; i < 3; i++) {
            gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo[i]);
            gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, targets[i], 0);
            if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
                gl.bindFramebuffer(gl.FRAMEBUFFER, null);
                throw new Error('zfield: R8UI/RGBA32UI targets not renderable here');
            }
        }
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        this.tex = [ztex, ...targets];
        this.n = n;
    }

    /**
     * Decide every vertex: a Uint8Array(n * n) of 1 (enabled) or 0,
     * corners 1.  p: {mode: 'vertical' | 'screen', threshold, eye: [x, y,
     * z], k, xyScale} as struct gv_zfield_params (zfield.h).
     */
    enable(p) {
        const gl = this.gl, n = this.n;
        if (!n)
            throw new Error('zfield: no heights uploaded');
        checkParams(n, p);
        const u = uniformsOf(p), [ztex, s0, s1] = this.tex, state = [s0, s1];
        const zero = new Uint32Array(4);
        for (let i = 0; i < 2; i++) {
            gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo[i]);
            gl.clearBufferuiv(gl.COLOR, 0, zero);
        }
        const depth = gl.isEnabled(gl.DEPTH_TEST), blend = gl.isEnabled(gl.BLEND);
        gl.disable(gl.DEPTH_TEST);
        gl.disable(gl.BLEND);
        gl.bindVertexArray(this.vao);
        gl.viewport(0, 0, n, n);
        const sw = this.sweep;
        gl.useProgram(sw.program);
        gl.uniform1i(sw.loc('u_n'), n);
        gl.uniform1i(sw.loc('u_mode'), u.mode);
        gl.uniform1f(sw.loc('u_thr2'), u.thr2);
        gl.uniform1f(sw.loc('u_tau2'), u.tau2);
        gl.uniform1f(sw.loc('u_halfk'), u.halfk);
        gl.uniform1f(sw.loc('u_xy'), u.xy);
        gl.uniform3f(sw.loc('u_eye'), u.eye[0], u.eye[1], u.eye[2]);
        gl.uniform1i(sw.loc('u_z'), 0);
        gl.uniform1i(sw.loc('u_prev'), 1);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, ztex);
        const L = levels(n);
        for (let lev = 0; lev < L; lev++) {
            gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo[lev & 1]);
            gl.activeTexture(gl.TEXTURE1);
            gl.bindTexture(gl.TEXTURE_2D, state[(lev + 1) & 1]);
            gl.uniform1i(sw.loc('u_level'), lev);
            gl.drawArrays(gl.POINTS, 0, levelCount(n, lev));
        }
        // pack: 128 states of a row per RGBA32UI texel, from both targets
        const pw = (n + 127) >> 7, pk = this.pack;
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.fbo[2]);
        gl.viewport(0, 0, pw, n);
        gl.useProgram(pk.program);
        gl.uniform1i(pk.loc('u_n'), n);
        gl.uniform1i(pk.loc('u_prev'), 1);
        gl.uniform1i(pk.loc('u_other'), 2);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, s0);
        gl.activeTexture(gl.TEXTURE2);
        gl.bindTexture(gl.TEXTURE_2D, s1);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
        const px = new Uint32Array(pw * n * 4);
        gl.pixelStorei(gl.PACK_ALIGNMENT, 4);
        gl.readPixels(0, 0, pw, n, gl.RGBA_INTEGER, gl.UNSIGNED_INT, px);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.bindVertexArray(null);
        gl.activeTexture(gl.TEXTURE0);
        if (depth) gl.enable(gl.DEPTH_TEST);
        if (blend) gl.enable(gl.BLEND);
        const en = new Uint8Array(n * n);
        for (let y = 0; y < n; y++)
            for (let x = 0; x < n; x++) {
                const w = px[(y * pw + (x >> 7)) * 4 + ((x & 127) >> 5)];
                en[y * n + x] = (w >>> (x & 31)) & 1;
            }
        en[0] = en[n - 1] = en[(n - 1) * n] = en[n * n - 1] = 1;
        return en;
    }

    /** Free the GL objects. */
    dispose() {
        const gl = this.gl;
        if (this.tex)
            for (const t of this.tex) gl.deleteTexture(t);
        for (const f of this.fbo) gl.deleteFramebuffer(f);
        gl.deleteVertexArray(this.vao);
        gl.deleteProgram(this.sweep.program);
        gl.deleteProgram(this.pack.program);
        this.tex = null;
        this.n = 0;
    }
}

// ---- the CPU sweep (zfield.c sweep(), activated(), child_enabled()) ----

// Hypotenuse ends and parents of (x,y) of spacing s (vertex_geometry()).
function geometry(n, x, y, s) {
    const xo = (x / s) & 1, yo = (y / s) & 1;
    let a, c, p;
    if (xo && yo) {
        const i = Math.floor(x / (2 * s)), j = Math.floor(y / (2 * s));
        if (((i + j) & 1) === 0) {
            a = [x - s, y - s]; c = [x + s, y + s]; p = [[x + s, y - s], [x - s, y + s]];
        } else {
            a = [x + s, y - s]; c = [x - s, y + s]; p = [[x - s, y - s], [x + s, y + s]];
        }
    } else if (xo) {
        a = [x - s, y]; c = [x + s, y]; p = [[x, y - s], [x, y + s]];
    } else {
        a = [x, y - s]; c = [x, y + s]; p = [[x - s, y], [x + s, y]];
    }
    return { a, c, p: p.filter((q) => q[0] >= 0 && q[1] >= 0 && q[0] < n && q[1] < n) };
}

/** The enabled states of the CPU sweep: same arguments as
 * ZFieldSweep.enable() with the heights z (Float32Array) of side n. */
export function zfieldEnableCpu(z, n, p) {
    checkParams(n, p);
    const u = uniformsOf(p), en = new Uint8Array(n * n), L = levels(n);
    const on = (x, y) => en[y * n + x] !== 0;
    for (let lev = 0; lev < L; lev++) {
        const s = 1 << (lev >> 1), centre = lev % 2 === 1;
        for (let y = 0; y < n; y += s)
            for (let x = 0; x < n; x += s) {
                const xo = (x / s) & 1, yo = (y / s) & 1;
                if (centre ? !(xo && yo) : xo === yo)
                    continue;
                const g = geometry(n, x, y, s), b = z[y * n + x];
                const t = f32(2 * b - z[g.a[1] * n + g.a[0]]);
                const d2 = Math.abs(f32(t - z[g.c[1] * n + g.c[0]]));
                let act;
                if (u.mode === 0) {
                    act = d2 > u.thr2;
                } else {
                    const e = f32(d2 * u.halfk);
                    const dx = f32(f32(x * u.xy) - u.eye[0]);
                    const dy = f32(f32(y * u.xy) - u.eye[1]);
                    const dz = f32(b - u.eye[2]);
                    const dd = f32(f32(f32(dx * dx) + f32(dy * dy)) + f32(dz * dz));
                    act = f32(e * e) > f32(u.tau2 * dd);
                }
                let child = false;
                if (!act && centre) {
                    child = (x >= s && on(x - s, y)) || (x + s < n && on(x + s, y)) ||
                        (y >= s && on(x, y - s)) || (y + s < n && on(x, y + s));
                } else if (!act && s > 1) {
                    const h = s / 2;
                    for (let k = 0; k < 4 && !child; k++) {
                        const cx = x + (k & 1 ? h : -h), cy = y + (k & 2 ? h : -h);
                        if (cx < 0 || cy < 0 || cx >= n || cy >= n || !on(cx, cy))
                            continue;
                        child = geometry(n, cx, cy, h).p.some((q) => q[0] === x && q[1] === y);
                    }
                }
                en[y * n + x] = act || child ? 1 : 0;
            }
    }
    en[0] = en[n - 1] = en[(n - 1) * n] = en[n * n - 1] = 1;
    return en;
}

// ---- the mesh (zfield.c gv_zfield_mesh()) ----

/**
 * The mesh of the enabled vertices: {vx, vy (Uint32Array: grid columns
 * and rows), vz (Float32Array), tris (Uint32Array, 3 per triangle,
 * counter-clockwise with y as a math axis)}: the bintree cut where the
 * hypotenuse midpoint is disabled, depth first from the root triangles on
 * the diagonal (0,0)-(n-1,n-1), vertices numbered by first use after the
 * four corners, exactly as gv_zfield_mesh numbers and orders them.
 */
export function zfieldMesh(z, n, en) {
    const index = new Uint32Array(n * n);
    let vx = new Uint32Array(256), vy = new Uint32Array(256), vz = new Float32Array(256);
    let tris = new Uint32Array(768), nv = 0, nt = 0;
    const vertex = (x, y) => {
        const i = y * n + x;
        if (index[i])
            return index[i] - 1;
        if (nv === vx.length) {
            const grow = (a, T) => { const b = new T(2 * a.length); b.set(a); return b; };
            vx = grow(vx, Uint32Array); vy = grow(vy, Uint32Array); vz = grow(vz, Float32Array);
        }
        vx[nv] = x; vy[nv] = y; vz[nv] = z[i];
        index[i] = ++nv;
        return nv - 1;
    };
    const emit = (ax, ay, px, py, cx, cy) => {
        if (3 * nt + 3 > tris.length) {
            const b = new Uint32Array(2 * tris.length);
            b.set(tris);
            tris = b;
        }
        const o = (px - ax) * (cy - ay) - (py - ay) * (cx - ax);
        const va = vertex(ax, ay), vp = vertex(px, py), vc = vertex(cx, cy);
        tris[3 * nt] = va;
        tris[3 * nt + 1] = o > 0 ? vp : vc;
        tris[3 * nt + 2] = o > 0 ? vc : vp;
        nt++;
    };
    const refine = (...root) => {
        const st = [root];
        while (st.length) {
            const [a0, a1, p0, p1, c0, c1] = st.pop();
            const sx = a0 + c0, sy = a1 + c1;
            if ((sx | sy) & 1 || !en[(sy / 2) * n + sx / 2]) {
                emit(a0, a1, p0, p1, c0, c1);
                continue;
            }
            const mx = sx / 2, my = sy / 2;
            st.push([c0, c1, mx, my, p0, p1]);
            st.push([p0, p1, mx, my, a0, a1]);
        }
    };
    const e = n - 1;
    vertex(0, 0); vertex(e, 0); vertex(e, e); vertex(0, e);
    refine(0, 0, e, 0, e, e);
    refine(e, e, 0, e, 0, 0);
    return { vx: vx.slice(0, nv), vy: vy.slice(0, nv), vz: vz.slice(0, nv), tris: tris.slice(0, 3 * nt) };
}

// ---- the height grid: GET /region?format=png16 ----

/** Decode a 16-bit gray PNG (what /region?format=png16 writes): {width,
 * height, codes: Uint16Array}.  Throws on any other PNG. */
export async function decodePng16(buf) {
    const b = new Uint8Array(buf), dv = new DataView(b.buffer, b.byteOffset, b.byteLength);
    const sig = [137, 80, 78, 71, 13, 10, 26, 10];
    if (b.length < 8 || sig.some((v, i) => b[i] !== v))
        throw new Error('png16: not a PNG');
    let at = 8, w = 0, h = 0;
    const idat = [];
    while (at + 8 <= b.length) {
        const len = dv.getUint32(at), type = String.fromCharCode(...b.subarray(at + 4, at + 8));
        if (at + 12 + len > b.length)
            throw new Error('png16: truncated');
        const data = b.subarray(at + 8, at + 8 + len);
        if (type === 'IHDR') {
            w = dv.getUint32(at + 8);
            h = dv.getUint32(at + 12);
            if (data[8] !== 16 || data[9] !== 0 || data[12] !== 0)
                throw new Error('png16: not a 16-bit gray non-interlaced PNG');
        } else if (type === 'IDAT') {
            idat.push(data);
        } else if (type === 'IEND') {
            break;
        }
        at += 12 + len;
    }
    if (!w || !h || w * h > 1 << 26)
        throw new Error('png16: bad size');
    const stream = new Blob(idat).stream().pipeThrough(new DecompressionStream('deflate'));
    const raw = new Uint8Array(await new Response(stream).arrayBuffer());
    const stride = 2 * w;
    if (raw.length < h * (stride + 1))
        throw new Error('png16: short image data');
    const out = new Uint8Array(h * stride), codes = new Uint16Array(w * h);
    for (let y = 0; y < h; y++) {
        const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
        const row = out.subarray(y * stride, (y + 1) * stride), up = y ? out.subarray((y - 1) * stride, y * stride) : null;
        for (let i = 0; i < stride; i++) {
            const a = i >= 2 ? row[i - 2] : 0, u = up ? up[i] : 0, c = up && i >= 2 ? up[i - 2] : 0;
            let v;
            switch (f) {
            case 0: v = 0; break;
            case 1: v = a; break;
            case 2: v = u; break;
            case 3: v = (a + u) >> 1; break;
            case 4: {
                const p = a + u - c, pa = Math.abs(p - a), pb = Math.abs(p - u), pc = Math.abs(p - c);
                v = pa <= pb && pa <= pc ? a : pb <= pc ? u : c;
                break;
            }
            default: throw new Error(`png16: bad filter ${f}`);
            }
            row[i] = (src[i] + v) & 255;
        }
        for (let x = 0; x < w; x++)
            codes[y * w + x] = (row[2 * x] << 8) | row[2 * x + 1];
    }
    return { width: w, height: h, codes };
}

/** The heights of codes as gigaviewd computes them ((float)(code * scale
 * + offset), route_mesh.c): a Float32Array. */
export function heightsOf(codes, scale, offset) {
    const z = new Float32Array(codes.length);
    for (let i = 0; i < codes.length; i++)
        z[i] = codes[i] * scale + offset;
    return z;
}
