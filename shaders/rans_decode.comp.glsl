// rans_decode.comp.glsl - decode the 257 rANS index streams of each
// entropy-coded tile buffer of a group (docs/FORMAT.md, sections 4.1 and
// 4.2), one invocation per row of blocks and one row of work groups per
// tile (gl_WorkGroupID.y), into one uint per index.  All the group's tiles
// in one dispatch: each row is a serial chain, so a tile alone (257
// invocations) leaves a large GPU nearly idle.  Bit for bit what
// lib/codec/tile_rans.c gv_rans_unpack produces for a well-formed buffer (the
// CPU checks the buffer before it is uploaded; a damaged stream still gives
// indices inside the codebook).  Needs compute shaders and storage
// buffers: GLSL ES 3.10 or GLSL 4.30.

precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer TileWords { uint words[]; };
layout(std430, binding = 1) writeonly buffer Indices { uint indices[]; };
// Per tile of the dispatch: (first word of its buffer in words[], r (1..12),
// byte offset of the model over all indices (gv_rans_tables_at: E's cum[],
// EX's escape model), first index of its output in indices[]).
layout(std430, binding = 2) readonly buffer Tiles { ivec4 tiles[]; };

int base;                  // this tile's first word in words[]

uint u16_at(int byte_offset)
{
    return (words[base + (byte_offset >> 2)] >> uint(8 * (byte_offset & 2))) & 0xffffu;
}

// The last symbol of the k-symbol model at byte offset `tables` whose
// cumulative frequency is <= slot: (symbol, cum, frequency).
ivec3 find_symbol(int tables, int k, uint slot)
{
    int lo = 0, hi = k - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (u16_at(tables + 2 * mid) <= slot)
            lo = mid;
        else
            hi = mid - 1;
    }
    uint c = u16_at(tables + 2 * lo);
    uint c1 = lo + 1 < k ? u16_at(tables + 2 * (lo + 1)) : 32768u;
    return ivec3(lo, int(c), int(c1 - c));
}

void main()
{
    int row = int(gl_GlobalInvocationID.x);
    if (row >= 257)
        return;
    ivec4 t = tiles[gl_WorkGroupID.y];
    base = t.x;
    int u_rate = t.y, u_tables = t.z, out_at = t.w;
    uint b0 = words[base] & 0xffu;
    bool ctx = (b0 & 64u) != 0u;
    // E: k = 2^r symbols, lengths after cum[].  EX (byte 1: contexts,
    // bytes 2-3: N): the escape model's N symbols, then the context map
    // (4-aligned, 8 bytes), 8 u16 per context model, then the lengths.
    int k = ctx ? int(u16_at(2)) : 1 << u_rate;
    int map_at = ((u_tables + 2 * k + 3) >> 2) << 2;
    int models = map_at + 8;
    int lengths = ctx ? models + 16 * int((words[base] >> 8) & 0xffu) : u_tables + 2 * k;
    int at = lengths + 516;            // 257 u16 lengths, padded to 4
    for (int i = 0; i < row; i++)
        at += 2 * int(u16_at(lengths + 2 * i));
    uint x = u16_at(at) | (u16_at(at + 2) << 16);
    int next = at + 4;
    int a = 0, b = 0;                  // EX: classes of the two blocks before
    for (int i = 0; i < 257; i++) {
        int idx;
        if (ctx) {
            int p = 4 * a + b;
            int m = int((words[base + ((map_at + (p >> 1)) >> 2)] >> uint(8 * ((p >> 1) & 3) + 4 * (p & 1))) & 15u);
            int cum = models + 16 * m;
            uint slot = x & 0x7fffu;
            int s = 0;
            while (s < 7 && u16_at(cum + 2 * (s + 1)) <= slot)
                s++;
            uint c = u16_at(cum + 2 * s);
            uint c1 = s < 7 ? u16_at(cum + 2 * (s + 1)) : 32768u;
            x = (c1 - c) * (x >> 15) + slot - c;
            if (x < 65536u) {
                x = (x << 16) | u16_at(next);
                next += 2;
            }
            idx = s;
            if (s == 7) {
                slot = x & 0x7fffu;
                ivec3 e = find_symbol(u_tables, k, slot);
                idx = e.x;
                x = uint(e.z) * (x >> 15) + slot - uint(e.y);
                if (x < 65536u) {
                    x = (x << 16) | u16_at(next);
                    next += 2;
                }
            }
            b = a;
            a = s == 0 ? 0 : (s <= 2 ? 1 : (s <= 6 ? 2 : 3));
        } else {
            uint slot = x & 0x7fffu;
            ivec3 e = find_symbol(u_tables, k, slot);
            idx = e.x;
            x = uint(e.z) * (x >> 15) + slot - uint(e.y);
            if (x < 65536u) {
                x = (x << 16) | u16_at(next);
                next += 2;
            }
        }
        indices[out_at + row * 257 + i] = uint(idx);
    }
}
