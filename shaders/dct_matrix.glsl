// dct_matrix.glsl - the 8x8 integer DCT basis K[u][i] of layout D's
// inverse transform (docs/FORMAT.md section 4.3), row-major, the one copy
// that every GPU decoder of layout D compiles: dct_rows.comp.glsl (the
// row pass) and tile_decode.frag.glsl (the column pass, or both in
// WebGL2) name it with an `#include "dct_matrix.glsl"` line, which
// shaders/glsl_include.sh replaces with this file when the shaders are
// embedded in the programs (shaders/embed.sh) and in gigaviewd's copy for
// the browser (client/web/embed.sh), so the native decoder and the
// browser compile the same text.  The CPU's copy is gv_dct_matrix
// (lib/codec/tile_dct_pixels.c); tests/test_dct_matrix.c fails unless the
// two hold the same 64 integers.  highp so that it means the same
// wherever it is included (a fragment shader's default int precision is
// mediump); a snippet, without a #version line, like the shaders that
// include it.
const highp int K[64] = int[64](
    64,  64,  64,  64,  64,  64,  64,  64,
    89,  75,  50,  18, -18, -50, -75, -89,
    83,  36, -36, -83, -83, -36,  36,  83,
    75, -18, -89, -50,  50,  89,  18, -75,
    64, -64, -64,  64,  64, -64, -64,  64,
    50, -89,  18,  75, -75, -18,  89, -50,
    36, -83,  83, -36, -36,  83, -83,  36,
    18, -50,  75, -89,  89, -75,  50, -18);
