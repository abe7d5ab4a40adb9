/*
 * view_select.c - the Shift-drag selection (view_select.h).
 *
 * The region is found in image space (vg_screen_to_image of the drag's
 * four corners) and drawn back through vg_image_to_screen, so what is
 * drawn is what vsel_region gives the filter: when the view is turned it
 * is the turned bounding box, not the rectangle the pointer spans.  The
 * outlines are two rings of triangles, one window pixel wide each, between
 * the region's edges offset by +1, 0 and -1 pixel along their normals (a
 * rectangle stays one in the window: the view's mapping is a similarity),
 * so at 1:1 unturned they cover whole pixel rows and columns exactly.
 * One small program draws the rings, the fill and the label's texture.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl32.h>

#include "view_overlay.h"
#include "view_select.h"

static const char vertex_src[] =
    "uniform vec2 u_pt[10];\n"
    "out vec2 v_uv;\n"
    "void main()\n"
    "{\n"
    "    v_uv = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));\n"
    "    gl_Position = vec4(u_pt[gl_VertexID], 0.0, 1.0);\n"
    "}\n";

static const char fragment_src[] =
    "precision mediump float;\n"
    "uniform sampler2D u_tex;\n"
    "uniform vec4 u_color;\n"
    "uniform int u_textured;\n"
    "in vec2 v_uv;\n"
    "out vec4 o_color;\n"
    "void main()\n"
    "{\n"
    "    o_color = u_textured != 0 ? texture(u_tex, v_uv) : u_color;\n"
    "}\n";

struct vsel {
    unsigned prog, vao, tex;
    int u_pt, u_tex, u_color, u_textured;
    char label[VO_LINE];         /* the text the texture holds */
    int lw, lh;                  /* its size */
};

/* Round v to the nearest integer when it is within 1e-6 of it: the
 * view's trigonometry leaves 90-degree turns a few ulps off. */
static double snap(double v)
{
    double r = nearbyint(v);
    return fabs(v - r) < 1e-6 ? r : v;
}

int vsel_region(const struct vg_view *v, int w, int h, const double sel[4],
                const struct gv_geometry *g, int top, struct vsel_region *out)
{
    double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
    for (int i = 0; i < 4; i++) {
        double px, py;
        vg_screen_to_image(v, w, h, sel[(i & 1) * 2], sel[1 + (i >> 1) * 2], &px, &py);
        x0 = fmin(x0, px), y0 = fmin(y0, py), x1 = fmax(x1, px), y1 = fmax(y1, py);
    }
    int level = (int)floor(v->zoom + 1e-9);
    if (level > top)
        level = top;
    if (level < 0)
        level = 0;
    uint32_t lw, lh;
    if (!isfinite(x0) || !isfinite(y0) || !isfinite(x1) || !isfinite(y1) ||
        gv_level_size(g, level, &lw, &lh) < 0)
        return -1;
    const double s = exp2(level);
    double a = fmax(0, floor(snap(x0 / s))), b = fmax(0, floor(snap(y0 / s)));
    double c = fmin(lw, ceil(snap(x1 / s))), d = fmin(lh, ceil(snap(y1 / s)));
    if (c <= a || d <= b)
        return -1;
    out->level = level;
    out->x = (uint32_t)a;
    out->y = (uint32_t)b;
    out->w = (uint32_t)(c - a);
    out->h = (uint32_t)(d - b);
    out->x0 = a * s;
    out->y0 = b * s;
    out->x1 = fmin(c * s, g->width);
    out->y1 = fmin(d * s, g->height);
    return 0;
}

struct vsel *vsel_new(struct gv_gpu *g, struct gv_error *err)
{
    struct vsel *s = calloc(1, sizeof *s);
    if (!s) {
        gv_fail(err, GV_ENOMEM, "view: out of memory");
        return NULL;
    }
    if (!(s->prog = gv_gpu_program(g, vertex_src, fragment_src, NULL, err))) {
        free(s);
        return NULL;
    }
    s->u_pt = glGetUniformLocation(s->prog, "u_pt");
    s->u_tex = glGetUniformLocation(s->prog, "u_tex");
    s->u_color = glGetUniformLocation(s->prog, "u_color");
    s->u_textured = glGetUniformLocation(s->prog, "u_textured");
    glGenVertexArrays(1, &s->vao);
    glGenTextures(1, &s->tex);
    return s;
}

void vsel_free(struct vsel *s)
{
    if (!s)
        return;
    glDeleteProgram(s->prog);
    glDeleteVertexArrays(1, &s->vao);
    glDeleteTextures(1, &s->tex);
    free(s);
}

/* Window points pt[0..n) (pixels from the top left) as clip coordinates
 * into the program's u_pt. */
static void points(struct vsel *s, const double (*pt)[2], int n, int w, int h)
{
    float c[20];
    for (int i = 0; i < n; i++) {
        c[2 * i] = (float)(2 * pt[i][0] / w - 1);
        c[2 * i + 1] = (float)(1 - 2 * pt[i][1] / h);
    }
    glUniform2fv(s->u_pt, n, c);
}

/* Corner i of quad p (in order around it) moved by d pixels out of it
 * along both of its edges' normals. */
static void offset(const double p[4][2], int i, double d, double out[2])
{
    out[0] = p[i][0];
    out[1] = p[i][1];
    for (int k = 1; k <= 3; k += 2) {        /* the next corner and the one before */
        const double *q = p[(i + k) % 4];
        double ex = p[i][0] - q[0], ey = p[i][1] - q[1], len = hypot(ex, ey);
        if (len > 1e-9) {
            out[0] += d * ex / len;
            out[1] += d * ey / len;
        }
    }
}

/* The ring between quad p offset by d_out and by d_in, in one colour. */
static void ring(struct vsel *s, const double p[4][2], double d_out, double d_in, int w,
                 int h, float r, float g, float b)
{
    double pt[10][2];
    for (int i = 0; i <= 4; i++) {
        offset(p, i % 4, d_out, pt[2 * i]);
        offset(p, i % 4, d_in, pt[2 * i + 1]);
    }
    points(s, pt, 10, w, h);
    glUniform4f(s->u_color, r, g, b, 1.0f);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 10);
}

/* The label's texture for text t (uploaded when t changed).  0 or -1. */
static int label(struct vsel *s, const char *t)
{
    if (s->lw && !strcmp(s->label, t))
        return 0;
    uint8_t *rgba;
    int w, h;
    if (vo_label(t, &rgba, &w, &h) < 0)
        return -1;
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, s->tex);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_SKIP_ROWS, 0);
    glPixelStorei(GL_UNPACK_SKIP_PIXELS, 0);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    free(rgba);
    snprintf(s->label, sizeof s->label, "%s", t);
    s->lw = w;
    s->lh = h;
    return 0;
}

void vsel_draw(struct vsel *s, const struct vg_view *v, int w, int h,
               const struct vsel_region *r)
{
    const double ix[4] = {r->x0, r->x1, r->x1, r->x0};
    const double iy[4] = {r->y0, r->y0, r->y1, r->y1};
    double p[4][2], bx0 = INFINITY, bx1 = -INFINITY, by1 = -INFINITY;
    for (int i = 0; i < 4; i++) {
        vg_image_to_screen(v, w, h, ix[i], iy[i], &p[i][0], &p[i][1]);
        p[i][0] = snap(p[i][0]);
        p[i][1] = snap(p[i][1]);
        bx0 = fmin(bx0, p[i][0]);
        bx1 = fmax(bx1, p[i][0]);
        by1 = fmax(by1, p[i][1]);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, w, h);
    glUseProgram(s->prog);
    glBindVertexArray(s->vao);
    glUniform1i(s->u_textured, 0);
    /* The fill, inside the light ring. */
    double q[4][2];
    for (int i = 0; i < 4; i++)
        offset(p, i, -1, q[i]);
    const double strip[4][2] = {{q[0][0], q[0][1]}, {q[1][0], q[1][1]},
                                {q[3][0], q[3][1]}, {q[2][0], q[2][1]}};
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    if (hypot(p[1][0] - p[0][0], p[1][1] - p[0][1]) > 2 &&
        hypot(p[3][0] - p[0][0], p[3][1] - p[0][1]) > 2) {
        points(s, strip, 4, w, h);
        glUniform4f(s->u_color, 1.0f, 1.0f, 1.0f, (float)VSEL_FILL_ALPHA);
        glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    }
    glDisable(GL_BLEND);
    ring(s, p, 1, 0, w, h, 0.0f, 0.0f, 0.0f);      /* dark, outside */
    ring(s, p, 0, -1, w, h, 1.0f, 1.0f, 1.0f);     /* light, inside */
    /* The size, below the region. */
    char t[VO_LINE];
    int n = snprintf(t, sizeof t, "%.0f x %.0f px", r->x1 - r->x0, r->y1 - r->y0);
    if (r->level > 0 && n > 0 && (size_t)n < sizeof t)
        snprintf(t + n, sizeof t - (size_t)n, "  level %d: %u x %u", r->level, r->w, r->h);
    if (label(s, t) == 0) {
        double lx = fmax(0, fmin(floor(bx0), w - s->lw));
        double ly = fmax(0, fmin(ceil(by1) + 4, h - s->lh));
        const double quad[4][2] = {{lx, ly}, {lx + s->lw, ly}, {lx, ly + s->lh},
                                   {lx + s->lw, ly + s->lh}};
        points(s, quad, 4, w, h);
        glUniform1i(s->u_textured, 1);
        glUniform1i(s->u_tex, 0);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, s->tex);
        glEnable(GL_BLEND);
        glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
        glDisable(GL_BLEND);
    }
    glBindVertexArray(0);
}
