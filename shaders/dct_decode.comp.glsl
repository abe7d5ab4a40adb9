// dct_decode.comp.glsl - decode the 65 coefficient streams of each
// transform-coded tile buffer of a group (layouts D and D2, docs/FORMAT.md
// sections 4.3 and 4.4), one invocation per row of 8x8 blocks and one row of work groups per
// tile (gl_WorkGroupID.y), into the tile's 520x520 coefficient plane: two
// uints per texel, (D_0 & 0xffff) | D_1 << 16 and (D_2 & 0xffff) | A << 16,
// the texel the WebGL2 path uploads as RGBA16I.  A is 0 but in the first
// texel of each block, where it bounds the block's nonzero coefficients:
// rows (v) in bits 0-3 and columns (u) in bits 4-7, 1 to 8 each, so that
// tile_decode.frag.glsl, which takes the inverse transform per pixel,
// reads no more of the block than it must (zero rows and columns add
// nothing to its sums; A = 0, as gv_dct_unpack leaves it for the C
// WebGL2 path, reads all 8 x 8; the browser's tile_dct.js writes the same
// bounds as here).  Bit for bit what lib/codec/tile_dct.c
// gv_dct_unpack produces for a well-formed buffer (the CPU checks the
// layout before it is uploaded; a damaged stream or a missing model still
// reads nothing past the tile's buffer and writes only its own block row).
// Needs compute shaders and storage buffers: GLSL ES 3.10 or GLSL 4.30.

precision highp int;

layout(local_size_x = 65) in;

layout(std430, binding = 0) readonly buffer TileWords { uint words[]; };
layout(std430, binding = 1) writeonly buffer Coefs { uint coefs[]; };
// Per tile of the dispatch: (first word of its buffer in words[], its
// length in bytes, first uint of its coefficient plane in coefs[],
// channels C).
layout(std430, binding = 2) readonly buffer Tiles { ivec4 tiles[]; };

// JPEG's zigzag order: ZZ[k] = 8 v + u of coefficient k (FORMAT.md 4.3).
const int ZZ[64] = int[64](
     0,  1,  8, 16,  9,  2,  3, 10, 17, 24, 32, 25, 18, 11,  4,  5,
    12, 19, 26, 33, 40, 48, 41, 34, 27, 20, 13,  6,  7, 14, 21, 28,
    35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23, 30, 37, 44, 51,
    58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63);

int base;                  // this tile's first word in words[]
int len;                   // its length in bytes
uint x;                    // the rANS state
int next;                  // byte offset of the stream's next word

int byte_at(int b)
{
    return b < len ? int((words[base + (b >> 2)] >> uint(8 * (b & 3))) & 0xffu) : 0;
}

uint u16_at(int b)
{
    return b + 1 < len ? (words[base + (b >> 2)] >> uint(8 * (b & 2))) & 0xffffu : 0u;
}

// s + h when that symbol's cum[] is still <= slot, else s.
int probe(int at, int k, int s, int h, uint slot)
{
    return s + h < k && uint(byte_at(at + s + h)) <= slot ? s + h : s;
}

// One rANS step with the k-symbol 8-bit model at byte offset `at`, or the
// uniform 6-bit step when at < 0 (also for a model the mask lacks, which
// the CPU decoder refuses).  Returns the symbol.
int rans_step(int at, int k)
{
    uint slot = x & 255u;
    int s, c, f;
    if (at < 0) {
        s = int(slot >> 2);
        c = 4 * s;
        f = 4;
    } else {
        // The largest s with cum[s] <= slot, by halving steps written out:
        // no loop, since llvmpipe ends a shader's loops after 65535
        // iterations in all, which a search loop per symbol reached within
        // one stream of an RGB tile.
        s = probe(at, k, 0, 64, slot);
        s = probe(at, k, s, 32, slot);
        s = probe(at, k, s, 16, slot);
        s = probe(at, k, s, 8, slot);
        s = probe(at, k, s, 4, slot);
        s = probe(at, k, s, 2, slot);
        s = probe(at, k, s, 1, slot);
        c = byte_at(at + s);
        f = (s + 1 < k ? byte_at(at + s + 1) : 256) - c;
    }
    x = uint(f) * (x >> 8) + slot - uint(c);
    if (x < 65536u) {
        x = (x << 16) | u16_at(next);
        next += 2;
    }
    return s;
}

int class_of(int q)
{
    return min(abs(q), 2);
}

void main()
{
    int by = int(gl_GlobalInvocationID.x);
    if (by >= 65)
        return;
    ivec4 t = tiles[gl_WorkGroupID.y];
    base = t.x;
    len = t.y;
    int out_at = t.z, channels = t.w;
    int step_q[3];
    for (int c = 0; c < 3; c++)
        step_q[c] = int(u16_at(2 + 2 * c));
    // Layout D2 (byte 0 = 0x21) has models 30 and 31 for each block's
    // last value; D (0x20) has 30 models.
    bool last_models = (u16_at(0) & 0xffu) == 0x21u;
    // Byte offsets of the stored models (-1: not stored), in order of m.
    uint mask = u16_at(8) | (u16_at(10) << 16);
    int model_at[32];
    int at = 12;
    for (int m = 0; m < 32; m++) {
        model_at[m] = -1;
        if ((mask & (1u << uint(m))) != 0u) {
            model_at[m] = at;
            at += m < 6 ? 65 : 16;
        }
    }
    int lengths = (at + 1) & ~1;
    at = lengths + 130;
    for (int i = 0; i < by; i++)
        at += 2 * int(u16_at(lengths + 2 * i));
    x = u16_at(at) | (u16_at(at + 2) << 16);
    next = at + 4;
    int pe[3] = int[3](0, 0, 0);
    int dcp[3] = int[3](0, 0, 0);
    int blk[192];              // the block's coefficients, 64 per channel
    for (int i = 0; i < 192; i++)
        blk[i] = 0;
    for (int bx = 0; bx < 65; bx++) {
        int rows = 1, cols = 1;    // of the block's nonzero coefficients
        for (int c = 0; c < channels; c++) {
            int cc = c == 0 ? 0 : 1;
            int n = min(rans_step(model_at[3 * cc + pe[c]], 65), 64);
            int prev = 0;
            for (int k = 0; k < n; k++) {
                int band = k == 0 ? 0 : (k <= 2 ? 1 : (k <= 9 ? 2 : 3));
                int p = k == 0 ? dcp[c] : class_of(prev);
                int m = last_models && k == n - 1 ? 30 + cc
                                                  : 6 + 3 * (4 * cc + band) + p;
                int tok = min(rans_step(model_at[m], 16), 15);
                int q;
                if (tok == 15) {
                    int h = rans_step(-1, 64);
                    int l = rans_step(-1, 64);
                    q = 64 * h + l - 2048;
                } else if ((tok & 1) == 1) {
                    q = (tok + 1) >> 1;
                } else {
                    q = -(tok >> 1);
                }
                if (k == 0)
                    dcp[c] = class_of(q);
                prev = q;
                int z = ZZ[k], d = clamp(q * step_q[c], -32768, 32767);
                blk[64 * c + z] = d;
                if (d != 0) {
                    rows = max(rows, (z >> 3) + 1);
                    cols = max(cols, (z & 7) + 1);
                }
            }
            pe[c] = n == 0 ? 0 : (n <= 4 ? 1 : 2);
            if (n == 0)
                dcp[c] = 0;
        }
        // The block into the plane: texel (8 bx + u, 8 by + v).
        for (int i = 0; i < 64; i++) {
            int w = out_at + 2 * ((8 * by + (i >> 3)) * 520 + 8 * bx + (i & 7));
            uint a = i == 0 ? uint(rows | cols << 4) << 16 : 0u;
            if (channels == 3) {
                coefs[w] = (uint(blk[i]) & 0xffffu) | (uint(blk[64 + i]) << 16);
                coefs[w + 1] = (uint(blk[128 + i]) & 0xffffu) | a;
            } else {
                coefs[w] = uint(blk[i]) & 0xffffu;
                coefs[w + 1] = a;
            }
            blk[i] = 0;
            blk[64 + i] = 0;
            blk[128 + i] = 0;
        }
    }
}
