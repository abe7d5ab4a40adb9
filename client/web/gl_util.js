// gl_util.js - WebGL2 helpers: compiling programs from GLSL sources that
// are served by gigaviewd (the decode shader is the same file the server
// and the native client compile), with driver logs mapped to line numbers,
// and fetching those sources.

/** The text of a file under web/ (relative to the page). */
export async function fetchText(name) {
    const r = await fetch(new URL(`web/${name}`, document.baseURI));
    if (!r.ok)
        throw new Error(`cannot load web/${name}: HTTP ${r.status}`);
    return r.text();
}

/** The source with line numbers, for an error listing. */
export function numbered(src) {
    return src.split('\n').map((l, i) => `${String(i + 1).padStart(4)}: ${l}`).join('\n');
}

function compile(gl, type, src, name) {
    const sh = gl.createShader(type);
    gl.shaderSource(sh, src);
    gl.compileShader(sh);
    if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS) && !gl.isContextLost()) {
        const log = gl.getShaderInfoLog(sh);
        gl.deleteShader(sh);
        const e = new Error(`${name}: compile failed:\n${log}\n${numbered(src)}`);
        e.log = log;
        throw e;
    }
    return sh;
}

/**
 * Link a program from GLSL ES 3.00 bodies (without the #version line,
 * which is prepended here, as lib/gpu does on EGL for GV_GPU_PATH_WEBGL2).
 * Returns {program, loc(name)}.  Throws with the log and a numbered listing.
 */
export function program(gl, vertSrc, fragSrc, name) {
    const vs = compile(gl, gl.VERTEX_SHADER, `#version 300 es\n${vertSrc}`, `${name} (vertex)`);
    const fs = compile(gl, gl.FRAGMENT_SHADER, `#version 300 es\n${fragSrc}`, `${name} (fragment)`);
    const p = gl.createProgram();
    gl.attachShader(p, vs);
    gl.attachShader(p, fs);
    gl.linkProgram(p);
    gl.deleteShader(vs);
    gl.deleteShader(fs);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS) && !gl.isContextLost()) {
        const log = gl.getProgramInfoLog(p);
        gl.deleteProgram(p);
        throw new Error(`${name}: link failed:\n${log}`);
    }
    const cache = new Map();
    return {
        program: p,
        loc(u) {
            if (!cache.has(u))
                cache.set(u, gl.getUniformLocation(p, u));
            return cache.get(u);
        },
    };
}

/** An immutable integer texture with nearest filtering (integer
 * textures are incomplete with any other filter). */
export function intTexture(gl, format, w, h) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texStorage2D(gl.TEXTURE_2D, 1, format, w, h);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return t;
}

/**
 * A vertex array for quads of interleaved floats (x, y, u, v: a_pos and
 * a_uv of `prog`, 16 bytes a vertex), with its buffer: {vao, vbo}.  The
 * tile renderer and the ROI layer draw through one each.
 */
export function quadArrays(gl, prog) {
    const vao = gl.createVertexArray();
    const vbo = gl.createBuffer();
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, vbo);
    const pos = gl.getAttribLocation(prog.program, 'a_pos');
    const uv = gl.getAttribLocation(prog.program, 'a_uv');
    gl.enableVertexAttribArray(pos);
    gl.vertexAttribPointer(pos, 2, gl.FLOAT, false, 16, 0);
    gl.enableVertexAttribArray(uv);
    gl.vertexAttribPointer(uv, 2, gl.FLOAT, false, 16, 8);
    gl.bindVertexArray(null);
    return { vao, vbo };
}
