// height_rans.comp.glsl - entropy-decode a height tile buffer (docs/FORMAT.md
// section 12): one invocation per stream of 8 rows, into one int q per
// sample, bit for bit what lib/codec/height_tile.c gv_height_tile_residuals
// gives for a well-formed buffer (the CPU checks the layout before upload;
// a damaged stream still terminates: every loop is bounded).  Needs compute
// shaders and storage buffers: GLSL ES 3.10 or GLSL 4.30.

precision highp int;

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer TileWords { uint words[]; };
layout(std430, binding = 1) writeonly buffer Residuals { int q[]; };

uint u16_at(int byte_offset)
{
    return (words[byte_offset >> 2] >> uint(8 * (byte_offset & 2))) & 0xffffu;
}

int bitlen(uint n)
{
    return n == 0u ? 0 : findMSB(n) + 1;
}

void main()
{
    int s = int(gl_GlobalInvocationID.x);
    if (s >= 65)
        return;
    uint mask = u16_at(4);
    int ntables = bitCount(mask);
    int at = ((136 + 58 * ntables + 3) >> 2) << 2;   // the first stream
    for (int i = 0; i < s; i++)
        at += 2 * int(u16_at(6 + 2 * i));
    uint x = u16_at(at) | (u16_at(at + 2) << 16);
    int next = at + 4;
    int r0 = 8 * s, r1 = min(r0 + 8, 513);
    // |q| of the row above in this stream (0 above its first row), and of
    // the sample to the left: kept here rather than read back from q.
    uint above[513];
    for (int u = 0; u < 513; u++)
        above[u] = 0u;
    for (int v = r0; v < r1; v++) {
        uint a = 0u;
        for (int u = 0; u < 513; u++) {
            uint b = above[u];
            int c = min(bitlen(a + b), 11);
            // Table of context c: after the tables of the contexts below it.
            int table = 136 + 58 * bitCount(mask & ((1u << uint(c)) - 1u));
            uint slot = x & 0x7fffu;
            // The largest t with cum[t] <= slot, by a binary search written
            // out: Mesa's llvmpipe stops a loop after 65535 iterations in
            // all (a linear search here ran into it after ~2000 samples).
            int t = 0;
            if (u16_at(table + 2 * (t + 16)) <= slot) t += 16;
            if (t + 8 <= 28 && u16_at(table + 2 * (t + 8)) <= slot) t += 8;
            if (t + 4 <= 28 && u16_at(table + 2 * (t + 4)) <= slot) t += 4;
            if (t + 2 <= 28 && u16_at(table + 2 * (t + 2)) <= slot) t += 2;
            if (t + 1 <= 28 && u16_at(table + 2 * (t + 1)) <= slot) t += 1;
            uint cl = u16_at(table + 2 * t);
            uint ch = t < 28 ? u16_at(table + 2 * (t + 1)) : 32768u;
            x = (ch - cl) * (x >> 15) + slot - cl;
            if (x < 65536u) {
                x = (x << 16) | u16_at(next);
                next += 2;
            }
            uint z = uint(t);
            if (t >= 16) {
                int k = t - 12;
                int lo = min(k, 12), hi = k - lo;
                uint vals[2] = uint[2](0u, 0u);
                for (int j = 0; j < 2; j++) {
                    int bits = j == 0 ? lo : hi;
                    if (bits == 0)
                        continue;
                    uint sl = x & 0x7fffu, sh = uint(15 - bits);
                    vals[j] = sl >> sh;
                    x = (1u << sh) * (x >> 15) + (sl & ((1u << sh) - 1u));
                    if (x < 65536u) {
                        x = (x << 16) | u16_at(next);
                        next += 2;
                    }
                }
                z = (1u << uint(k)) + (vals[1] << uint(lo)) + vals[0];
            }
            int qv = (z & 1u) != 0u ? -int(z >> 1) - 1 : int(z >> 1);
            q[v * 513 + u] = qv;
            a = uint(abs(qv));
            above[u] = a;
        }
    }
}
