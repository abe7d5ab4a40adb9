// display.frag.glsl - draw a decoded tile (RGBA8UI, so no hardware
// filtering): bilinear interpolation of the four texels around the
// sample, with the taps clamped to the level's last pixel, exactly the
// sampling of `gigaview render` (client/cmd/cmd_render.c).  At a 1:1 view of
// a level (integer zoom, no rotation, pixel centres on texel centres) the
// weights are 0 and 1 and the output is the decoded pixel itself.
//
// A tile's last column and row (512) overlap its right and lower
// neighbours, whose own decode of those pixels may differ slightly (each
// tile is coded on its own).  Every decoder takes such a pixel from the
// neighbour (docs/FORMAT.md section 2), so the taps there are read from
// the neighbours' textures when they are resident (u_has), and from the
// tile's own overlap otherwise: no seams either way.
//
// u_round: 1 when the fragment is written alone (no blending): the value
// is rounded here and nudged by a quarter step so that a conversion to
// 8 bits that truncates gives the same byte as one that rounds.  0 when
// it is blended with the coarser level (renderer.js), which rounds once
// at the end.
//
// u_window: 1 when a display window is set (client/web/window.js): the
// bilinear value, rounded to a sample, is looked up in u_lut (256 x 1
// RGBA8UI, texel v holding the red, green and blue tables at v), so the
// window changes by a texture upload, never a tile.  At a 1:1 view the
// output is the server's `window=` region byte for byte.

precision highp float;
precision highp int;
precision highp usampler2D;

uniform usampler2D u_tile;
uniform usampler2D u_right;   // tile (tx + 1, ty)
uniform usampler2D u_below;   // tile (tx, ty + 1)
uniform usampler2D u_diag;    // tile (tx + 1, ty + 1)
uniform ivec3 u_has;          // 1 where that neighbour is bound
uniform ivec2 u_max;          // last valid texel of the level in this texture
uniform int u_round;
uniform usampler2D u_lut;
uniform int u_window;

in vec2 v_uv;
out vec4 o_color;

vec3 texel(ivec2 p)
{
    p = clamp(p, ivec2(0), u_max);
    uvec4 t;
    if (p.x == 512 && p.y == 512 && u_has.z == 1)
        t = texelFetch(u_diag, ivec2(0), 0);
    else if (p.x == 512 && u_has.x == 1)
        t = texelFetch(u_right, ivec2(0, p.y), 0);
    else if (p.y == 512 && u_has.y == 1)
        t = texelFetch(u_below, ivec2(p.x, 0), 0);
    else
        t = texelFetch(u_tile, p, 0);
    return vec3(t.rgb);
}

#include "bilinear.glsl"

void main()
{
    vec3 c = bilinear(v_uv);
    if (u_window == 1) {
        ivec3 s = ivec3(clamp(floor(c + 0.5), 0.0, 255.0));
        c = vec3(float(texelFetch(u_lut, ivec2(s.r, 0), 0).r),
                 float(texelFetch(u_lut, ivec2(s.g, 0), 0).g),
                 float(texelFetch(u_lut, ivec2(s.b, 0), 0).b));
    }
    if (u_round == 1)
        c = floor(c + 0.5) + 0.25;
    o_color = vec4(c / 255.0, 1.0);
}
