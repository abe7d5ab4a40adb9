/*
 * run_gpu.c - running a filter graph on the EGL context (filter.h
 * gv_filter_compile, gv_filter_run; docs/FILTERS.md sections 3-6).
 *
 * Everything happens in one gv_gpu_call on the GL thread.  Each used
 * module becomes one fragment program: the prelude (predefined variables),
 * a read function per input typed by the input's format, the expanded body
 * after "#line 1" (so that the driver numbers the body's lines from 1, which
 * map_log turns into the module's own line numbers), and the main
 * function.  The templates:
 *
 *   point        one draw over the padded region;
 *   logreduce    level 0 copied from input 1, then one draw per level with
 *                the previous level as the only sampled level (base = max
 *                = k - 1, so reading and writing one texture is no
 *                feedback loop);
 *   propagation  the thesis's ping-pong sweep (fig. 7.15): one draw per
 *                line into a one-texel-wide viewport, reading the texture
 *                that holds the previous line's new value.  Which texture
 *                holds the latest value of each line is tracked, so a sweep
 *                in the opposite direction that continues on the same pair
 *                (merge skipped, section 7.8.5) needs only a line copy, and
 *                a merge copies every other line in one draw when the
 *                stale lines allow it, single lines otherwise.
 *
 * Textures live in slots planned by graph.c; a slot is created at its
 * first use with the module's format and size and reused as planned.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <GLES3/gl31.h>

#include "base/byteorder.h"
#include "filter.h"
#include "gpu/gpu.h"
#include "graph_body.h"
#include "shaders.h"

enum family { FAM_FLOAT = 0, FAM_UINT, FAM_INT };

static enum family family_of(enum gv_filter_format f)
{
    return f == GV_FILTER_RGBA32UI ? FAM_UINT : f == GV_FILTER_RGBA32I ? FAM_INT : FAM_FLOAT;
}

static const char *const fam_type[] = {"vec4", "uvec4", "ivec4"};
static const char *const fam_sampler[] = {"sampler2D", "usampler2D", "isampler2D"};

static GLenum internal_format(enum gv_filter_format f)
{
    switch (f) {
    case GV_FILTER_RGBA16F: return GL_RGBA16F;
    case GV_FILTER_RGBA8: return GL_RGBA8;
    case GV_FILTER_RGBA32UI: return GL_RGBA32UI;
    case GV_FILTER_RGBA32I: return GL_RGBA32I;
    default: return GL_RGBA32F;
    }
}

struct slot {
    GLuint tex, fbo;      /* fbo: level 0 attached */
    int levels;
};

struct run {
    struct gv_gpu *gpu;
    const struct gv_filter_graph *g;
    const struct gv_filter_input *in;   /* NULL: compile only */
    int compute;                  /* propagation as compute shaders */
    struct gv_filter_stats st;
    float *out;
    GLuint *prog;                 /* per module, 0 if unused */
    GLuint copy[3];               /* per family */
    GLuint source_tex;
    GLuint values_tex[2];         /* values: channels 1-4, values2: 5-8 */
    struct slot *slots;
    int nslots;
    GLuint vao;
    int w, h;                     /* padded region */
    int mip_levels;               /* of every log-reduce texture */
    int *levels;                  /* per module: mip levels of its texture */
    unsigned char *valid[2];      /* propagation: line holds latest value */
    GLuint spare_tex, spare_fbo;  /* propagation partner / compute target */
    enum gv_filter_format spare_fmt;
};

static int gl_check(const char *what, struct gv_error *err)
{
    GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return 0;
    if (e == GL_OUT_OF_MEMORY)
        return gv_fail(err, GV_ENOMEM, "filter: GPU out of memory (%s)", what);
    return gv_fail(err, GV_EIO, "filter: GL error 0x%x (%s)", (unsigned)e, what);
}

static const char *version_line(const struct gv_gpu *gpu)
{
    return gv_gpu_info(gpu)->es ? "#version 310 es\n" : "#version 430 core\n";
}

/*
 * The body starts at "#line 1" and everything else is numbered from
 * GV_TEMPLATE_LINE (Mesa ignores #line's source-string number), so a
 * driver message about a line below GV_TEMPLATE_LINE is about the body.
 * Keep the errors, rewritten "line N: ...", and drop warnings.  Formats:
 * Mesa "0:N(C): error: ...", NVIDIA "0(N) : error C...: ...", ANGLE and
 * glslang "ERROR: 0:N: ...".
 */
#define GV_TEMPLATE_LINE 100001

static void map_log(const char *log, const char *module, struct gv_error *err)
{
    char msg[sizeof err->text];
    size_t n = 0;
    int found = 0;
    for (const char *p = log; *p && n + 8 < sizeof msg;) {
        const char *eol = strchr(p, '\n');
        size_t len = eol ? (size_t)(eol - p) : strlen(p);
        int src = 0, line = 0, col = 0, used = 0;
        const char *q = p;
        if (!strncmp(q, "ERROR: ", 7))
            q += 7;
        if (sscanf(q, "%d:%d(%d): %n", &src, &line, &col, &used) < 3 || !used) {
            used = 0;
            if (sscanf(q, "%d(%d) : %n", &src, &line, &used) < 2 || !used) {
                used = 0;
                if (sscanf(q, "%d:%d: %n", &src, &line, &used) < 2 || !used)
                    line = used = 0;
            }
        }
        const char *text = q + used;
        size_t tlen = len - (size_t)(text - p);
        int is_error = strstr(text, "error") && strstr(text, "error") < text + tlen;
        if (tlen && is_error) {
            if (line > 0 && line < GV_TEMPLATE_LINE)
                n += (size_t)snprintf(msg + n, sizeof msg - n, "%sline %d: %.*s",
                                      found ? "; " : "", line, (int)tlen, text);
            else
                n += (size_t)snprintf(msg + n, sizeof msg - n, "%s(template) %.*s",
                                      found ? "; " : "", (int)tlen, text);
            found = 1;
        }
        if (!eol)
            break;
        p = eol + 1;
    }
    if (!found)
        snprintf(msg, sizeof msg, "does not compile: %.200s", log);
    gv_fail(err, GV_EINVAL, "filter: module '%s' %s", module, msg);
}

/* The driver's log of a failed compile or link: mapped back to the user's
 * module, or, for a template (module NULL), "filter: template <what>". */
static void report(const char *log, const char *module, const char *what,
                   struct gv_error *err)
{
    if (module)
        map_log(log, module, err);
    else
        gv_fail(err, GV_EINVAL, "filter: template %s: %.200s", what, log);
}

/* Same shape as link_stages below: deliberately separate, a stage compiled
 * here, stages linked there, each failure reported through report(). */
static GLuint compile_stage(GLenum type, const char *src, const char *module,
                            struct gv_error *err)
{
    char log[2048];
    GLuint sh = gv_gpu_compile_stage(type, src, log, sizeof log);
    if (!sh)
        report(log, module, "shader does not compile", err);
    return sh;
}

/* Link the compiled stages (deleted here, whatever happens); link errors
 * are mapped like compile errors.  Same shape as compile_stage above:
 * deliberately separate, linking is its own GL step. */
static GLuint link_stages(const GLuint *sh, int n, const char *module,
                          struct gv_error *err)
{
    char log[2048];
    GLuint p = gv_gpu_link_stages(sh, n, log, sizeof log);
    if (!p)
        report(log, module, "program does not link", err);
    return p;
}

static GLuint link_program(const char *vs_src, const char *fs_src,
                           const char *module, struct gv_error *err)
{
    GLuint sh[2] = {compile_stage(GL_VERTEX_SHADER, vs_src, NULL, err), 0};
    if (!sh[0])
        return 0;
    if (!(sh[1] = compile_stage(GL_FRAGMENT_SHADER, fs_src, module, err))) {
        glDeleteShader(sh[0]);
        return 0;
    }
    return link_stages(sh, 2, module, err);
}

static GLuint link_compute(const char *src, const char *module, struct gv_error *err)
{
    GLuint cs = compile_stage(GL_COMPUTE_SHADER, src, module, err);
    return cs ? link_stages(&cs, 1, module, err) : 0;
}

static char *concat(const char *const *parts, int n)
{
    size_t len = 1;
    for (int i = 0; i < n; i++)
        len += strlen(parts[i]);
    char *s = malloc(len);
    if (!s)
        return NULL;
    s[0] = 0;
    char *e = s;
    for (int i = 0; i < n; i++)
        e = stpcpy(e, parts[i]);
    return s;
}

/* The fragment source of module i. */
/* Workgroup size and lines per dispatch of the compute sweeps. */
#define SWEEP_WG 256
#define SWEEP_K 32

static const char *image_format(enum gv_filter_format f)
{
    switch (f) {
    case GV_FILTER_RGBA16F: return "rgba16f";
    case GV_FILTER_RGBA8: return "rgba8";
    case GV_FILTER_RGBA32UI: return "rgba32ui";
    case GV_FILTER_RGBA32I: return "rgba32i";
    default: return "rgba32f";
    }
}

static const char *const fam_image[] = {"image2D", "uimage2D", "iimage2D"};

static char *module_source(const struct run *r, int i)
{
    const struct gv_filter_module *m = &r->g->module[i];
    const int sweep = r->compute && m->tpl == GV_FILTER_PROPAGATION;
    char *body = gv_filter_expand_body(m->glsl);
    size_t cap = 4096;
    char *reads = malloc(cap);
    if (!body || !reads) {
        free(body);
        free(reads);
        return NULL;
    }
    size_t n = 0;
    for (int k = 0; k < m->ninputs; k++) {
        int src = m->input[k];
        enum family f = src < 0 ? FAM_FLOAT : family_of(r->g->module[src].format);
        const char *T = fam_type[f];
        n += (size_t)snprintf(reads + n, cap - n, "uniform highp %s gv_tex%d;\n",
                              fam_sampler[f], k + 1);
        if (k == 0 && sweep) {
            /* The line being computed from before the sweep; the previous
             * line from the workgroup's shared copy. */
            n += (size_t)snprintf(reads + n, cap - n,
                                  "%s gv_in1(ivec2 p) { ivec2 s = gv_size;"
                                  " ivec2 t = clamp(p + gv_origin, ivec2(0), s - 1);"
                                  " int line = gv_axis == 0 ? t.x : t.y;"
                                  " int perp = gv_axis == 0 ? t.y : t.x;"
                                  " if (line == gv_cur_line) return %s(texelFetch(gv_tex1, t, 0));"
                                  " return gv_prev[clamp(perp - gv_seg0, 0, GV_WG - 1)]; }\n",
                                  fam_type[family_of(m->format)], fam_type[family_of(m->format)]);
            continue;
        }
        if (k == 0 && m->tpl == GV_FILTER_LOGREDUCE) {
            /* The previous level, in its own texel coordinates. */
            n += (size_t)snprintf(reads + n, cap - n,
                                  "%s gv_in1(ivec2 q) { int k = gv_shift - 1; ivec2 s = (gv_size + (1 << k) - 1) >> k;"
                                  " return texelFetch(gv_tex1, clamp(q, ivec2(0), s - 1), 0); }\n",
                                  T);
            continue;
        }
        n += (size_t)snprintf(reads + n, cap - n,
                              "%s gv_in%d(ivec2 p) { ivec2 s = gv_size;"
                              " return texelFetch(gv_tex%d, clamp(p + gv_origin, ivec2(0), s - 1), 0); }\n",
                              T, k + 1, k + 1);
        if (src >= 0 && r->g->module[src].tpl == GV_FILTER_LOGREDUCE)
            n += (size_t)snprintf(reads + n, cap - n,
                                  "uniform int gv_levels%d;\n"
                                  "%s gv_in%d(ivec2 p, int lod) { int l = clamp(lod, 0, gv_levels%d - 1);"
                                  " ivec2 s = (gv_size + (1 << l) - 1) >> l;"
                                  " return texelFetch(gv_tex%d, clamp((p + gv_origin) >> l, ivec2(0), s - 1), l); }\n",
                                  k + 1, T, k + 1, k + 1, k + 1);
    }
    char out_decl[160], sweep_defs[320] = "";
    enum family mf = family_of(m->format);
    const char *T = fam_type[mf];
    if (sweep) {
        snprintf(out_decl, sizeof out_decl, "%s gv_body()\n{\n#line 1\n", T);
        snprintf(sweep_defs, sizeof sweep_defs,
                 "#define GV_WG %d\n#define GV_K %d\n#define GV_OUT_T %s\n"
                 "#define GV_IMAGE %s\n#define GV_IMAGE_FORMAT %s\n"
                 "#define GV_PREV_SAMPLER %s\n",
                 SWEEP_WG, SWEEP_K, T, fam_image[mf], image_format(m->format),
                 fam_sampler[mf]);
    } else {
        snprintf(out_decl, sizeof out_decl,
                 "layout(location = 0) out %s gv_out;\n%s gv_body()\n{\n#line 1\n", T, T);
    }
    char line_tpl[32], line_main[32];
    snprintf(line_tpl, sizeof line_tpl, "#line %d\n", GV_TEMPLATE_LINE);
    snprintf(line_main, sizeof line_main, "\n#line %d\n", 2 * GV_TEMPLATE_LINE);
    const char *parts[] = {version_line(r->gpu), sweep_defs, line_tpl,
                           gv_shader_filter_prelude_frag,
                           sweep ? gv_shader_filter_sweep_head_comp : "", reads, out_decl,
                           body, "\n}", line_main,
                           sweep ? gv_shader_filter_sweep_comp : gv_shader_filter_main_frag};
    char *s = concat(parts, 11);
    free(body);
    free(reads);
    return s;
}

static char *vertex_source(const struct run *r)
{
    const char *parts[] = {version_line(r->gpu), gv_shader_fullscreen_vert};
    return concat(parts, 2);
}

static int compile_all(struct run *r, struct gv_error *err)
{
    char *vs = vertex_source(r);
    if (!vs)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    int rc = 0;
    for (int i = 0; i < r->g->nmodules && rc == 0; i++) {
        if (r->g->module[i].texture < 0)
            continue;
        char *fs = module_source(r, i);
        if (!fs) {
            rc = gv_fail(err, GV_ENOMEM, "filter: out of memory");
            break;
        }
        if (r->compute && r->g->module[i].tpl == GV_FILTER_PROPAGATION)
            r->prog[i] = link_compute(fs, r->g->module[i].id, err);
        else
            r->prog[i] = link_program(vs, fs, r->g->module[i].id, err);
        free(fs);
        if (!r->prog[i])
            rc = -1;
    }
    for (int f = 0; f < 3 && rc == 0; f++) {
        char defs[128];
        snprintf(defs, sizeof defs, "#define GV_SAMPLER %s\n#define GV_OUT_T %s\n",
                 fam_sampler[f], fam_type[f]);
        const char *parts[] = {version_line(r->gpu), defs, gv_shader_filter_copy_frag};
        char *fs = concat(parts, 3);
        if (!fs) {
            rc = gv_fail(err, GV_ENOMEM, "filter: out of memory");
            break;
        }
        r->copy[f] = link_program(vs, fs, NULL, err);
        free(fs);
        if (!r->copy[f])
            rc = -1;
    }
    free(vs);
    return rc;
}

/* ---- textures ---- */

static GLuint new_texture(GLenum ifmt, int w, int h, int levels)
{
    GLuint t;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, levels, ifmt, w, h);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                    levels > 1 ? GL_NEAREST_MIPMAP_NEAREST : GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return t;
}

static int ceil_log2(int v)
{
    int k = 0;
    while ((1 << k) < v)
        k++;
    return k;
}

/* Number of log-reduce passes on a w x h region. */
static int logreduce_passes(const struct gv_filter_module *m, int w, int h)
{
    int k = ceil_log2(w > h ? w : h);
    return k < m->max_passes ? k : m->max_passes;
}

static int slot_texture(struct run *r, int s, const struct gv_filter_module *m,
                        struct gv_error *err)
{
    struct slot *sl = &r->slots[s];
    if (!sl->tex) {
        /* Mip chains get a base rounded up to a multiple of 2^(levels-1),
         * so that every level holds at least ceil(size / 2^k) texels
         * (glTexStorage2D rounds level sizes down); reads clamp to the
         * region's own level sizes. */
        int lr = m->tpl == GV_FILTER_LOGREDUCE;
        sl->levels = lr ? r->mip_levels : 1;
        int unit = 1 << (sl->levels - 1);
        sl->tex = new_texture(internal_format(m->format),
                              lr ? (r->w + unit - 1) / unit * unit : r->w,
                              lr ? (r->h + unit - 1) / unit * unit : r->h, sl->levels);
        glGenFramebuffers(1, &sl->fbo);
        glBindFramebuffer(GL_FRAMEBUFFER, sl->fbo);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D,
                               sl->tex, 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            return gv_fail(err, GV_EIO, "filter: cannot render to a %s texture here",
                           gv_filter_format_name(m->format));
    }
    return gl_check("texture", err);
}

/* Bind texture `tex` to unit `unit` for sampler uniform `name`. */
static void bind_sampler(GLuint prog, const char *name, int unit, GLuint tex)
{
    glActiveTexture(GL_TEXTURE0 + (GLenum)unit);
    glBindTexture(GL_TEXTURE_2D, tex);
    glUniform1i(glGetUniformLocation(prog, name), unit);
}

static GLuint module_tex(const struct run *r, int mod)
{
    if (mod >= 0)
        return r->slots[r->g->module[mod].texture].tex;
    return mod == GV_FILTER_SOURCE ? r->source_tex
                                   : r->values_tex[mod == GV_FILTER_VALUES ? 0 : 1];
}

/* Copy all of `src` (level 0) into the framebuffer fbo, or only the lines
 * of one parity (axis 0: columns, 1: rows), or one line (line >= 0). */
static void copy_pass(struct run *r, enum family f, GLuint src, GLuint fbo,
                      int axis, int parity, int line)
{
    GLuint p = r->copy[f];
    glUseProgram(p);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    bind_sampler(p, "gv_src", 0, src);
    glUniform1i(glGetUniformLocation(p, "gv_axis"), line >= 0 ? -1 : axis);
    glUniform1i(glGetUniformLocation(p, "gv_parity"), parity);
    if (line >= 0 && axis == 0)
        glViewport(line, 0, 1, r->h);
    else if (line >= 0)
        glViewport(0, line, r->w, 1);
    else
        glViewport(0, 0, r->w, r->h);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

static void set_common_uniforms(const struct run *r, GLuint p,
                                const struct gv_filter_module *m)
{
    const struct gv_filter_input *in = r->in;
    glUseProgram(p);
    glUniform2i(glGetUniformLocation(p, "gv_origin"), (GLint)in->roi_x, (GLint)in->roi_y);
    glUniform2i(glGetUniformLocation(p, "gv_size"), r->w, r->h);
    glUniform2i(glGetUniformLocation(p, "gv_abs"), (GLint)in->abs_x, (GLint)in->abs_y);
    glUniform1i(glGetUniformLocation(p, "gv_shift"), 0);
    glUniform4f(glGetUniformLocation(p, "pixelsAround"), (float)in->roi_x,
                (float)in->roi_y, (float)(in->w - in->roi_x - in->roi_w),
                (float)(in->h - in->roi_y - in->roi_h));
    float vw = in->viewport_w ? (float)in->viewport_w : (float)in->roi_w;
    float vh = in->viewport_h ? (float)in->viewport_h : (float)in->roi_h;
    glUniform2f(glGetUniformLocation(p, "filterArea"), (float)in->roi_w, (float)in->roi_h);
    glUniform2f(glGetUniformLocation(p, "backBufferSize"), vw, vh);
    glUniform2f(glGetUniformLocation(p, "filterScaling"), (float)in->roi_w / vw,
                (float)in->roi_h / vh);
    glUniform1i(glGetUniformLocation(p, "gv_pass"), 0);
    glUniform1i(glGetUniformLocation(p, "gv_npasses"), 0);
    glUniform2i(glGetUniformLocation(p, "sweepDir"), m->dir_x, m->dir_y);
    float pv[GV_FILTER_MAX_PARAMS] = {0};
    for (int k = 0; k < m->nparams; k++)
        pv[k] = (float)in->params[m->param_base + k];
    glUniform1fv(glGetUniformLocation(p, "gv_p"), GV_FILTER_MAX_PARAMS, pv);
}

/* Bind inputs 2..n (input 1 too when bind_first). */
static void bind_inputs(struct run *r, GLuint p, const struct gv_filter_module *m,
                        int bind_first)
{
    for (int k = bind_first ? 0 : 1; k < m->ninputs; k++) {
        char name[32];
        snprintf(name, sizeof name, "gv_tex%d", k + 1);
        bind_sampler(p, name, k, module_tex(r, m->input[k]));
        int src = m->input[k];
        if (src >= 0 && r->g->module[src].tpl == GV_FILTER_LOGREDUCE) {
            snprintf(name, sizeof name, "gv_levels%d", k + 1);
            glUniform1i(glGetUniformLocation(p, name), r->levels[src]);
        }
    }
}

static void run_point(struct run *r, int i)
{
    const struct gv_filter_module *m = &r->g->module[i];
    GLuint p = r->prog[i];
    set_common_uniforms(r, p, m);
    bind_inputs(r, p, m, 1);
    glBindFramebuffer(GL_FRAMEBUFFER, r->slots[m->texture].fbo);
    glViewport(0, 0, r->w, r->h);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    r->st.passes++;
}

static GLuint fbo_for(GLuint tex, int level)
{
    GLuint fbo;
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex,
                           level);
    return fbo;
}

/*
 * Level k is drawn into a scratch texture while only level k - 1 of the
 * chain is sampled (base = max = k - 1), then blitted into level k with the
 * whole chain enabled again: OpenGL ES makes an immutable texture's
 * attachment incomplete outside [base, max], and sampling the level being
 * rendered a feedback loop, so neither may be done in one step.
 */
static int run_logreduce(struct run *r, int i, struct gv_error *err)
{
    const struct gv_filter_module *m = &r->g->module[i];
    struct slot *sl = &r->slots[m->texture];
    int passes = logreduce_passes(m, r->w, r->h);
    r->levels[i] = passes + 1;
    glBindTexture(GL_TEXTURE_2D, sl->tex);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, 0);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, sl->levels - 1);
    copy_pass(r, family_of(m->format), module_tex(r, m->input[0]), sl->fbo, -1, 0, -1);
    if (passes < 1)
        return gl_check("logreduce", err);
    int sw = (r->w + 1) / 2, sh = (r->h + 1) / 2;
    GLuint scratch = new_texture(internal_format(m->format), sw, sh, 1);
    GLuint scratch_fbo = fbo_for(scratch, 0);
    GLuint p = r->prog[i];
    set_common_uniforms(r, p, m);
    bind_inputs(r, p, m, 0);
    glUniform1i(glGetUniformLocation(p, "gv_npasses"), passes);
    GLint loc_pass = glGetUniformLocation(p, "gv_pass");
    GLint loc_shift = glGetUniformLocation(p, "gv_shift");
    glUniform1i(glGetUniformLocation(p, "gv_tex1"), 0);
    for (int k = 1; k <= passes; k++) {
        int lw = (r->w + (1 << k) - 1) >> k, lh = (r->h + (1 << k) - 1) >> k;
        glUseProgram(p);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, sl->tex);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, k - 1);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, k - 1);
        glBindFramebuffer(GL_FRAMEBUFFER, scratch_fbo);
        glViewport(0, 0, lw, lh);
        glUniform1i(loc_pass, k);
        glUniform1i(loc_shift, k);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        r->st.passes++;
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, 0);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, sl->levels - 1);
        GLuint level_fbo = fbo_for(sl->tex, k);
        glBindFramebuffer(GL_READ_FRAMEBUFFER, scratch_fbo);
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, level_fbo);
        glBlitFramebuffer(0, 0, lw, lh, 0, 0, lw, lh, GL_COLOR_BUFFER_BIT, GL_NEAREST);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glDeleteFramebuffers(1, &level_fbo);
    }
    glDeleteFramebuffers(1, &scratch_fbo);
    glDeleteTextures(1, &scratch);
    return gl_check("logreduce", err);
}

/* ---- propagation ---- */

struct pair {
    int slot[2];
    unsigned char *valid[2];   /* per line: texture holds the latest value */
    int nlines;
};

static void line_copy(struct run *r, struct pair *pr, enum family f, int axis,
                      int from, int line)
{
    copy_pass(r, f, r->slots[pr->slot[from]].tex, r->slots[pr->slot[!from]].fbo, axis,
              0, line);
    pr->valid[!from][line] = 1;
    r->st.line_copies++;
}

/* Make texture `to` hold every line's latest value. */
static void merge(struct run *r, struct pair *pr, enum family f, int axis, int to)
{
    int from = !to, stale = 0, parity = -1, same_parity = 1;
    for (int l = 0; l < pr->nlines; l++)
        if (!pr->valid[to][l]) {
            stale++;
            if (parity < 0)
                parity = l & 1;
            else if ((l & 1) != parity)
                same_parity = 0;
        }
    if (!stale)
        return;
    /* One draw copying every line of that parity is right when the source
     * holds the latest value of all of them. */
    int ok = same_parity;
    for (int l = parity; ok && l < pr->nlines; l += 2)
        if (!pr->valid[from][l])
            ok = 0;
    if (ok) {
        copy_pass(r, f, r->slots[pr->slot[from]].tex, r->slots[pr->slot[to]].fbo, axis,
                  parity, -1);
        for (int l = parity; l < pr->nlines; l += 2)
            pr->valid[to][l] = 1;
        r->st.merges++;
        return;
    }
    for (int l = 0; l < pr->nlines; l++)
        if (!pr->valid[to][l])
            line_copy(r, pr, f, axis, from, l);
    r->st.merges++;
}

static int run_propagation(struct run *r, int i, struct pair *pr, struct gv_error *err)
{
    const struct gv_filter_module *m = &r->g->module[i];
    enum family f = family_of(m->format);
    int axis = m->dir_x ? 0 : 1;
    int nlines = axis == 0 ? r->w : r->h;
    int prev = m->input[0];
    int inherited = prev >= 0 && r->g->module[prev].skip_merge;
    if (!inherited) {
        /* Start both textures as copies of input 1. */
        pr->nlines = nlines;
        GLuint src = module_tex(r, prev);
        for (int t = 0; t < 2; t++) {
            copy_pass(r, f, src, r->slots[pr->slot[t]].fbo, -1, 0, -1);
            memset(pr->valid[t], 1, (size_t)nlines);
        }
    }
    GLuint p = r->prog[i];
    set_common_uniforms(r, p, m);
    bind_inputs(r, p, m, 0);
    int passes = nlines - 1;
    glUniform1i(glGetUniformLocation(p, "gv_npasses"), passes);
    GLint loc_pass = glGetUniformLocation(p, "gv_pass");
    GLint loc_tex = glGetUniformLocation(p, "gv_tex1");
    int step = axis == 0 ? m->dir_x : m->dir_y;
    for (int k = 1; k <= passes; k++) {
        int line = step > 0 ? k : nlines - 1 - k;
        int before = line - step;
        int rd;
        if (pr->valid[0][before] && pr->valid[0][line]) {
            rd = 0;
        } else if (pr->valid[1][before] && pr->valid[1][line]) {
            rd = 1;
        } else {
            /* The sweep before this one ended in the other texture: copy
             * the previous line next to this one's latest value (thesis
             * fig. 7.15: one line copy when opposite sweeps are paired). */
            rd = pr->valid[0][line] ? 0 : 1;
            line_copy(r, pr, f, axis, !rd, before);
            glUseProgram(p);
        }
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, r->slots[pr->slot[rd]].tex);
        glUniform1i(loc_tex, 0);
        glBindFramebuffer(GL_FRAMEBUFFER, r->slots[pr->slot[!rd]].fbo);
        if (axis == 0)
            glViewport(line, 0, 1, r->h);
        else
            glViewport(0, line, r->w, 1);
        glUniform1i(loc_pass, k);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        pr->valid[!rd][line] = 1;
        pr->valid[rd][line] = 0;
        r->st.passes++;
    }
    if (m->skip_merge) {
        r->st.merges_skipped++;
    } else {
        /* Merge into the slot the plan named as the module's texture. */
        int to = pr->slot[0] == m->texture ? 0 : 1;
        merge(r, pr, f, axis, to);
    }
    return gl_check("propagation", err);
}

/* The spare texture of the region's size in format f (made or remade). */
static int spare(struct run *r, enum gv_filter_format f)
{
    if (r->spare_tex && r->spare_fmt == f)
        return 0;
    if (r->spare_tex) {
        glDeleteFramebuffers(1, &r->spare_fbo);
        glDeleteTextures(1, &r->spare_tex);
    }
    r->spare_tex = new_texture(internal_format(f), r->w, r->h, 1);
    r->spare_fbo = fbo_for(r->spare_tex, 0);
    r->spare_fmt = f;
    return glGetError() == GL_NO_ERROR ? 0 : -1;
}

/*
 * The compute sweep (shaders/filter_sweep.comp.glsl): input 1 is read,
 * the module's texture written, SWEEP_K lines per dispatch.  When the plan
 * put the module in its input's texture (a skipped merge), it writes the
 * spare texture and the two are swapped afterwards.
 */
static int run_propagation_compute(struct run *r, int i, struct gv_error *err)
{
    const struct gv_filter_module *m = &r->g->module[i];
    struct slot *sl = &r->slots[m->texture];
    GLuint a = module_tex(r, m->input[0]);
    int in_place = sl->tex == a;
    if (in_place && spare(r, m->format) < 0)
        return gl_check("spare texture", err);
    GLuint b = in_place ? r->spare_tex : sl->tex;
    GLuint bfbo = in_place ? r->spare_fbo : sl->fbo;
    int axis = m->dir_x ? 0 : 1;
    int nline = axis == 0 ? r->w : r->h, nperp = axis == 0 ? r->h : r->w;
    int passes = nline - 1;
    if (passes < 1) {
        copy_pass(r, family_of(m->format), a, bfbo, -1, 0, -1);
    } else {
        GLuint p = r->prog[i];
        set_common_uniforms(r, p, m);
        bind_inputs(r, p, m, 0);
        bind_sampler(p, "gv_tex1", 0, a);
        bind_sampler(p, "gv_prev_tex", m->ninputs, b);
        glBindImageTexture(0, b, 0, GL_FALSE, 0, GL_WRITE_ONLY, internal_format(m->format));
        glUniform1i(glGetUniformLocation(p, "gv_npasses"), passes);
        glUniform1i(glGetUniformLocation(p, "gv_axis"), axis);
        glUniform1i(glGetUniformLocation(p, "gv_step"), m->dir_x + m->dir_y);
        GLint loc_first = glGetUniformLocation(p, "gv_first_pass");
        GLint loc_lines = glGetUniformLocation(p, "gv_lines");
        GLint loc_read_first = glGetUniformLocation(p, "gv_read_first");
        GLuint groups = (GLuint)((nperp + SWEEP_WG - 2 * SWEEP_K - 1) / (SWEEP_WG - 2 * SWEEP_K));
        for (int k0 = 1; k0 <= passes; k0 += SWEEP_K) {
            int lines = passes - k0 + 1 < SWEEP_K ? passes - k0 + 1 : SWEEP_K;
            glUniform1i(loc_first, k0);
            glUniform1i(loc_lines, lines);
            glUniform1i(loc_read_first, k0 == 1);
            glDispatchCompute(groups, 1, 1);
            glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
            r->st.passes++;
        }
        glMemoryBarrier(GL_ALL_BARRIER_BITS);
    }
    if (in_place) {
        r->spare_tex = sl->tex;
        r->spare_fbo = sl->fbo;
        sl->tex = b;
        sl->fbo = bfbo;
    }
    return gl_check("compute propagation", err);
}

/* ---- the run ---- */

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static int read_result(struct run *r, struct gv_error *err)
{
    const struct gv_filter_module *m = &r->g->module[r->g->output];
    const struct gv_filter_input *in = r->in;
    size_t n = (size_t)in->roi_w * in->roi_h * 4;
    r->out = malloc(n * sizeof *r->out);
    if (!r->out)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    glBindFramebuffer(GL_FRAMEBUFFER, r->slots[m->texture].fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    enum family f = family_of(m->format);
    if (f == FAM_FLOAT && m->format != GV_FILTER_RGBA8) {
        glReadPixels((GLint)in->roi_x, (GLint)in->roi_y, (GLsizei)in->roi_w,
                     (GLsizei)in->roi_h, GL_RGBA, GL_FLOAT, r->out);
    } else if (m->format == GV_FILTER_RGBA8) {
        uint8_t *b = malloc(n);
        if (!b)
            return gv_fail(err, GV_ENOMEM, "filter: out of memory");
        glReadPixels((GLint)in->roi_x, (GLint)in->roi_y, (GLsizei)in->roi_w,
                     (GLsizei)in->roi_h, GL_RGBA, GL_UNSIGNED_BYTE, b);
        for (size_t k = 0; k < n; k++)
            r->out[k] = b[k] / 255.0f;
        free(b);
    } else {
        uint32_t *b = malloc(n * sizeof *b);
        if (!b)
            return gv_fail(err, GV_ENOMEM, "filter: out of memory");
        glReadPixels((GLint)in->roi_x, (GLint)in->roi_y, (GLsizei)in->roi_w,
                     (GLsizei)in->roi_h, GL_RGBA_INTEGER,
                     f == FAM_UINT ? GL_UNSIGNED_INT : GL_INT, b);
        for (size_t k = 0; k < n; k++)
            r->out[k] = f == FAM_UINT ? (float)b[k] : (float)(int32_t)b[k];
        free(b);
    }
    return gl_check("reading the result", err);
}

/* The values textures the graph reads (RGBA32F, 4 channels each): each
 * code c of in->values as the float nearest c * scale + offset, channels
 * past in->nvalues 0; without values (an image), the source's RGBA bytes
 * as 0..255 and values2 0. */
static int upload_values(struct run *r, struct gv_error *err)
{
    const struct gv_filter_input *in = r->in;
    const size_t n = (size_t)r->w * (size_t)r->h;
    float *v = r->g->value_channels ? malloc(n * 4 * sizeof *v) : NULL;
    if (r->g->value_channels && !v)
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    for (int t = 0; t < r->g->value_channels / 4; t++) {
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 4; c++) {
                const int ch = 4 * t + c;
                float x = 0.0f;
                if (!in->nvalues && !t) {
                    x = (float)in->rgba[i * 4 + (size_t)c];
                } else if (ch < in->nvalues) {
                    const uint8_t *b = in->values + (i * (size_t)in->nvalues + (size_t)ch) * 2;
                    x = (float)(gv_get16(b) * in->values_scale + in->values_offset);
                }
                v[i * 4 + (size_t)c] = x;
            }
        r->values_tex[t] = new_texture(GL_RGBA32F, r->w, r->h, 1);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, r->w, r->h, GL_RGBA, GL_FLOAT, v);
    }
    free(v);
    return gl_check("uploading the values", err);
}

static int execute(struct run *r, struct gv_error *err)
{
    const struct gv_filter_graph *g = r->g;
    const struct gv_filter_input *in = r->in;
    r->w = (int)in->w;
    r->h = (int)in->h;
    GLint maxsize = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &maxsize);
    if (r->w > maxsize || r->h > maxsize)
        return gv_fail(err, GV_ELIMIT,
                       "filter: a padded region of %dx%d exceeds this GPU's texture "
                       "size of %d", r->w, r->h, (int)maxsize);
    r->mip_levels = 1;
    for (int i = 0; i < g->nmodules; i++)
        if (g->module[i].texture >= 0 && g->module[i].tpl == GV_FILTER_LOGREDUCE &&
            logreduce_passes(&g->module[i], r->w, r->h) + 1 > r->mip_levels)
            r->mip_levels = logreduce_passes(&g->module[i], r->w, r->h) + 1;
    r->source_tex = new_texture(GL_RGBA8, r->w, r->h, 1);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, r->w, r->h, GL_RGBA, GL_UNSIGNED_BYTE,
                    in->rgba);
    if (gl_check("uploading the region", err) < 0 || upload_values(r, err) < 0)
        return -1;
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_SCISSOR_TEST);

    /* Texture pairs of propagation modules: the planned slot plus a
     * partner slot, picked as graph.c did (first free slot of the kind). */
    struct pair pr = {{-1, -1}, {NULL, NULL}, 0};
    int nl = r->w > r->h ? r->w : r->h;
    pr.valid[0] = malloc((size_t)nl);
    pr.valid[1] = malloc((size_t)nl);
    if (!pr.valid[0] || !pr.valid[1]) {
        free(pr.valid[0]);
        free(pr.valid[1]);
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    }
    int rc = 0;
    for (int i = 0; i < g->nmodules && rc == 0; i++) {
        const struct gv_filter_module *m = &g->module[i];
        if (m->texture < 0)
            continue;
        if (slot_texture(r, m->texture, m, err) < 0) {
            rc = -1;
            break;
        }
        if (m->tpl == GV_FILTER_POINT) {
            run_point(r, i);
        } else if (m->tpl == GV_FILTER_LOGREDUCE) {
            rc = run_logreduce(r, i, err);
        } else {
            int prev = m->input[0];
            if (r->compute) {
                rc = run_propagation_compute(r, i, err);
                continue;
            }
            if (!(prev >= 0 && g->module[prev].skip_merge)) {
                /* A fresh pair: the module's slot and the spare texture. */
                if (spare(r, m->format) < 0) {
                    rc = gl_check("spare texture", err);
                    break;
                }
                r->slots[r->nslots - 1].tex = r->spare_tex;
                r->slots[r->nslots - 1].fbo = r->spare_fbo;
                pr.slot[0] = m->texture;
                pr.slot[1] = r->nslots - 1;
            } else if (pr.slot[0] != m->texture) {
                /* graph.c gave this module its predecessor's slot. */
                rc = gv_fail(err, GV_EIO, "filter: internal: propagation pair mismatch");
                break;
            }
            rc = run_propagation(r, i, &pr, err);
        }
    }
    free(pr.valid[0]);
    free(pr.valid[1]);
    if (rc == 0)
        rc = read_result(r, err);
    return rc;
}

static void release(struct run *r)
{
    for (int i = 0; i < r->nslots; i++) {
        if (r->slots[i].tex == r->spare_tex)
            continue;   /* the spare, deleted below */
        if (r->slots[i].fbo)
            glDeleteFramebuffers(1, &r->slots[i].fbo);
        if (r->slots[i].tex)
            glDeleteTextures(1, &r->slots[i].tex);
    }
    if (r->source_tex)
        glDeleteTextures(1, &r->source_tex);
    for (int t = 0; t < 2; t++)
        if (r->values_tex[t])
            glDeleteTextures(1, &r->values_tex[t]);
    if (r->spare_tex) {
        glDeleteFramebuffers(1, &r->spare_fbo);
        glDeleteTextures(1, &r->spare_tex);
    }
    for (int i = 0; i < r->g->nmodules; i++)
        if (r->prog && r->prog[i])
            glDeleteProgram(r->prog[i]);
    for (int f = 0; f < 3; f++)
        if (r->copy[f])
            glDeleteProgram(r->copy[f]);
    if (r->vao)
        glDeleteVertexArrays(1, &r->vao);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glUseProgram(0);
    free(r->prog);
    free(r->slots);
    free(r->levels);
}

static int on_gl_thread(void *arg, struct gv_error *err)
{
    struct run *r = arg;
    double t0 = now_ms();
    int n = r->g->nmodules;
    r->prog = calloc((size_t)n, sizeof *r->prog);
    r->levels = calloc((size_t)n, sizeof *r->levels);
    /* Planned slots, plus one for the propagation partner (graph.c counts
     * it in ntextures but does not name it). */
    int maxslot = 0;
    for (int i = 0; i < n; i++)
        if (r->g->module[i].texture + 1 > maxslot)
            maxslot = r->g->module[i].texture + 1;
    r->nslots = maxslot + 1;
    r->slots = calloc((size_t)r->nslots, sizeof *r->slots);
    if (!r->prog || !r->levels || !r->slots) {
        release(r);
        return gv_fail(err, GV_ENOMEM, "filter: out of memory");
    }
    while (glGetError() != GL_NO_ERROR)
        ;
    glGenVertexArrays(1, &r->vao);
    glBindVertexArray(r->vao);
    int rc = compile_all(r, err);
    if (rc == 0 && r->in)
        rc = execute(r, err);
    if (rc == 0)
        glFinish();
    release(r);
    r->st.textures = r->g->ntextures;
    r->st.compute = r->compute;
    r->st.gpu_ms = now_ms() - t0;
    return rc;
}

int gv_filter_compile(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                      struct gv_error *err)
{
    struct run r;
    memset(&r, 0, sizeof r);
    r.gpu = gpu;
    r.g = g;
    r.compute = gv_gpu_info(gpu)->ssbo;
    return gv_gpu_call(gpu, on_gl_thread, &r, err);
}

int gv_filter_run(struct gv_gpu *gpu, const struct gv_filter_graph *g,
                  const struct gv_filter_input *in, float **out,
                  struct gv_filter_stats *stats, struct gv_error *err)
{
    *out = NULL;
    if (!in || !in->rgba || in->w < 1 || in->h < 1 || in->roi_w < 1 || in->roi_h < 1 ||
        in->roi_x > in->w || in->roi_y > in->h || in->roi_w > in->w - in->roi_x ||
        in->roi_h > in->h - in->roi_y || (g->nparams && !in->params))
        return gv_fail(err, GV_EINVAL, "filter: bad run geometry");
    if (in->nvalues < 0 || in->nvalues > 8 || (in->nvalues && !in->values) ||
        (in->nvalues && (!isfinite(in->values_scale) || !isfinite(in->values_offset))))
        return gv_fail(err, GV_EINVAL, "filter: bad values for the run");
    if (g->nmodules > 64)
        return gv_fail(err, GV_ELIMIT, "filter: too many modules");
    struct run r;
    memset(&r, 0, sizeof r);
    r.gpu = gpu;
    r.g = g;
    r.in = in;
    r.compute = in->path == GV_FILTER_PATH_AUTO ? gv_gpu_info(gpu)->ssbo
                                                : in->path == GV_FILTER_PATH_COMPUTE;
    if (r.compute && !gv_gpu_info(gpu)->ssbo)
        return gv_fail(err, GV_EFORMAT, "filter: this GPU context has no compute shaders");
    int rc = gv_gpu_call(gpu, on_gl_thread, &r, err);
    if (stats)
        *stats = r.st;
    if (rc < 0) {
        free(r.out);
        return -1;
    }
    *out = r.out;
    return 0;
}
