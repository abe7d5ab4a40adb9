// zfield_sweep.comp.glsl - one level of the z-field simplification sweep
// (lib/mesh/zfield.h; the paper's sections 4 and 5): every vertex of level
// u_level decides its enabled state from its error and its children's
// states, written by the previous level's dispatch.  The same operations
// in the same order as lib/mesh/zfield.c (activated(), child_enabled()),
// `precise` so that no fused multiply-add changes a rounding: the CPU and
// the GPU decide every vertex identically.  With GV_ZFIELD_PACK defined,
// the program instead packs 32 enabled states into a word for read-back
// (the paper's section 5.3 packs 8 into a byte).

#if defined(GL_ES)
#if defined(GL_EXT_gpu_shader5)
#extension GL_EXT_gpu_shader5 : enable
#define PRECISE precise
#elif defined(GL_OES_gpu_shader5)
#extension GL_OES_gpu_shader5 : enable
#define PRECISE precise
#else
#define PRECISE
#endif
#else
#define PRECISE precise
#endif

precision highp float;
precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Heights { float z[]; };
layout(std430, binding = 1) buffer Enabled { uint en[]; };
layout(std430, binding = 2) writeonly buffer Packed { uint packed_en[]; };

uniform int u_n;          // grid side, 2^k + 1
uniform int u_level;      // 0 .. 2k - 1
uniform int u_count;      // vertices of the level (or words to pack)
uniform int u_mode;       // 0: vertical, 1: screen
uniform float u_thr2;     // vertical: 2 tau
uniform float u_tau2;     // screen: tau^2
uniform float u_halfk;    // screen: K / 2
uniform float u_xy;       // world units per sample step
uniform vec3 u_eye;

int invocation()
{
    return int(gl_GlobalInvocationID.y) * int(gl_NumWorkGroups.x) * 64 +
           int(gl_GlobalInvocationID.x);
}

#ifdef GV_ZFIELD_PACK
void main()
{
    int w = invocation();
    if (w >= u_count)
        return;
    int total = u_n * u_n;
    uint bits = 0u;
    for (int b = 0; b < 32; b++) {
        int i = 32 * w + b;
        if (i < total && en[i] != 0u)
            bits |= 1u << uint(b);
    }
    packed_en[w] = bits;
}
#else
float zat(int x, int y) { return z[y * u_n + x]; }
bool on(int x, int y) { return en[y * u_n + x] != 0u; }

// Hypotenuse ends (a, c) and parents (p0, p1; -1 when outside) of the
// vertex (x,y) of spacing s: zfield.c vertex_geometry().
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

void main()
{
    int idx = invocation();
    if (idx >= u_count)
        return;
    int s = 1 << (u_level / 2);
    int w = (u_n - 1) / (2 * s);
    bool centre = (u_level & 1) == 1;
    int x, y;
    if (centre) {
        x = s * (2 * (idx % w) + 1);
        y = s * (2 * (idx / w) + 1);
    } else if (idx < w * (w + 1)) {          // horizontal edges
        x = s * (2 * (idx % w) + 1);
        y = 2 * s * (idx / w);
    } else {                                 // vertical edges
        int k = idx - w * (w + 1);
        x = 2 * s * (k % (w + 1));
        y = s * (2 * (k / (w + 1)) + 1);
    }
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
    en[y * u_n + x] = (act || child_enabled(x, y, s, centre)) ? 1u : 0u;
}
#endif
