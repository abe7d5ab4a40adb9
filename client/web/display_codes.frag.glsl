// display_codes.frag.glsl - draw a decoded tile of 16-bit codes (a sample
// store's, codes_decode.js: a 513 x 513 x C R16UI array texture) through
// the display window and the channels' colours, the rule of
// lib/render/samples_region.c (docs/API.md, "Sample stores"):
//   t_c = table_c[code_c] (the window's table on codes 0 .. 65535);
//   one channel: gray t_0;
//   more: RGB_j = min(255, (sum_c t_c * colour_c[j] + 127) / 255), integers.
// The tables are a 256 x 256 x C R8UI array texture (table c's entry v at
// (v & 255, v >> 8, c)) and the colours a uniform, so a new window or new
// colours are an upload of C * 64 KiB: no tile is fetched or decoded again.
//
// Sampling as display.frag.glsl: each channel's codes bilinear
// (bilinear.glsl, up to three channels a call, only the store's fetched),
// rounded to a code, with the overlap's taps from the neighbours that own
// them; at a 1:1 view the weights are 0 and 1 and the output is the
// server's region byte for byte.

precision highp float;
precision highp int;
precision highp usampler2DArray;

uniform usampler2DArray u_tile;
uniform usampler2DArray u_right;   // tile (tx + 1, ty)
uniform usampler2DArray u_below;   // tile (tx, ty + 1)
uniform usampler2DArray u_diag;    // tile (tx + 1, ty + 1)
uniform ivec3 u_has;               // 1 where that neighbour is bound
uniform ivec2 u_max;               // last valid texel of the level in this texture
uniform int u_round;
uniform usampler2DArray u_tables;  // 256 x 256 x C R8UI
uniform int u_channels;            // C, 1 .. 8
uniform uvec3 u_colour[8];         // each channel's colour, 0 .. 255

in vec2 v_uv;
out vec4 o_color;

int g_first;    // the first of the channels texel() returns
int g_count;    // how many, 1 .. 3 (the same for every fragment of a draw)

// Layers g_first .. g_first + g_count - 1 of texel q of s (0 past them).
uvec3 layers(usampler2DArray s, ivec2 q)
{
    uvec3 t = uvec3(texelFetch(s, ivec3(q, g_first), 0).r, 0u, 0u);
    if (g_count > 1)
        t.y = texelFetch(s, ivec3(q, g_first + 1), 0).r;
    if (g_count > 2)
        t.z = texelFetch(s, ivec3(q, g_first + 2), 0).r;
    return t;
}

// Those channels of texel p (clamped to the level), from the texture that
// owns it, chosen once for them (most texels are the tile's own).
vec3 texel(ivec2 p)
{
    p = clamp(p, ivec2(0), u_max);
    if (p.x < 512 && p.y < 512)
        return vec3(layers(u_tile, p));
    if (p.x == 512 && p.y == 512 && u_has.z == 1)
        return vec3(layers(u_diag, ivec2(0)));
    if (p.x == 512 && u_has.x == 1)
        return vec3(layers(u_right, ivec2(0, p.y)));
    if (p.y == 512 && u_has.y == 1)
        return vec3(layers(u_below, ivec2(p.x, 0)));
    return vec3(layers(u_tile, p));
}

#include "bilinear.glsl"

uint windowed(float c, int k)
{
    int s = int(clamp(floor(c + 0.5), 0.0, 65535.0));
    return texelFetch(u_tables, ivec3(s & 255, s >> 8, k), 0).r;
}

void main()
{
    uvec3 acc = uvec3(0u);
    for (g_first = 0; g_first < u_channels; g_first += 3) {
        g_count = min(3, u_channels - g_first);
        vec3 c = bilinear(v_uv);
        uint t = windowed(c.x, g_first);
        if (u_channels == 1) {
            acc = uvec3(t * 255u);   // gray: (255 t + 127) / 255 = t
            break;
        }
        acc += t * u_colour[g_first];
        if (g_count > 1)
            acc += windowed(c.y, g_first + 1) * u_colour[g_first + 1];
        if (g_count > 2)
            acc += windowed(c.z, g_first + 2) * u_colour[g_first + 2];
    }
    vec3 rgb = vec3(min((acc + 127u) / 255u, uvec3(255u)));
    if (u_round == 1)
        rgb += 0.25;
    o_color = vec4(rgb / 255.0, 1.0);
}
