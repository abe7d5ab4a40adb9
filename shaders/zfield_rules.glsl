// zfield_rules.glsl - the rules of the z-field simplification sweep
// (lib/mesh/zfield.h; the paper's sections 3 and 4), shared by its two
// variants: zfield_sweep.comp.glsl (compute, GLSL ES 3.10 / 4.30) and
// zfield_sweep.frag.glsl with zfield_points.vert.glsl (fragment, GLSL ES
// 3.00: WebGL2 runs it).  Each variant defines zat() and on() over its
// own storage and calls vertex_of() and decide().  The same operations in
// the same order as lib/mesh/zfield.c (activated(), child_enabled()):
// only +, - and *, each correctly rounded, `precise` where the language
// has it, so that every vertex is decided as on the CPU.

#if defined(GL_ES) && __VERSION__ >= 310
#if defined(GL_EXT_gpu_shader5)
#extension GL_EXT_gpu_shader5 : enable
#define PRECISE precise
#elif defined(GL_OES_gpu_shader5)
#extension GL_OES_gpu_shader5 : enable
#define PRECISE precise
#else
#define PRECISE
#endif
#elif defined(GL_ES)
#define PRECISE
#else
#define PRECISE precise
#endif

precision highp float;
precision highp int;

uniform int u_n;          // grid side, 2^k + 1
uniform int u_level;      // 0 .. 2k - 1
uniform int u_mode;       // 0: vertical, 1: screen
uniform float u_thr2;     // vertical: 2 tau
uniform float u_tau2;     // screen: tau^2
uniform float u_halfk;    // screen: K / 2
uniform float u_xy;       // world units per sample step
uniform vec3 u_eye;

float zat(int x, int y);  // the height of sample (x,y)
bool on(int x, int y);    // the state of (x,y), decided one level below

// Vertex `idx` of level u_level: horizontal edge midpoints, then vertical
// ones (even levels), or block centres (odd levels).
ivec2 vertex_of(int idx)
{
    int s = 1 << (u_level / 2);
    int w = (u_n - 1) / (2 * s);
    if ((u_level & 1) == 1)
        return ivec2(s * (2 * (idx % w) + 1), s * (2 * (idx / w) + 1));
    if (idx < w * (w + 1))
        return ivec2(s * (2 * (idx % w) + 1), 2 * s * (idx / w));
    int k = idx - w * (w + 1);
    return ivec2(2 * s * (k % (w + 1)), s * (2 * (k / (w + 1)) + 1));
}

// Hypotenuse ends (a, c) and parents (p0, p1) of the vertex (x,y) of
// spacing s: zfield.c vertex_geometry().
void geometry(int x, int y, int s, out ivec2 a, out ivec2 c, out ivec2 p0, out ivec2 p1)
{
    bool xo = ((x / s) & 1) == 1, yo = ((y / s) & 1) == 1;
    if (xo && yo) {
        int i = x / (2 * s), j = y / (2 * s);
        if (((i + j) & 1) == 0) {
            a = ivec2(x - s, y - s); c = ivec2(x + s, y + s);
            p0 = ivec2(x + s, y - s); p1 = ivec2(x - s, y + s);
        } else {
            a = ivec2(x + s, y - s); c = ivec2(x - s, y + s);
            p0 = ivec2(x - s, y - s); p1 = ivec2(x + s, y + s);
        }
    } else if (xo) {
        a = ivec2(x - s, y); c = ivec2(x + s, y);
        p0 = ivec2(x, y - s); p1 = ivec2(x, y + s);
    } else {
        a = ivec2(x, y - s); c = ivec2(x, y + s);
        p0 = ivec2(x - s, y); p1 = ivec2(x + s, y);
    }
}

bool child_enabled(int x, int y, int s, bool centre)
{
    int n = u_n;
    if (centre)
        return (x >= s && on(x - s, y)) || (x + s < n && on(x + s, y)) ||
               (y >= s && on(x, y - s)) || (y + s < n && on(x, y + s));
    if (s == 1)
        return false;
    int h = s / 2;
    for (int k = 0; k < 4; k++) {
        int cx = x + ((k & 1) != 0 ? h : -h), cy = y + ((k & 2) != 0 ? h : -h);
        if (cx < 0 || cy < 0 || cx >= n || cy >= n || !on(cx, cy))
            continue;
        ivec2 a, c, p0, p1;
        geometry(cx, cy, h, a, c, p0, p1);
        if (p0 == ivec2(x, y) || p1 == ivec2(x, y))
            return true;
    }
    return false;
}

// The enabled state of vertex (x,y) of level u_level.
bool decide(int x, int y)
{
    int s = 1 << (u_level / 2);
    ivec2 a, c, p0, p1;
    geometry(x, y, s, a, c, p0, p1);
    float b = zat(x, y);
    PRECISE float t = 2.0 * b - zat(a.x, a.y);
    PRECISE float d2 = abs(t - zat(c.x, c.y));
    bool act;
    if (u_mode == 0) {
        act = d2 > u_thr2;
    } else {
        PRECISE float e = d2 * u_halfk;
        PRECISE float dx = float(x) * u_xy - u_eye.x;
        PRECISE float dy = float(y) * u_xy - u_eye.y;
        PRECISE float dz = b - u_eye.z;
        PRECISE float dd = dx * dx + dy * dy + dz * dz;
        PRECISE float lhs = e * e;
        PRECISE float rhs = u_tau2 * dd;
        act = lhs > rhs;
    }
    return act || child_enabled(x, y, s, (u_level & 1) == 1);
}
