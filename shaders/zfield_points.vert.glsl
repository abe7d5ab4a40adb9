// zfield_points.vert.glsl - the fragment variant of the z-field sweep
// (zfield_sweep.frag.glsl): one point per vertex of level u_level, drawn
// on the pixel of its grid position in an n x n target (gl_VertexID picks
// the vertex; no attributes), so that only that level's vertices are
// rasterized, as the paper's frame arrangement (section 5.1) achieves with
// a rearranged frame.  Appended to zfield_rules.glsl.

flat out ivec2 v_xy;

float zat(int x, int y) { return 0.0; }
bool on(int x, int y) { return false; }

void main()
{
    ivec2 v = vertex_of(gl_VertexID);
    v_xy = v;
    vec2 at = (vec2(v) + 0.5) / float(u_n) * 2.0 - 1.0;
    gl_Position = vec4(at, 0.0, 1.0);
    gl_PointSize = 1.0;
}
