// terrain_gl.js - the 3D terrain view's drawing: a TIN read from a glTF 2.0
// binary (GLB, as GET /v1/images/{id}/mesh?format=glb writes it:
// docs/MESHES.md) drawn in WebGL2 from an orbiting camera, shaded by a
// hillshade computed in the fragment shader or draped with an image.
//
// World frame: x east and z south in level-0 pixels of the height store,
// relative to the mesh's centre; y up, the height times an exaggeration
// chosen so that the relief's range is a tenth of the mesh's width.  The
// hillshade is Lambert's law for a sun in the north-west at 45 degrees
// (the cartographers' convention), with the face normal from the
// derivatives of the position (flat shading per triangle: the TIN itself
// shows).  A drape is a texture over the mesh's rectangle.

const VS = `#version 300 es
in vec3 a_pos;          // x, height, y (level samples; glTF +Y up)
uniform mat4 u_mvp;
uniform vec4 u_xy;      // level-0 pixels per level sample, centre x, centre y
uniform vec2 u_z;       // exaggeration, centre height
uniform vec4 u_rect;    // the drape's rectangle: x0, y0, 1/w, 1/h (level 0)
out vec3 v_world;
out vec2 v_uv;
void main() {
    vec2 p = a_pos.xz * u_xy.x;
    vec3 w = vec3(p.x - u_xy.y, (a_pos.y - u_z.y) * u_z.x, p.y - u_xy.z);
    v_world = w;
    v_uv = (p - u_rect.xy) * u_rect.zw;
    gl_Position = u_mvp * vec4(w, 1.0);
}`;

const FS = `#version 300 es
precision highp float;
in vec3 v_world;
in vec2 v_uv;
uniform sampler2D u_drape;
uniform int u_draped;
out vec4 o;
void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    if (n.y < 0.0) n = -n;
    float shade = max(dot(n, normalize(vec3(-1.0, 1.414, -1.0))), 0.0);
    if (u_draped == 1) {
        vec3 c = texture(u_drape, clamp(v_uv, 0.0, 1.0)).rgb;
        o = vec4(c * (0.55 + 0.45 * shade), 1.0);
    } else {
        o = vec4(vec3(0.15 + 0.85 * shade), 1.0);
    }
}`;

/**
 * Parse a GLB with one mesh (POSITION float vec3, uint32 indices) into
 * {pos: Float32Array, idx: Uint32Array, min, max, extras}.  Throws on a
 * file that is not such a GLB.
 */
export function parseGlb(buf) {
    const dv = new DataView(buf);
    if (dv.getUint32(0, true) !== 0x46546c67 || dv.getUint32(4, true) !== 2)
        throw new Error('not a glTF 2.0 binary');
    const jl = dv.getUint32(12, true);
    if (dv.getUint32(16, true) !== 0x4e4f534a)
        throw new Error('glb: no JSON chunk');
    const j = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 20, jl)));
    const binAt = 20 + jl;
    if (dv.getUint32(binAt + 4, true) !== 0x004e4942)
        throw new Error('glb: no BIN chunk');
    const bin = binAt + 8;
    const prim = j.meshes[0].primitives[0];
    const view = (acc) => {
        const a = j.accessors[acc], bv = j.bufferViews[a.bufferView];
        return { a, off: bin + (bv.byteOffset || 0) + (a.byteOffset || 0) };
    };
    const p = view(prim.attributes.POSITION), ix = view(prim.indices);
    if (p.a.componentType !== 5126 || p.a.type !== 'VEC3' || ix.a.componentType !== 5125)
        throw new Error('glb: expected float positions and uint32 indices');
    return {
        pos: new Float32Array(buf.slice(p.off, p.off + 12 * p.a.count)),
        idx: new Uint32Array(buf.slice(ix.off, ix.off + 4 * ix.a.count)),
        min: p.a.min, max: p.a.max, extras: (j.asset && j.asset.extras) || {},
    };
}

function compile(gl, type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS))
        throw new Error(`terrain shader: ${gl.getShaderInfoLog(s)}`);
    return s;
}

// 4x4 column-major helpers
function perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
}
function lookAt(e, c, up) {
    const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    const norm = (a) => { const l = Math.hypot(...a); return a.map((x) => x / l); };
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const z = norm(sub(e, c)), x = norm(cross(up, z)), y = cross(z, x);
    return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, e), -dot(y, e), -dot(z, e), 1];
}
function mul(a, b) {
    const o = new Array(16).fill(0);
    for (let c = 0; c < 4; c++)
        for (let r = 0; r < 4; r++)
            for (let k = 0; k < 4; k++)
                o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
    return o;
}

export class TerrainGl {
    /** canvas: the 3D view's own canvas (its own WebGL2 context). */
    constructor(canvas) {
        const gl = canvas.getContext('webgl2', { antialias: true, preserveDrawingBuffer: true });
        if (!gl)
            throw new Error('the terrain view needs WebGL2');
        this.gl = gl;
        this.canvas = canvas;
        const pr = gl.createProgram();
        gl.attachShader(pr, compile(gl, gl.VERTEX_SHADER, VS));
        gl.attachShader(pr, compile(gl, gl.FRAGMENT_SHADER, FS));
        gl.bindAttribLocation(pr, 0, 'a_pos');
        gl.linkProgram(pr);
        if (!gl.getProgramParameter(pr, gl.LINK_STATUS))
            throw new Error(`terrain program: ${gl.getProgramInfoLog(pr)}`);
        this.prog = pr;
        this.u = {};
        for (const n of ['u_mvp', 'u_xy', 'u_z', 'u_rect', 'u_drape', 'u_draped'])
            this.u[n] = gl.getUniformLocation(pr, n);
        this.vao = gl.createVertexArray();
        this.vbo = gl.createBuffer();
        this.ibo = gl.createBuffer();
        this.tex = gl.createTexture();
        this.count = 0;
        this.mesh = null;
        this.drape = null;
    }

    /** Upload a parsed mesh of level `level` (parseGlb). */
    setMesh(m, level) {
        const gl = this.gl;
        gl.bindVertexArray(this.vao);
        gl.bindBuffer(gl.ARRAY_BUFFER, this.vbo);
        gl.bufferData(gl.ARRAY_BUFFER, m.pos, gl.STATIC_DRAW);
        gl.enableVertexAttribArray(0);
        gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
        gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.ibo);
        gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, m.idx, gl.STATIC_DRAW);
        gl.bindVertexArray(null);
        this.count = m.idx.length;
        const s = 2 ** level;
        const x0 = m.min[0] * s, x1 = m.max[0] * s, y0 = m.min[2] * s, y1 = m.max[2] * s;
        const size = Math.max(x1 - x0, y1 - y0, 1);
        const range = Math.max(m.max[1] - m.min[1], 1e-6);
        this.mesh = { s, cx: (x0 + x1) / 2, cy: (y0 + y1) / 2, size, zc: (m.min[1] + m.max[1]) / 2,
            exag: 0.1 * size / range };
    }

    /** Drape an ImageBitmap over the level-0 rectangle [x0, y0, w, h], or
     * null for the hillshade. */
    setDrape(bitmap, rect) {
        const gl = this.gl;
        if (!bitmap) {
            this.drape = null;
            return;
        }
        gl.bindTexture(gl.TEXTURE_2D, this.tex);
        gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, bitmap);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
        this.drape = rect;
    }

    /** The eye in the world frame for azimuth az, elevation el (degrees)
     * at dist mesh sizes from the centre (a mesh must be set). */
    eye(az, el, dist) {
        const a = az * Math.PI / 180, e = el * Math.PI / 180, d = dist * this.mesh.size;
        // az 0: the camera south of the centre, looking north (-z)
        return [d * Math.cos(e) * Math.sin(a), d * Math.sin(e), d * Math.cos(e) * Math.cos(a)];
    }

    /** Draw from azimuth az (degrees, 0: looking north), elevation el
     * (degrees above the horizon), at dist mesh sizes from the centre. */
    draw(az, el, dist) {
        const gl = this.gl, c = this.canvas, m = this.mesh;
        gl.viewport(0, 0, c.width, c.height);
        gl.clearColor(0.03, 0.03, 0.03, 1);
        gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        if (!m || !this.count)
            return;
        gl.enable(gl.DEPTH_TEST);
        gl.useProgram(this.prog);
        const d = dist * m.size, eye = this.eye(az, el, dist);
        const mvp = mul(perspective(Math.PI / 4, c.width / c.height, d / 100, d * 4), lookAt(eye, [0, 0, 0], [0, 1, 0]));
        gl.uniformMatrix4fv(this.u.u_mvp, false, mvp);
        gl.uniform4f(this.u.u_xy, m.s, m.cx, m.cy, 0);
        gl.uniform2f(this.u.u_z, m.exag, m.zc);
        const r = this.drape || [0, 0, 1, 1];
        gl.uniform4f(this.u.u_rect, r[0], r[1], 1 / r[2], 1 / r[3]);
        gl.uniform1i(this.u.u_draped, this.drape ? 1 : 0);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, this.tex);
        gl.uniform1i(this.u.u_drape, 0);
        gl.bindVertexArray(this.vao);
        gl.drawElements(gl.TRIANGLES, this.count, gl.UNSIGNED_INT, 0);
        gl.bindVertexArray(null);
    }
}
