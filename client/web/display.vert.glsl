// display.vert.glsl - one tile quad of the view (renderer.js): the
// position in clip space and the tile-local level coordinates, both
// computed on the CPU in double precision from the view, so that the
// interpolated coordinates are exact to the float's precision near the
// tile and not near the image origin (a gigapixel image is wider than a
// float resolves).

in vec2 a_pos;   // clip space
in vec2 a_uv;    // level pixels relative to the texture's (0, 0), continuous

out vec2 v_uv;

void main()
{
    v_uv = a_uv;
    gl_Position = vec4(a_pos, 0.0, 1.0);
}
