// height_decode.frag.glsl - decode one height tile (docs/FORMAT.md section
// 12) into a 513x513 R16UI target, bit for bit what lib/codec/height_tile.c
// gv_height_tile_decode produces: the Catmull-Rom prediction from the
// decoded parent (an R16UI texture read with texelFetch) plus q (2e + 1),
// clamped to 0..65535, in 32-bit integers.
//
// One source for both GPU paths, as tile_decode.frag.glsl: with GV_SSBO
// (GLSL ES 3.10, GLSL 4.30) q comes from the storage buffer that
// height_rans.comp.glsl filled; without (WebGL2, GLSL ES 3.00) from an
// R32I texture the CPU decoded (client/web/heighttile.js in the browser).
//
// With GV_LAYERED (the browser's sample stores, client/web/codes_decode.js)
// the parent is one layer, u_layer, of a 513x513xC R16UI array texture that
// holds a tile's C channels, and the target a layer of the child's: one
// texture a tile whatever its channels, the arithmetic unchanged.

precision highp float;
precision highp int;
precision highp usampler2D;
precision highp isampler2D;

#ifdef GV_LAYERED
precision highp usampler2DArray;
uniform usampler2DArray u_parent;   // decoded parent tile, 513x513xC, R16UI
uniform int u_layer;                // the channel decoded
int parent_at(ivec2 p) { return int(texelFetch(u_parent, ivec3(p, u_layer), 0).r); }
#else
uniform usampler2D u_parent;   // decoded parent tile, 513x513, R16UI
int parent_at(ivec2 p) { return int(texelFetch(u_parent, p, 0).r); }
#endif
uniform ivec2 u_quadrant;      // (tx & 1, ty & 1)
uniform int u_e;               // the half-step e of the buffer
uniform int u_coded;           // 0: prediction only (q = 0)

#ifdef GV_SSBO
layout(std430, binding = 1) readonly buffer Residuals { int q[]; };
int q_at(ivec2 p) { return q[p.y * 513 + p.x]; }
#else
uniform isampler2D u_q;        // 513x513 R32I
int q_at(ivec2 p) { return texelFetch(u_q, p, 0).r; }
#endif

out uvec4 o_height;

// Catmull-Rom weights in 128ths at the quarter offsets (FORMAT.md 3).
int weight(int odd, int k)
{
    if (odd == 0)
        return k == 0 ? -3 : (k == 1 ? 29 : (k == 2 ? 111 : -9));
    return k == 0 ? -9 : (k == 1 ? 111 : (k == 2 ? 29 : -3));
}

void main()
{
    ivec2 p = ivec2(gl_FragCoord.xy);
    if (p.x > 512 || p.y > 512)
        discard;
    int px = 256 * u_quadrant.x + (p.x >> 1) + ((p.x & 1) != 0 ? -1 : -2);
    int py = 256 * u_quadrant.y + (p.y >> 1) + ((p.y & 1) != 0 ? -1 : -2);
    int s = 0;
    for (int j = 0; j < 4; j++) {
        int row = clamp(py + j, 0, 512);
        int h = 0;
        for (int i = 0; i < 4; i++)
            h += weight(p.x & 1, i) * parent_at(ivec2(clamp(px + i, 0, 512), row));
        s += weight(p.y & 1, j) * h;
    }
    int pred = clamp(s + 8192, 0, 65535 * 16384 + 16383) >> 14;
    int v = pred;
    if (u_coded != 0) {
        int step = 2 * u_e + 1;
        int lim = 65535 / step + 1;   // past it the clamp below decides
        v = pred + clamp(q_at(p), -lim, lim) * step;
    }
    o_height = uvec4(uint(clamp(v, 0, 65535)), 0u, 0u, 1u);
}
