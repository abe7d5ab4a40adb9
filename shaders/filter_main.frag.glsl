// filter_main.frag.glsl - the end of every filter module's fragment
// shader: sets the predefined positions for the texel being written and
// stores the body's value.  GV_OUT_T (vec4, uvec4 or ivec4) is defined by
// filters/run_gpu.c before the body.
void main()
{
    Pass = gv_pass;
    numPasses = gv_npasses;
    texel_pos = ivec2(gl_FragCoord.xy);
    rel_pos = (texel_pos << gv_shift) - gv_origin;
    abs_pos = gv_abs + (texel_pos << gv_shift);
    gv_out = gv_body();
}
