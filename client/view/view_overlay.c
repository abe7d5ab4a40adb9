/*
 * view_overlay.c - text and a scale bar over the picture (view_overlay.h).
 *
 * The overlay is a CPU canvas (RGBA, premultiplied by nothing: text is
 * opaque white on a translucent black box) as wide as the longest line
 * allows, uploaded when the content or the window size changes and drawn
 * as one blended quad.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl32.h>

#include "view_overlay.h"

#define SCALE 2                  /* font pixels per glyph pixel */
#define CW (6 * SCALE)           /* cell width */
#define CH (9 * SCALE)           /* cell height */
#define PAD 8

static const char vertex_src[] =
    "uniform vec4 u_rect;\n"
    "out vec2 v_uv;\n"
    "void main()\n"
    "{\n"
    "    vec2 q = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));\n"
    "    v_uv = q;\n"
    "    gl_Position = vec4(u_rect.xy + q * u_rect.zw, 0.0, 1.0);\n"
    "}\n";

static const char fragment_src[] =
    "precision mediump float;\n"
    "uniform sampler2D u_tex;\n"
    "in vec2 v_uv;\n"
    "out vec4 o_color;\n"
    "void main()\n"
    "{\n"
    "    o_color = texture(u_tex, v_uv);\n"
    "}\n";

struct vo {
    unsigned prog, vao, tex;
    int u_rect, u_tex;
    uint8_t *canvas;
    int cw, ch;                  /* canvas size (= window size) */
    struct vo_content last;
    int have_last;
};

struct vo *vo_new(struct gv_gpu *g, struct gv_error *err)
{
    struct vo *o = calloc(1, sizeof *o);
    if (!o) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    if (!(o->prog = gv_gpu_program(g, vertex_src, fragment_src, NULL, err))) {
        free(o);
        return NULL;
    }
    o->u_rect = glGetUniformLocation(o->prog, "u_rect");
    o->u_tex = glGetUniformLocation(o->prog, "u_tex");
    glGenVertexArrays(1, &o->vao);
    glGenTextures(1, &o->tex);
    return o;
}

void vo_free(struct vo *o)
{
    if (!o)
        return;
    glDeleteProgram(o->prog);
    glDeleteVertexArrays(1, &o->vao);
    glDeleteTextures(1, &o->tex);
    free(o->canvas);
    free(o);
}

static void fill(struct vo *o, int x0, int y0, int x1, int y1, uint32_t rgba)
{
    for (int y = y0 < 0 ? 0 : y0; y < y1 && y < o->ch; y++)
        for (int x = x0 < 0 ? 0 : x0; x < x1 && x < o->cw; x++)
            memcpy(o->canvas + ((size_t)y * o->cw + x) * 4, &rgba, 4);
}

static const uint32_t BOX = 0xa0000000u;   /* translucent black (little endian) */
static const uint32_t INK = 0xffffffffu;

/* Text s with its top left at (x, y). */
static void text(struct vo *o, int x, int y, const char *s)
{
    for (; *s; s++, x += CW) {
        const unsigned char *g = vo_glyph(*s);
        for (int r = 0; g && r < 7; r++)
            for (int c = 0; c < 5; c++)
                if (g[r] & (0x10 >> c))
                    fill(o, x + SCALE * c, y + SCALE * r, x + SCALE * (c + 1),
                         y + SCALE * (r + 1), INK);
    }
}

/* A box holding lines[0..n) with its top left at (x, y). */
static void block(struct vo *o, int x, int y, const char (*lines)[VO_LINE], int n)
{
    int wmax = 0, rows = 0;
    for (int i = 0; i < n; i++)
        if (lines[i][0]) {
            int len = (int)strlen(lines[i]);
            wmax = len > wmax ? len : wmax;
            rows++;
        }
    if (!rows)
        return;
    fill(o, x, y, x + wmax * CW + 2 * PAD, y + rows * CH + 2 * PAD - SCALE * 2, BOX);
    for (int i = 0, r = 0; i < n; i++)
        if (lines[i][0])
            text(o, x + PAD, y + PAD + CH * r++, lines[i]);
}

int vo_label(const char *s, uint8_t **rgba, int *w, int *h)
{
    const int len = (int)strlen(s);
    if (!len || len > VO_LINE)
        return -1;
    struct vo o = {.cw = len * CW + 2 * PAD, .ch = CH + 2 * PAD - SCALE * 2};
    if (!(o.canvas = malloc((size_t)o.cw * o.ch * 4)))
        return -1;
    fill(&o, 0, 0, o.cw, o.ch, BOX);
    text(&o, PAD, PAD, s);
    *rgba = o.canvas;
    *w = o.cw;
    *h = o.ch;
    return 0;
}

static void compose(struct vo *o, const struct vo_content *c)
{
    memset(o->canvas, 0, (size_t)o->cw * o->ch * 4);
    int rows = 0;
    for (int i = 0; i < 6; i++)
        rows += c->bottom[i][0] != 0;
    int y = o->ch - PAD - rows * CH - 2 * PAD;
    block(o, PAD, y, c->bottom, 6);
    if (c->bar_px > 0) {
        int len = (int)lround(c->bar_px), by = y - 3 * CH;
        fill(o, PAD, by, PAD + len + 2 * PAD + (int)strlen(c->bar_label) * CW + PAD,
             by + 2 * CH, BOX);
        fill(o, 2 * PAD, by + CH - 2, 2 * PAD + len, by + CH + 2, INK);
        fill(o, 2 * PAD, by + CH - 8, 2 * PAD + 2, by + CH + 8, INK);
        fill(o, 2 * PAD + len - 2, by + CH - 8, 2 * PAD + len, by + CH + 8, INK);
        text(o, 3 * PAD + len, by + CH / 2, c->bar_label);
    }
    if (c->npanel)
        block(o, PAD, PAD, c->panel, c->npanel);
}

void vo_draw(struct vo *o, int w, int h, const struct vo_content *c)
{
    if (w != o->cw || h != o->ch) {
        uint8_t *cv = realloc(o->canvas, (size_t)w * h * 4);
        if (!cv)
            return;
        o->canvas = cv;
        o->cw = w;
        o->ch = h;
        o->have_last = 0;
        glBindTexture(GL_TEXTURE_2D, o->tex);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, w, h, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    }
    glBindTexture(GL_TEXTURE_2D, o->tex);
    if (!o->have_last || memcmp(&o->last, c, sizeof *c)) {
        compose(o, c);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE,
                        o->canvas);
        o->last = *c;
        o->have_last = 1;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, w, h);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(o->prog);
    glActiveTexture(GL_TEXTURE0);
    glUniform1i(o->u_tex, 0);
    /* The canvas's first row is the window's top: flip y. */
    glUniform4f(o->u_rect, -1.0f, 1.0f, 2.0f, -2.0f);
    glBindVertexArray(o->vao);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    glBindVertexArray(0);
    glDisable(GL_BLEND);
}
