// filter_copy.frag.glsl - texel copies for the filter templates: input 1
// into a log-reduce level 0 or a propagation pair, and the merge of a
// ping-pong pair (thesis section 7.8.4), where every other line is
// discarded (gv_axis 0: columns, 1: rows, -1: copy everything).
// GV_SAMPLER and GV_OUT_T are defined by filters/run_gpu.c.
precision highp float;
precision highp int;
uniform highp GV_SAMPLER gv_src;
uniform int gv_axis;
uniform int gv_parity;
layout(location = 0) out GV_OUT_T gv_out;

void main()
{
    ivec2 t = ivec2(gl_FragCoord.xy);
    if (gv_axis >= 0 && (t[gv_axis] & 1) != gv_parity)
        discard;
    gv_out = GV_OUT_T(texelFetch(gv_src, t, 0));
}
