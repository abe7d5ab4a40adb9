/*
 * view_roi.c - a filter result drawn in place (view_roi.h).
 *
 * The four corners of the region go through the view's geometry
 * (vg_image_to_screen, the mapping every frame uses) to window pixels and
 * then to clip space; the vertex shader picks one per gl_VertexID of a
 * four-vertex strip.  With the region's corners on window pixel corners
 * (1:1, unrotated, as at the views tests use) every fragment samples its
 * own texel's centre.
 */
#include <stdlib.h>

#include <GLES3/gl32.h>

#include "view_roi.h"

static const char vertex_src[] =
    "uniform vec2 u_corner[4];\n"
    "out vec2 v_uv;\n"
    "void main()\n"
    "{\n"
    "    vec2 q = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));\n"
    "    v_uv = q;\n"
    "    gl_Position = vec4(u_corner[gl_VertexID], 0.0, 1.0);\n"
    "}\n";

static const char fragment_src[] =
    "precision highp float;\n"
    "uniform highp sampler2D u_tex;\n"
    "in vec2 v_uv;\n"
    "out vec4 o_color;\n"
    "void main()\n"
    "{\n"
    "    o_color = vec4(texture(u_tex, v_uv).rgb, 1.0);\n"
    "}\n";

struct vr {
    unsigned prog, vao, tex;
    int u_corner, u_tex;
    int shown;
    double x0, y0, x1, y1;
};

struct vr *vr_new(struct gv_gpu *g, struct gv_error *err)
{
    struct vr *r = calloc(1, sizeof *r);
    if (!r) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    if (!(r->prog = gv_gpu_program(g, vertex_src, fragment_src, NULL, err))) {
        free(r);
        return NULL;
    }
    r->u_corner = glGetUniformLocation(r->prog, "u_corner");
    r->u_tex = glGetUniformLocation(r->prog, "u_tex");
    glGenVertexArrays(1, &r->vao);
    glGenTextures(1, &r->tex);
    return r;
}

void vr_free(struct vr *r)
{
    if (!r)
        return;
    glDeleteProgram(r->prog);
    glDeleteVertexArrays(1, &r->vao);
    glDeleteTextures(1, &r->tex);
    free(r);
}

void vr_set(struct vr *r, const uint8_t *rgba, uint32_t w, uint32_t h, double x0,
            double y0, double x1, double y1)
{
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, r->tex);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_SKIP_ROWS, 0);
    glPixelStorei(GL_UNPACK_SKIP_PIXELS, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, (GLsizei)w, (GLsizei)h, 0, GL_RGBA,
                 GL_UNSIGNED_BYTE, rgba);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    r->x0 = x0;
    r->y0 = y0;
    r->x1 = x1;
    r->y1 = y1;
    r->shown = 1;
}

void vr_clear(struct vr *r)
{
    r->shown = 0;
}

void vr_draw(struct vr *r, const struct vg_view *v, int w, int h)
{
    if (!r->shown)
        return;
    const double px[4] = {r->x0, r->x1, r->x0, r->x1};
    const double py[4] = {r->y0, r->y0, r->y1, r->y1};
    float c[8];
    for (int i = 0; i < 4; i++) {
        double sx, sy;
        vg_image_to_screen(v, w, h, px[i], py[i], &sx, &sy);
        c[2 * i] = (float)(2 * sx / w - 1);
        c[2 * i + 1] = (float)(1 - 2 * sy / h);
    }
    glDisable(GL_BLEND);
    glUseProgram(r->prog);
    glUniform2fv(r->u_corner, 4, c);
    glUniform1i(r->u_tex, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, r->tex);
    glBindVertexArray(r->vao);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    glBindVertexArray(0);
}
