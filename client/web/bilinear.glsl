// bilinear.glsl - the one bilinear sampling of the viewer's fragment
// shaders (display.frag.glsl, roi.frag.glsl include it after their own
// texel(p), which fetches one clamped texel): the four texels around uv,
// mixed across then down, as `gigaview render` samples
// (client/cmd/cmd_render.c).  At integer uv + 0.5 steps of a 1:1 view the
// weights are 0 and 1 and the result is the texel itself.
vec3 bilinear(vec2 uv)
{
    vec2 f = floor(uv);
    vec2 a = uv - f;
    ivec2 i = ivec2(f);
    vec3 top = mix(texel(i), texel(i + ivec2(1, 0)), a.x);
    vec3 bottom = mix(texel(i + ivec2(0, 1)), texel(i + ivec2(1, 1)), a.x);
    return mix(top, bottom, a.y);
}
