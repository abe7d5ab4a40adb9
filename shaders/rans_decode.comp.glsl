// rans_decode.comp.glsl - decode the 257 rANS index streams of an
// entropy-coded tile buffer (docs/FORMAT.md, section 4.1), one invocation
// per row of blocks, into one uint per index.  Bit for bit what
// lib/codec/tile_rans.c gv_rans_unpack produces for a well-formed buffer (the
// CPU checks the buffer before it is uploaded).  Needs compute shaders and
// storage buffers: GLSL ES 3.10 or GLSL 4.30.

precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer TileWords { uint words[]; };
layout(std430, binding = 1) writeonly buffer Indices { uint indices[]; };

uniform int u_rate;        // r, 1..12
uniform int u_tables;      // byte offset of the cumulative frequencies

uint u16_at(int byte_offset)
{
    return (words[byte_offset >> 2] >> uint(8 * (byte_offset & 2))) & 0xffffu;
}

void main()
{
    int row = int(gl_GlobalInvocationID.x);
    if (row >= 257)
        return;
    int k = 1 << u_rate;
    int lengths = u_tables + 2 * k;
    int at = lengths + 516;            // 257 u16 lengths, padded to 4
    for (int i = 0; i < row; i++)
        at += 2 * int(u16_at(lengths + 2 * i));
    uint x = u16_at(at) | (u16_at(at + 2) << 16);
    int next = at + 4;
    for (int i = 0; i < 257; i++) {
        uint slot = x & 0x7fffu;
        int lo = 0, hi = k - 1;
        while (lo < hi) {
            int mid = (lo + hi + 1) >> 1;
            if (u16_at(u_tables + 2 * mid) <= slot)
                lo = mid;
            else
                hi = mid - 1;
        }
        uint c = u16_at(u_tables + 2 * lo);
        uint c1 = lo + 1 < k ? u16_at(u_tables + 2 * (lo + 1)) : 32768u;
        indices[row * 257 + i] = uint(lo);
        x = (c1 - c) * (x >> 15) + slot - c;
        if (x < 65536u) {
            x = (x << 16) | u16_at(next);
            next += 2;
        }
    }
}
