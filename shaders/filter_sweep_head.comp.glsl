// filter_sweep_head.comp.glsl - declarations of the compute propagation
// template (filter_sweep.comp.glsl), placed before the read functions and
// the body: the workgroup, the dispatch's uniforms, the shared lines and
// the current line, which gv_in1 needs.
layout(local_size_x = GV_WG) in;

uniform int gv_first_pass;     // Pass of the first line of this dispatch
uniform int gv_lines;          // lines in this dispatch
uniform int gv_axis;           // 0: ±x sweep (lines are columns), 1: ±y
uniform int gv_step;           // +1 or -1
uniform int gv_read_first;     // 1: the previous line is the sweep's first
uniform highp GV_PREV_SAMPLER gv_prev_tex;   // = gv_dst, as a texture
layout(GV_IMAGE_FORMAT) writeonly uniform highp GV_IMAGE gv_dst;

shared GV_OUT_T gv_prev[GV_WG];
shared GV_OUT_T gv_next[GV_WG];
int gv_cur_line;   // the line being computed
int gv_seg0;       // position along the line of invocation 0

int gv_line_of(int pass_no, int n)
{
    return gv_step > 0 ? pass_no : n - 1 - pass_no;
}

ivec2 gv_at(int line, int perp)
{
    return gv_axis == 0 ? ivec2(line, perp) : ivec2(perp, line);
}

