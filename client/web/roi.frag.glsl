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

void main()
{
    vec2 f = floor(v_uv);
    vec2 a = v_uv - f;
    ivec2 i = ivec2(f);
    vec3 top = mix(texel(i), texel(i + ivec2(1, 0)), a.x);
    vec3 bottom = mix(texel(i + ivec2(0, 1)), texel(i + ivec2(1, 1)), a.x);
    vec3 c = mix(top, bottom, a.y) * 255.0;
    o_color = vec4((floor(c + 0.5) + 0.25) / 255.0, 1.0);
}
