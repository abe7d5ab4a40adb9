// quarter_copy.frag.glsl - the second mip level of a decoded tile: the
// quarter of its parent that covers the same part of the image (section
// 7.5), 257x257 texels, copied exactly.

precision highp float;
precision highp int;
precision highp usampler2D;

uniform usampler2D u_parent;
uniform ivec2 u_quadrant;

out uvec4 o_color;

void main()
{
    ivec2 uv = ivec2(gl_FragCoord.xy);   // 0..256 each
    o_color = texelFetch(u_parent, 256 * u_quadrant + uv, 0);
}
