// tile_decode.frag.glsl - decode one gigaview tile (docs/FORMAT.md,
// sections 3 and 4) into a 513x513 RGBA8UI target, bit for bit what the CPU
// reference decoder (lib/codec/tile_decode.c, lib/codec/predict.c) produces.
//
// One source for every GPU decoder: the embedding program prepends the
// #version line and, where shader storage buffers exist (GLSL ES 3.10+,
// GLSL 4.30), "#define GV_SSBO 1"; WebGL2 (GLSL ES 3.00) reads the tile
// buffer from an R32UI texture instead, u_words_width words per row.  Both
// variants are tested bit for bit on EGL (tests/test_gpu_decode.c).
// Integer arithmetic only: the parent is an RGBA8UI texture read with
// texelFetch, so no filtering or float rounding takes part.  Entropy-coded
// tiles (byte 0 bit 7) need their indices decoded first: by
// rans_decode.comp.glsl where there are compute shaders, on the CPU
// otherwise (WebGL2), uploaded as a texture.  Transform-coded tiles
// (layouts D and D2, byte 0 = 0x20 and 0x21, FORMAT.md 4.3 and 4.4)
// likewise need their 520x520
// coefficient plane: with compute shaders, from dct_decode.comp.glsl (two
// uints per texel), whose row pass dct_rows.comp.glsl then takes, so that
// this shader takes the column pass (8 texels a pixel); in WebGL2, as the
// RGBA16I texture u_coefs (channel c in component c, from the CPU's
// gv_dct_unpack), of which this shader takes both passes (up to 64
// texels).  Then the inverse colour transform.

precision highp float;
precision highp int;
precision highp usampler2D;
precision highp isampler2D;

uniform usampler2D u_parent;   // decoded parent tile, 513x513, RGBA8UI
uniform ivec2 u_quadrant;      // (tx & 1, ty & 1)
uniform int u_channels;        // 1 (gray: R, replicated on output) or 3

#ifdef GV_SSBO
layout(std430, binding = 0) readonly buffer TileWords { uint words[]; };
uint word_at(int i) { return words[i]; }
// Indices of an entropy-coded tile, decoded by rans_decode.comp.glsl, or
// the row pass of a transform-coded one's inverse transform, by
// dct_decode.comp.glsl and dct_rows.comp.glsl.
layout(std430, binding = 1) readonly buffer Indices { uint indices[]; };
#else
uniform usampler2D u_words;    // tile buffer as R32UI, u_words_width wide
uniform int u_words_width;
uint word_at(int i) { return texelFetch(u_words, ivec2(i % u_words_width, i / u_words_width), 0).r; }
// Indices of an entropy-coded tile, decoded on the CPU (no compute shaders
// here) and uploaded as a 257x257 R16UI texture.
uniform usampler2D u_indices;
// Coefficients of a transform-coded tile, decoded on the CPU
// (gv_dct_unpack) and uploaded as a 520x520 RGBA16I texture.
uniform isampler2D u_coefs;
ivec3 coef_at(int x, int y) { return texelFetch(u_coefs, ivec2(x, y), 0).rgb; }
int coef_bounds(int x, int y) { return texelFetch(u_coefs, ivec2(x, y), 0).a; }
#endif

out uvec4 o_color;

// Byte b of the tile buffer.
int byte_at(int b)
{
    return int((word_at(b >> 2) >> uint(8 * (b & 3))) & 0xffu);
}

// r bits starting at bit offset `bit` (r <= 12, so at most two words).
int bits_at(int bit, int r)
{
    int w = bit >> 5, s = bit & 31;
    uint v = word_at(w) >> uint(s);
    if (s + r > 32)
        v |= word_at(w + 1) << uint(32 - s);
    return int(v & ((1u << uint(r)) - 1u));
}

// Catmull-Rom weights in 128ths at the quarter offsets (FORMAT.md 3).
int weight(int odd, int k)
{
    if (odd == 0)
        return k == 0 ? -3 : (k == 1 ? 29 : (k == 2 ? 111 : -9));
    return k == 0 ? -9 : (k == 1 ? 111 : (k == 2 ? 29 : -3));
}

int first_tap(int q, int u)
{
    int p = 256 * q + (u >> 1);
    return (u & 1) == 1 ? p - 1 : p - 2;
}

// The rounding offsets of the two inverse-transform passes (FORMAT.md
// 4.3); only a test changes them, to see that a wrong one is caught.
#ifndef GV_DCT_ROUND_ROWS
#define GV_DCT_ROUND_ROWS 64
#endif
#ifndef GV_DCT_ROUND_COLS
#define GV_DCT_ROUND_COLS 1024
#endif

// The 8x8 integer DCT basis K[u][i] of FORMAT.md 4.3, row-major: the one
// copy, shared with the other decoders (put here by shaders/glsl_include.sh
// when the shaders are embedded).
#include "dct_matrix.glsl"

// The inverse colour transform of residual e: YCoCg-R back to RGB (C =
// 3), or gray as is.
ivec3 inverse_colour(ivec3 e)
{
    if (u_channels == 1)
        return ivec3(e.x);
    int t = e.x - (e.z >> 1);
    int g = e.z + t;
    int bl = t - (e.y >> 1);
    return ivec3(bl + e.y, g, bl);
}

#ifdef GV_SSBO
// The row pass's result t of texel words w0, w1 (dct_rows.comp.glsl):
// three 19-bit integers.
ivec3 row_pass_at(uint w0, uint w1)
{
    return ivec3(int(w0 << 13) >> 13,
                 int(((w0 >> 19) | (w1 << 13)) << 13) >> 13,
                 int(w1 << 7) >> 13);
}

// Residual of pixel uv of a transform-coded tile whose row pass
// dct_rows.comp.glsl has done (the plane then holds t[v][i] per texel, and
// the block's row count in its row 0): the column pass, rounded by an
// arithmetic shift (>> on a signed int), then the colour transform.
ivec3 dct_residual(ivec2 uv)
{
    int j = uv.y & 7;
    int w = 2 * ((uv.y & ~7) * 520 + uv.x);
    uint w1 = indices[w + 1];
    int rows = int((w1 >> 25) & 15u);
    ivec3 e = K[j] * row_pass_at(indices[w], w1);
    for (int v = 1; v < rows; v++) {
        w += 2 * 520;
        e += K[8 * v + j] * row_pass_at(indices[w], indices[w + 1]);
    }
    return inverse_colour((e + GV_DCT_ROUND_COLS) >> 11);
}
#else
// Residual of pixel uv of a transform-coded tile: the inverse transform of
// its block, rows then columns, each rounded by an arithmetic shift (>> on
// a signed int), then the colour transform.  Rows and columns past the
// block's bounds (its first texel's fourth component, 0 meaning all 8 of
// each) hold zeros, which change no sum: a zero row's t[v] is
// (0 + 64) >> 7 = 0.
ivec3 dct_residual(ivec2 uv)
{
    ivec2 b = (uv >> 3) << 3;
    int i = uv.x & 7, j = uv.y & 7;
    int bounds = coef_bounds(b.x, b.y);
    int rows = (bounds & 15) == 0 ? 8 : bounds & 15;
    int cols = (bounds >> 4 & 15) == 0 ? 8 : bounds >> 4 & 15;
    ivec3 e = ivec3(0);
    for (int v = 0; v < rows; v++) {
        ivec3 acc = ivec3(0);
        for (int u = 0; u < cols; u++)
            acc += K[8 * u + i] * coef_at(b.x + u, b.y + v);
        e += K[8 * v + j] * ((acc + GV_DCT_ROUND_ROWS) >> 7);
    }
    return inverse_colour((e + GV_DCT_ROUND_COLS) >> 11);
}
#endif

void main()
{
    ivec2 uv = ivec2(gl_FragCoord.xy);   // 0..512 each
    int tx0 = first_tap(u_quadrant.x, uv.x), ty0 = first_tap(u_quadrant.y, uv.y);
    ivec3 s = ivec3(0);
    for (int j = 0; j < 4; j++) {
        int row = clamp(ty0 + j, 0, 512);
        ivec3 h = ivec3(0);
        for (int i = 0; i < 4; i++) {
            int col = clamp(tx0 + i, 0, 512);
            h += weight(uv.x & 1, i) * ivec3(texelFetch(u_parent, ivec2(col, row), 0).rgb);
        }
        s += weight(uv.y & 1, j) * h;
    }
    ivec3 pred = clamp(s + 8192, 0, 255 * 16384 + 16383) >> 14;

    ivec3 res = ivec3(0);
    int r = byte_at(0) & 15;
    if (byte_at(0) == 0x20 || byte_at(0) == 0x21) {   // layouts D and D2
        res = dct_residual(uv);
    } else if (r > 0) {
        int dim = 4 * u_channels;
        int block = (uv.y >> 1) * 257 + (uv.x >> 1);
        int idx;
        if ((byte_at(0) & 128) != 0)
#ifdef GV_SSBO
            idx = int(indices[block]);
#else
            idx = int(texelFetch(u_indices, ivec2(uv.x >> 1, uv.y >> 1), 0).r);
#endif
        else
            idx = bits_at(8 * (1 + (1 << r) * dim) + block * r, r);
        int book = (byte_at(0) & 64) != 0 ? 4 : 1;   // EX layout: after N
        int at = book + idx * dim + ((uv.y & 1) * 2 + (uv.x & 1)) * u_channels;
        for (int c = 0; c < 3; c++) {
            if (c < u_channels) {
                int v = byte_at(at + c);
                res[c] = v >= 128 ? v - 256 : v;
            }
        }
        if (u_channels == 1)
            res = ivec3(res.x);
    }
    ivec3 px = clamp(pred + res, 0, 255);
    o_color = uvec4(uvec3(px), 255u);
}
