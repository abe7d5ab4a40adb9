// zfield_sweep.comp.glsl - one level of the z-field sweep as a compute
// pass (appended to zfield_rules.glsl): one invocation per vertex of the
// level, the heights and every vertex's state in storage buffers (the
// paper runs five fragment passes per level; compute needs one).  With
// GV_ZFIELD_PACK defined (before the rules) the program instead packs 32
// states into a word for read-back (the paper's section 5.3 packs 8 into
// a byte).

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Heights { float z[]; };
layout(std430, binding = 1) buffer Enabled { uint en[]; };
layout(std430, binding = 2) writeonly buffer Packed { uint packed_en[]; };

uniform int u_count;      // vertices of the level (or words to pack)

float zat(int x, int y) { return z[y * u_n + x]; }
bool on(int x, int y) { return en[y * u_n + x] != 0u; }

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
void main()
{
    int idx = invocation();
    if (idx >= u_count)
        return;
    ivec2 v = vertex_of(idx);
    en[v.y * u_n + v.x] = decide(v.x, v.y) ? 1u : 0u;
}
#endif
