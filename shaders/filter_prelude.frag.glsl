// filter_prelude.frag.glsl - the start of every filter module's shader,
// fragment or compute (docs/FILTERS.md section 3): precision, the
// predefined variables of thesis table 7.1 and the parameters.
// filters/run_gpu.c appends the per-input read functions, the body (after
// "#line 1", so that driver messages count the body's own lines) and
// filter_main.frag.glsl or filter_sweep.comp.glsl.
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp usampler2D;
precision highp isampler2D;
precision highp image2D;
precision highp uimage2D;
precision highp iimage2D;

uniform ivec2 gv_origin;      // the ROI's top-left texel in the padded region
uniform ivec2 gv_size;        // the padded region's size (level 0)
uniform ivec2 gv_abs;         // level coordinates of texel (0, 0)
uniform int gv_shift;         // log-reduce: the level being written, else 0
uniform vec4 pixelsAround;
uniform vec2 filterArea;
uniform vec2 backBufferSize;
uniform vec2 filterScaling;
uniform int gv_pass;           // Pass and numPasses, set by main
uniform int gv_npasses;
uniform ivec2 sweepDir;
uniform float gv_p[16];

ivec2 rel_pos;
ivec2 abs_pos;
ivec2 texel_pos;
int Pass;
int numPasses;
