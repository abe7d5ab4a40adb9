// cluster_select.comp.glsl - vertex clustering at level T (Kanaya et al.,
// section 2.5; lib/mesh/cluster.h): pass 0 selects each vertex's
// representative from the tree in storage buffers, pass 1 marks the
// triangles whose three corners fall into three different clusters.
// Integer tests only, so the selection is the CPU's
// (lib/mesh/cluster.c gv_cluster_select) on every GPU.  Needs compute
// shaders and storage buffers: GLSL ES 3.10 or GLSL 4.30.

precision highp float;
precision highp int;

layout(local_size_x = 64) in;

// Kanaya figure 3's Tree-buffer texel: the representative and r_level,
// with the parent pointer and the rank in r_level order beside it.
struct Node {
    vec4 rep;
    uint parent;
    uint rank;
    uint pad0;
    uint pad1;
};
layout(std430, binding = 0) readonly buffer Tree { Node tree[]; };
// Kanaya figure 4's Leaf-buffer texel: the vertex (float bits) and the
// pointer to its parent in the Tree-buffer (0xffffffff: none).
layout(std430, binding = 1) readonly buffer Leaf { uvec4 leaf[]; };
layout(std430, binding = 2) readonly buffer Faces { uint tris[]; };
layout(std430, binding = 3) buffer Cluster { uint cluster[]; };
layout(std430, binding = 4) writeonly buffer Selected { vec4 selected[]; };
layout(std430, binding = 5) writeonly buffer Keep { uint keep[]; };

uniform uint u_T;       // nodes of rank >= u_T are above the level
uniform uint u_count;   // vertices (pass 0) or triangles (pass 1)
uniform uint u_nnodes;
uniform int u_pass;

const uint NONE = 0xffffffffu;

void main()
{
    uint i = gl_GlobalInvocationID.x +
             gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
    if (i >= u_count)
        return;
    if (u_pass == 0) {
        uvec4 l = leaf[i];
        uint p = l.w;
        if (p == NONE || tree[p].rank < u_T) {
            cluster[i] = u_nnodes + i;
            selected[i] = vec4(uintBitsToFloat(l.xyz), 0.0);
            return;
        }
        for (;;) {
            uint q = tree[p].parent;
            if (q == NONE || tree[q].rank < u_T)
                break;
            p = q;
        }
        cluster[i] = p;
        selected[i] = vec4(tree[p].rep.xyz, 0.0);
    } else {
        uint a = cluster[tris[3u * i]];
        uint b = cluster[tris[3u * i + 1u]];
        uint c = cluster[tris[3u * i + 2u]];
        keep[i] = (a != b && b != c && a != c) ? 1u : 0u;
    }
}
