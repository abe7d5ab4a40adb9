/*
 * gpu_program.c - compiling the embedded GLSL for the current context
 * (gpu.h: gv_gpu_program, gv_gpu_compile_stage, gv_gpu_link_stages; and
 * gpu_module_int.h: gv_gpu_build_programs, the programs of every module
 * of lib/gpu, built from tables of stages and uniform names).
 *
 * The shared shader bodies carry no #version line: it depends on the
 * context (GLSL ES 3.10 on ES 3.1+, 4.30 core on desktop GL, 3.00 ES in
 * WebGL2, where the browser adds its own).  On failure the listing shows
 * the final source with line numbers beside the driver's log, so that a
 * log's "0:42" points at something (mpv's compile_attach_shader does the
 * same).  A stage's final source is the version head followed by its
 * parts, put together in one place (concat).
 */
#include <assert.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl31.h>

#include "gpu/gpu.h"
#include "gpu/gpu_module_int.h"

static char *number_lines(const char *src, const char *log)
{
    size_t cap = strlen(src) * 2 + strlen(log) + 256, n = 0;
    char *out = malloc(cap);
    if (!out)
        return NULL;
    int line = 1;
    const char *p = src;
    n += (size_t)snprintf(out + n, cap - n, "%4d  ", line);
    for (; *p && n + 16 < cap; p++) {
        out[n++] = *p;
        if (*p == '\n' && p[1])
            n += (size_t)snprintf(out + n, cap - n, "%4d  ", ++line);
    }
    snprintf(out + n, cap - n, "\n--- driver log ---\n%s\n", log);
    return out;
}

unsigned gv_gpu_compile_stage(unsigned type, const char *src, char *log, size_t cap)
{
    GLuint sh = glCreateShader(type);
    glShaderSource(sh, 1, &src, NULL);
    glCompileShader(sh);
    GLint ok = 0;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (ok)
        return sh;
    log[0] = 0;
    glGetShaderInfoLog(sh, (GLsizei)cap, NULL, log);
    log[cap - 1] = 0;
    glDeleteShader(sh);
    return 0;
}

unsigned gv_gpu_link_stages(const unsigned *stages, int n, char *log, size_t cap)
{
    GLuint p = glCreateProgram();
    for (int i = 0; i < n; i++)
        glAttachShader(p, stages[i]);
    glLinkProgram(p);
    for (int i = 0; i < n; i++)
        glDeleteShader(stages[i]);
    GLint ok = 0;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (ok)
        return p;
    log[0] = 0;
    glGetProgramInfoLog(p, (GLsizei)cap, NULL, log);
    log[cap - 1] = 0;
    glDeleteProgram(p);
    return 0;
}

static GLuint compile(GLenum type, const char *src, char **listing,
                      struct gv_error *err)
{
    char log[4096];
    GLuint sh = gv_gpu_compile_stage(type, src, log, sizeof log);
    if (sh)
        return sh;
    if (listing)
        *listing = number_lines(src, log);
    gv_fail(err, GV_EINVAL, "gpu: %s shader does not compile: %.200s",
            type == GL_VERTEX_SHADER ? "vertex" :
            type == GL_COMPUTE_SHADER ? "compute" : "fragment", log);
    return 0;
}

static const char *version_head(const struct gv_gpu *g)
{
    return gv_gpu_info(g)->es ? "#version 310 es\n#define GV_SSBO 1\n"
                              : "#version 430 core\n#define GV_SSBO 1\n";
}

/* head followed by the non-NULL parts, malloc'ed; NULL without memory.
 * The one place a shader's final source is put together. */
static char *concat(const char *head, const char *const *parts)
{
    const char *all[GV_GPU_STAGE_PARTS + 1] = {head};
    size_t len[GV_GPU_STAGE_PARTS + 1], total = 1;
    int n = 1;
    for (int i = 0; i < GV_GPU_STAGE_PARTS && parts[i]; i++)
        all[n++] = parts[i];
    for (int i = 0; i < n; i++)
        total += len[i] = strlen(all[i]);
    char *s = malloc(total), *p = s;
    if (!s)
        return NULL;
    for (int i = 0; i < n; i++) {
        memcpy(p, all[i], len[i]);
        p += len[i];
    }
    *p = 0;
    return s;
}

/* Link the n stages (deleted here); on failure the listing shows `shown`. */
static GLuint link(const GLuint *stages, int n, const char *shown, char **listing,
                   struct gv_error *err)
{
    char log[4096];
    GLuint prog = gv_gpu_link_stages(stages, n, log, sizeof log);
    if (prog)
        return prog;
    if (listing)
        *listing = number_lines(shown, log);
    gv_fail(err, GV_EINVAL, "gpu: program does not link: %.200s", log);
    return 0;
}

/* One program of one or two stages, each head + parts. */
static GLuint build(const char *head, const struct gv_gpu_stage *stage,
                    char **listing, struct gv_error *err)
{
    const int n = stage[1].type ? 2 : 1;
    char *src[2] = {NULL, NULL};
    GLuint sh[2] = {0, 0}, prog = 0;
    for (int i = 0; i < n; i++)
        if (!(src[i] = concat(head, stage[i].parts))) {
            gv_fail(err, GV_ENOMEM, "gpu: out of memory");
            goto out;
        }
    for (int i = 0; i < n; i++)
        if (!(sh[i] = compile(stage[i].type, src[i], listing, err))) {
            for (int k = 0; k < i; k++)
                glDeleteShader(sh[k]);
            goto out;
        }
    prog = link(sh, n, src[n - 1], listing, err);
out:
    free(src[0]);
    free(src[1]);
    return prog;
}

/* The version head of `path`, or NULL with *err. */
static const char *path_head(const struct gv_gpu *g, enum gv_gpu_path path,
                             struct gv_error *err)
{
    if (path == GV_GPU_PATH_COMPUTE)
        return version_head(g);
    if (!gv_gpu_info(g)->es) {
        gv_fail(err, GV_EFORMAT, "gpu: GLSL ES 3.00 needs an OpenGL ES context");
        return NULL;
    }
    return "#version 300 es\n";
}

int gv_gpu_build_programs(const struct gv_gpu *g, enum gv_gpu_path path,
                          const struct gv_gpu_program_def *defs, size_t n,
                          struct gv_error *err)
{
    const char *head = path_head(g, path, err);
    if (!head)
        return -1;
    for (size_t i = 0; i < n; i++) {
        char *listing = NULL;
        assert(path == GV_GPU_PATH_COMPUTE ||
               defs[i].stage[0].type != GL_COMPUTE_SHADER);
        *defs[i].prog = build(head, defs[i].stage, &listing, err);
        if (!*defs[i].prog) {
            if (listing)
                fprintf(stderr, "%s", listing);
            free(listing);
            return -1;
        }
        for (const struct gv_gpu_uniform *u = defs[i].uniforms; u && u->name; u++)
            *u->loc = glGetUniformLocation(*defs[i].prog, u->name);
    }
    return 0;
}

unsigned gv_gpu_program(const struct gv_gpu *g, const char *vertex,
                        const char *fragment, char **listing,
                        struct gv_error *err)
{
    const struct gv_gpu_stage stage[2] = {
        {GL_VERTEX_SHADER, {vertex}},
        {GL_FRAGMENT_SHADER, {fragment}},
    };
    return build(version_head(g), stage, listing, err);
}
