// roi.frag.glsl - draw a filter result (an RGBA8 texture made from the
// PNG that POST /v1/images/{id}/filter returned) over the region of
// interest, sampled exactly like the tiles (display.frag.glsl): bilinear
// interpolation of texelFetch taps clamped to the result's edge, so a 1:1
// view shows the server's bytes unchanged.  The renderer clips it to the
// ROI with the scissor test.

precision highp float;
precision highp int;

uniform sampler2D u_img;
uniform ivec2 u_max;      // last texel of the result

in vec2 v_uv;
out vec4 o_color;

vec3 texel(ivec2 p)
{
    return texelFetch(u_img, clamp(p, ivec2(0), u_max), 0).rgb;
}

#include "bilinear.glsl"

void main()
{
    vec3 c = bilinear(v_uv) * 255.0;
    o_color = vec4((floor(c + 0.5) + 0.25) / 255.0, 1.0);
}
