// dct_rows.comp.glsl - the first (row) pass of layout D's inverse
// transform (docs/FORMAT.md section 4.3), in place on the coefficient
// planes that dct_decode.comp.glsl wrote, one invocation per 8x8 block
// and one row of work groups per tile (gl_WorkGroupID.y, the same
// per-tile parameters).  Row v of a block becomes, for each column i and
// channel c,
//
//   t[v][i] = (sum over u of K[u][i] * D[v][u] + 64) >> 7
//
// (>> an arithmetic shift), only the rows and columns the block's bounds
// name (its first texel's A: rows in bits 0-3, columns in bits 4-7; the
// rest are zero, and a zero row's t is (0 + 64) >> 7 = 0).  Each texel of
// the plane then holds its t of the three channels in 57 bits, 19 bits
// each (|t| <= 479 * 32768 / 128 < 2^17: the sum of |K[u][i]| over u is at
// most 479), and the texels of the block's row 0 the block's row count:
//
//   word 0 = t0 & 0x7ffff | t1 << 19
//   word 1 = (t1 >> 13) & 0x3f | (t2 & 0x7ffff) << 6 | rows << 25
//
// so that tile_decode.frag.glsl takes the column pass with one texel per
// row of the block: at most 8 reads a pixel instead of 64.  Reading the
// block's row before writing it, and no invocation touching another's
// block, makes the pass safe in place.  The integers are those of the
// CPU's gv_dct_inverse.  Needs compute shaders and storage buffers: GLSL
// ES 3.10 or GLSL 4.30.

precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 1) buffer Coefs { uint coefs[]; };
// Per tile: (first word of its buffer, its length in bytes, first uint of
// its coefficient plane in coefs[], channels), as for dct_decode.
layout(std430, binding = 2) readonly buffer Tiles { ivec4 tiles[]; };

// The row pass's rounding offset (FORMAT.md 4.3); only a test changes it,
// to see that a wrong one is caught.
#ifndef GV_DCT_ROUND_ROWS
#define GV_DCT_ROUND_ROWS 64
#endif

// The 8x8 integer DCT basis K[u][i] of FORMAT.md 4.3, row-major: the one
// copy, shared with the other decoders (put here by shaders/glsl_include.sh
// when the shaders are embedded).
#include "dct_matrix.glsl"

void main()
{
    int blk = int(gl_GlobalInvocationID.x);
    if (blk >= 65 * 65)
        return;
    int plane = tiles[gl_WorkGroupID.y].z;
    int bx = blk % 65, by = blk / 65;
    int first = plane + 2 * (8 * by * 520 + 8 * bx);
    uint a = coefs[first + 1] >> 16;
    int rows = int(a & 15u), cols = int((a >> 4) & 15u);
    rows = rows == 0 ? 8 : rows;   // 0: all 8 (as in tile_decode.frag.glsl)
    cols = cols == 0 ? 8 : cols;
    ivec3 d[8];
    for (int v = 0; v < rows; v++) {
        int at = first + 2 * 520 * v;
        for (int u = 0; u < cols; u++) {
            uint w0 = coefs[at + 2 * u], w1 = coefs[at + 2 * u + 1];
            d[u] = ivec3(int(w0 << 16) >> 16, int(w0) >> 16, int(w1 << 16) >> 16);
        }
        uint tagged = v == 0 ? uint(rows) << 25 : 0u;
        for (int i = 0; i < 8; i++) {
            ivec3 acc = ivec3(GV_DCT_ROUND_ROWS);
            for (int u = 0; u < cols; u++)
                acc += K[8 * u + i] * d[u];
            uvec3 t = uvec3(acc >> 7);
            coefs[at + 2 * i] = (t.x & 0x7ffffu) | (t.y << 19);
            coefs[at + 2 * i + 1] = ((t.y >> 13) & 0x3fu) |
                                    ((t.z & 0x7ffffu) << 6) | tagged;
        }
    }
}
