/*
 * view_draw.c - the display pass of `gigaview view` (view_draw.h).
 *
 * The arithmetic follows cmd_render.c's compose_view and sample() in
 * single precision: at 1:1 every product is exact (powers of two, a
 * cosine of 1 and a sine of 0, half-integer coordinates below 2^23), so
 * the frame equals `gigaview render`'s picture bit for bit; at fractional
 * zooms and rotations a weight may round differently in the last bit.
 * The rounded value is nudged by a quarter step before the conversion to
 * 8 bits, so a GPU that truncates there writes the same byte as one that
 * rounds (as display.frag.glsl does in the browser).  The display window
 * maps that 8-bit value through a table texture built by lib/render's
 * gv_window_table8, the server's own tables, so a windowed frame at 1:1
 * equals the server's windowed region; changing it uploads 1 KiB and
 * draws again from the resident tiles.
 */
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl32.h>

#include "view_draw.h"

static const char vertex_src[] =
    "void main()\n"
    "{\n"
    "    vec2 p = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));\n"
    "    gl_Position = vec4(p, 0.0, 1.0);\n"
    "}\n";

static const char fragment_src[] =
    "precision highp float;\n"
    "precision highp int;\n"
    "precision highp usampler2D;\n"
    "precision highp usampler2DArray;\n"
    "uniform usampler2DArray u_atlas;\n"
    "uniform usampler2D u_pt;\n"
    "uniform usampler2D u_lut;\n"
    "uniform ivec4 u_lv[40];\n"
    "uniform int u_row[40];\n"
    "uniform int u_f, u_top, u_root, u_sabotage, u_lut_on;\n"
    "uniform float u_t, u_scale, u_cs, u_sn;\n"
    "uniform vec2 u_c, u_win, u_img;\n"
    "#ifdef GV_CODES\n"
    "uniform usampler2DArray u_tables;\n"
    "uniform int u_channels;\n"
    "uniform uvec3 u_colour[8];\n"
    "#endif\n"
    "out vec4 o_color;\n"
    "\n"
    "vec3 tap(int k, ivec2 p, inout bool ok)\n"
    "{\n"
    "    ivec4 L = u_lv[k];\n"
    "    ivec2 t = min(p / 512, L.zw - 1);\n"
    "    uint s = texelFetch(u_pt, ivec2(t.x, u_row[k] + t.y), 0).r;\n"
    "    if (s == 0u) {\n"
    "        ok = false;\n"
    "        return vec3(0.0);\n"
    "    }\n"
    "    ivec2 q = p - t * 512;\n"
    "    uint flip = u_sabotage == 1 && k < u_root && q == ivec2(100) ? 1u : 0u;\n"
    "#ifdef GV_CODES\n"
    "    int base = (int(s) - 1) * u_channels;\n"
    "    uvec3 acc = uvec3(0u);\n"
    "    uint gray = 0u;\n"
    "    for (int c = 0; c < u_channels; c++) {\n"
    "        uint code = texelFetch(u_atlas, ivec3(q, base + c), 0).r ^ flip;\n"
    "        gray = texelFetch(u_tables, ivec3(int(code & 255u), int(code >> 8), c), 0).r;\n"
    "        acc += gray * u_colour[c];\n"
    "    }\n"
    "    return u_channels == 1 ? vec3(float(gray))\n"
    "                           : vec3(min((acc + 127u) / 255u, uvec3(255u)));\n"
    "#else\n"
    "    uvec4 v = texelFetch(u_atlas, ivec3(q, int(s) - 1), 0) ^ uvec4(flip);\n"
    "    return vec3(v.rgb);\n"
    "#endif\n"
    "}\n"
    "\n"
    "vec3 level_sample(int k, vec2 p, out bool ok)\n"
    "{\n"
    "    float u = ldexp(p.x, -k) - 0.5, v = ldexp(p.y, -k) - 0.5;\n"
    "    float fu = floor(u), fv = floor(v);\n"
    "    float au = u - fu, av = v - fv;\n"
    "    ivec2 m = u_lv[k].xy - 1;\n"
    "    ivec2 a = clamp(ivec2(int(fu), int(fv)), ivec2(0), m);\n"
    "    ivec2 b = clamp(ivec2(int(fu) + 1, int(fv) + 1), ivec2(0), m);\n"
    "    ok = true;\n"
    "    vec3 p00 = tap(k, a, ok), p10 = tap(k, ivec2(b.x, a.y), ok);\n"
    "    vec3 p01 = tap(k, ivec2(a.x, b.y), ok), p11 = tap(k, b, ok);\n"
    "    return (1.0 - av) * ((1.0 - au) * p00 + au * p10) +\n"
    "           av * ((1.0 - au) * p01 + au * p11);\n"
    "}\n"
    "\n"
    "void main()\n"
    "{\n"
    "    float dx = (gl_FragCoord.x - u_win.x * 0.5) * u_scale;\n"
    "    float dy = ((u_win.y - gl_FragCoord.y) - u_win.y * 0.5) * u_scale;\n"
    "    vec2 p = vec2(u_c.x + dx * u_cs - dy * u_sn, u_c.y + dx * u_sn + dy * u_cs);\n"
    "    if (p.x < 0.0 || p.y < 0.0 || p.x >= u_img.x || p.y >= u_img.y) {\n"
    "        o_color = vec4(0.0, 0.0, 0.0, 1.0);\n"
    "        return;\n"
    "    }\n"
    "    bool ok0, ok1 = false, done = true;\n"
    "    vec3 c = level_sample(u_f, p, ok0);\n"
    "    if (u_t > 0.0) {\n"
    "        vec3 b = level_sample(u_f + 1, p, ok1);\n"
    "        if (ok0 && ok1)\n"
    "            c = (1.0 - u_t) * c + u_t * b;\n"
    "        else if (ok1)\n"
    "            c = b;\n"
    "        else\n"
    "            done = ok0;\n"
    "    } else {\n"
    "        done = ok0;\n"
    "    }\n"
    "    for (int k = u_f + 1; !done && k <= u_top; k++)\n"
    "        c = level_sample(k, p, done);\n"
    "    c = floor(c + 0.5);\n"
    "    if (u_lut_on == 1) {\n"
    "        ivec3 i = clamp(ivec3(c), ivec3(0), ivec3(255));\n"
    "        c = vec3(float(texelFetch(u_lut, ivec2(i.r, 0), 0).r),\n"
    "                 float(texelFetch(u_lut, ivec2(i.g, 0), 0).g),\n"
    "                 float(texelFetch(u_lut, ivec2(i.b, 0), 0).b));\n"
    "    }\n"
    "    c += 0.25;\n"
    "    o_color = vec4(c / 255.0, 1.0);\n"
    "}\n";

/* One display program and its uniforms: [0] for image stores, [1] for
 * stores of codes (GV_CODES: the atlas holds a layer a channel, and each
 * tap goes through the tables and colours of vd_set_codes). */
struct vd_prog {
    unsigned prog;
    GLint u_atlas, u_pt, u_lut, u_lut_on, u_lv, u_row, u_f, u_top, u_root,
        u_sabotage, u_t, u_scale, u_cs, u_sn, u_c, u_win, u_img, u_tables,
        u_channels, u_colour;
};

struct vd {
    struct vd_prog p[2];
    unsigned vao, lut, tables;
    int sabotage, lut_on;
    int channels;                  /* layers of the tables */
    GLuint colour[24];
};

static int prog_new(struct gv_gpu *g, int codes, struct vd_prog *v,
                    struct gv_error *err)
{
    char *listing = NULL;
    char *src = malloc(sizeof fragment_src + 32);
    if (!src)
        return gv_fail(err, GV_ENOMEM, "out of memory");
    snprintf(src, sizeof fragment_src + 32, "%s%s", codes ? "#define GV_CODES 1\n" : "",
             fragment_src);
    v->prog = gv_gpu_program(g, vertex_src, src, &listing, err);
    free(src);
    if (!v->prog) {
        if (listing)
            fprintf(stderr, "%s\n", listing);
        free(listing);
        return -1;
    }
#define U(name) v->name = glGetUniformLocation(v->prog, #name)
    U(u_atlas); U(u_pt); U(u_lut); U(u_lut_on); U(u_lv); U(u_row); U(u_f); U(u_top); U(u_root);
    U(u_sabotage); U(u_t); U(u_scale); U(u_cs); U(u_sn); U(u_c); U(u_win); U(u_img);
    U(u_tables); U(u_channels);
#undef U
    v->u_colour = glGetUniformLocation(v->prog, "u_colour[0]");
    return 0;
}

struct vd *vd_new(struct gv_gpu *g, struct gv_error *err)
{
    struct vd *d = calloc(1, sizeof *d);
    if (!d) {
        gv_fail(err, GV_ENOMEM, "out of memory");
        return NULL;
    }
    if (prog_new(g, 0, &d->p[0], err) < 0 || prog_new(g, 1, &d->p[1], err) < 0) {
        vd_free(d);
        return NULL;
    }
    const char *sab = getenv("GIGAVIEW_VIEW_SABOTAGE");
    d->sabotage = sab && !strcmp(sab, "decode");
    glGenVertexArrays(1, &d->vao);
    glGenTextures(1, &d->lut);
    glBindTexture(GL_TEXTURE_2D, d->lut);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8UI, 256, 1);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glBindTexture(GL_TEXTURE_2D, 0);
    return d;
}

void vd_set_codes(struct vd *d, const uint8_t *tables, const uint8_t (*colour)[3],
                  int channels)
{
    if (d->tables && d->channels != channels) {
        glDeleteTextures(1, &d->tables);
        d->tables = 0;
    }
    if (!d->tables) {
        glGenTextures(1, &d->tables);
        glBindTexture(GL_TEXTURE_2D_ARRAY, d->tables);
        glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_R8UI, 256, 256, channels);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        d->channels = channels;
    }
    glBindTexture(GL_TEXTURE_2D_ARRAY, d->tables);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, 256, 256, channels,
                    GL_RED_INTEGER, GL_UNSIGNED_BYTE, tables);
    glBindTexture(GL_TEXTURE_2D_ARRAY, 0);
    memset(d->colour, 0, sizeof d->colour);
    for (int k = 0; k < channels && k < 8; k++)
        for (int j = 0; j < 3; j++)
            d->colour[3 * k + j] = colour[k][j];
}

void vd_set_window(struct vd *d, const struct gv_window *w, int channels)
{
    d->lut_on = w && w->count > 0;
    if (!d->lut_on)
        return;
    uint8_t tab[3][256], px[256 * 4];
    for (int c = 0; c < 3; c++)
        gv_window_table8(gv_window_of(w, channels == 1 ? 0 : c), tab[c]);
    for (int v = 0; v < 256; v++) {
        for (int c = 0; c < 3; c++)
            px[v * 4 + c] = tab[c][v];
        px[v * 4 + 3] = 255;
    }
    glBindTexture(GL_TEXTURE_2D, d->lut);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 256, 1, GL_RGBA_INTEGER,
                    GL_UNSIGNED_BYTE, px);
    glBindTexture(GL_TEXTURE_2D, 0);
}

void vd_free(struct vd *d)
{
    if (!d)
        return;
    for (int i = 0; i < 2; i++)
        if (d->p[i].prog)
            glDeleteProgram(d->p[i].prog);
    glDeleteVertexArrays(1, &d->vao);
    glDeleteTextures(1, &d->lut);
    if (d->tables)
        glDeleteTextures(1, &d->tables);
    free(d);
}

void vd_draw(struct vd *d, const struct vt *t, const struct vt_plan *p,
             const struct vg_view *v, int w, int h)
{
    const struct vt_gl *gl = vt_gl(t);
    const struct gv_geometry *g = vt_geometry(t);
    const struct vd_prog *P = &d->p[gl->codes ? 1 : 0];
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, w, h);
    glDisable(GL_BLEND);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_DEPTH_TEST);
    glUseProgram(P->prog);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, gl->atlas);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, gl->page_table);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, d->lut);
    if (gl->codes) {
        glActiveTexture(GL_TEXTURE3);
        glBindTexture(GL_TEXTURE_2D_ARRAY, d->tables);
        glUniform1i(P->u_tables, 3);
        glUniform1i(P->u_channels, g->channels);
        glUniform3uiv(P->u_colour, 8, d->colour);
    }
    glActiveTexture(GL_TEXTURE0);
    glUniform1i(P->u_atlas, 0);
    glUniform1i(P->u_pt, 1);
    glUniform1i(P->u_lut, 2);
    glUniform1i(P->u_lut_on, d->lut_on);
    glUniform4iv(P->u_lv, gl->nlevels, &gl->lv[0][0]);
    glUniform1iv(P->u_row, gl->nlevels, gl->row);
    glUniform1i(P->u_f, p->f);
    glUniform1i(P->u_top, gl->nlevels - 1);
    glUniform1i(P->u_root, gl->root);
    glUniform1i(P->u_sabotage, d->sabotage);
    glUniform1f(P->u_t, (float)p->t);
    glUniform1f(P->u_scale, (float)p->scale);
    glUniform1f(P->u_cs, (float)p->cs);
    glUniform1f(P->u_sn, (float)p->sn);
    glUniform2f(P->u_c, (float)v->cx, (float)v->cy);
    glUniform2f(P->u_win, (float)w, (float)h);
    glUniform2f(P->u_img, (float)g->width, (float)g->height);
    glBindVertexArray(d->vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
}

void vd_read(int w, int h, int channels, uint8_t *px)
{
    uint8_t *rgba = malloc((size_t)w * h * 4);
    if (!rgba) {
        memset(px, 0, (size_t)w * h * channels);
        return;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    glPixelStorei(GL_PACK_SKIP_ROWS, 0);
    glPixelStorei(GL_PACK_SKIP_PIXELS, 0);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    for (int j = 0; j < h; j++) {
        const uint8_t *src = rgba + (size_t)(h - 1 - j) * w * 4;
        uint8_t *dst = px + (size_t)j * w * channels;
        for (int i = 0; i < w; i++)
            for (int c = 0; c < channels; c++)
                dst[i * channels + c] = src[i * 4 + c];
    }
    free(rgba);
}
