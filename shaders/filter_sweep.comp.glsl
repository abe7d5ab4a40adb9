// filter_sweep.comp.glsl - the propagation template as a compute shader
// (docs/FILTERS.md section 4.3): one dispatch sweeps GV_K lines.
//
// A workgroup of GV_WG invocations owns GV_WG - 2 GV_K positions along the
// line and reads GV_K more on each side.  Each step computes one line:
// the previous line's new values come from shared memory, the line's own
// values from before the sweep from gv_tex1 (input 1, never written), and
// the result goes to gv_dst (another texture).  A position at the edge of
// the workgroup misses a neighbour, and the wrong value it computes
// spreads by one position per line, so after GV_K lines it has reached
// only the positions that other workgroups own: the stored values are
// exact.  The thesis's ping-pong textures and merges are not needed.
// filters/run_gpu.c defines GV_WG, GV_K, GV_OUT_T, GV_IMAGE and
// GV_PREV_SAMPLER, and has put filter_sweep_head.comp.glsl, gv_in1 and
// gv_body before this.
void main()
{
    int j = int(gl_LocalInvocationID.x);
    ivec2 size = gv_size;
    int nline = gv_axis == 0 ? size.x : size.y;
    int nperp = gv_axis == 0 ? size.y : size.x;
    gv_seg0 = int(gl_WorkGroupID.x) * (GV_WG - 2 * GV_K) - GV_K;
    int perp = clamp(gv_seg0 + j, 0, nperp - 1);
    bool mine = j >= GV_K && j < GV_WG - GV_K && gv_seg0 + j < nperp;
    numPasses = gv_npasses;

    ivec2 tp = gv_at(gv_line_of(gv_first_pass - 1, nline), perp);
    GV_OUT_T prev = gv_read_first != 0 ? GV_OUT_T(texelFetch(gv_tex1, tp, 0))
                                       : GV_OUT_T(texelFetch(gv_prev_tex, tp, 0));
    gv_prev[j] = prev;
    if (gv_read_first != 0 && mine)
        imageStore(gv_dst, tp, prev);
    barrier();
    for (int t = 0; t < gv_lines; t++) {
        Pass = gv_first_pass + t;
        gv_cur_line = gv_line_of(Pass, nline);
        texel_pos = gv_at(gv_cur_line, perp);
        rel_pos = texel_pos - gv_origin;
        abs_pos = gv_abs + texel_pos;
        GV_OUT_T v = gv_body();
        gv_next[j] = v;
        if (mine)
            imageStore(gv_dst, texel_pos, v);
        barrier();
        gv_prev[j] = gv_next[j];
        barrier();
    }
}
