// zfield_sweep.frag.glsl - one level of the z-field sweep as a fragment
// program (GLSL ES 3.00, so WebGL2 runs it; appended to
// zfield_rules.glsl): each point of zfield_points.vert.glsl decides its
// vertex from the heights (an R32F texture) and the states of the level
// below (an R8UI texture written by the previous pass: levels alternate
// between two targets, and a vertex's children are always exactly one
// level below).  With GV_ZFIELD_PACK defined the program instead packs 128
// states of a row into one RGBA32UI texel, from both targets, for
// read-back (the paper's section 5.3).

uniform highp sampler2D u_z;
uniform highp usampler2D u_prev;    // states of the level below
uniform highp usampler2D u_other;   // pack: the other target

float zat(int x, int y) { return texelFetch(u_z, ivec2(x, y), 0).r; }
bool on(int x, int y) { return texelFetch(u_prev, ivec2(x, y), 0).r != 0u; }

#ifdef GV_ZFIELD_PACK
layout(location = 0) out uvec4 o_bits;
void main()
{
    ivec2 t = ivec2(gl_FragCoord.xy);
    uvec4 bits = uvec4(0u);
    for (int c = 0; c < 4; c++) {
        uint w = 0u;
        for (int b = 0; b < 32; b++) {
            int x = 128 * t.x + 32 * c + b;
            if (x < u_n && (texelFetch(u_prev, ivec2(x, t.y), 0).r != 0u ||
                            texelFetch(u_other, ivec2(x, t.y), 0).r != 0u))
                w |= 1u << uint(b);
        }
        bits[c] = w;
    }
    o_bits = bits;
}
#else
flat in ivec2 v_xy;
layout(location = 0) out uint o_state;
void main()
{
    o_state = decide(v_xy.x, v_xy.y) ? 1u : 0u;
}
#endif
