/*
 * gpu_program.c - compiling the embedded GLSL for the current context
 * (gpu.h: gv_gpu_program, gv_gpu_program_es300, gv_gpu_compute_program).
 *
 * The shared shader bodies carry no #version line: it depends on the
 * context (GLSL ES 3.10 on ES 3.1+, 4.30 core on desktop GL, 3.00 ES in
 * WebGL2, where the browser adds its own).  On failure the listing shows
 * the final source with line numbers beside the driver's log, so that a
 * log's "0:42" points at something (mpv's compile_attach_shader does the
 * same).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl31.h>

#include "gpu/gpu.h"

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

static char *with_head(const char *head, const char *body)
{
    char *s = malloc(strlen(head) + strlen(body) + 1);
    if (s)
        strcat(strcpy(s, head), body);
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

unsigned gv_gpu_compute_program(const struct gv_gpu *g, const char *compute,
                                char **listing, struct gv_error *err)
{
    char *cs = with_head(version_head(g), compute);
    GLuint c = 0, prog = 0;
    if (!cs) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return 0;
    }
    if ((c = compile(GL_COMPUTE_SHADER, cs, listing, err)))
        prog = link(&c, 1, cs, listing, err);
    free(cs);
    return prog;
}

static unsigned program_with_head(const char *head, const char *vertex,
                                  const char *fragment, char **listing,
                                  struct gv_error *err)
{
    char *vs = with_head(head, vertex);
    char *fs = with_head(head, fragment);
    GLuint prog = 0, v = 0, f = 0;
    if (!vs || !fs) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        goto out;
    }
    if (!(v = compile(GL_VERTEX_SHADER, vs, listing, err)))
        goto out;
    if (!(f = compile(GL_FRAGMENT_SHADER, fs, listing, err))) {
        glDeleteShader(v);
        goto out;
    }
    prog = link((const GLuint[]){v, f}, 2, fs, listing, err);
out:
    free(vs);
    free(fs);
    return prog;
}

unsigned gv_gpu_program(const struct gv_gpu *g, const char *vertex,
                        const char *fragment, char **listing,
                        struct gv_error *err)
{
    return program_with_head(version_head(g), vertex, fragment, listing, err);
}

unsigned gv_gpu_program_es300(const struct gv_gpu *g, const char *vertex,
                              const char *fragment, char **listing,
                              struct gv_error *err)
{
    if (!gv_gpu_info(g)->es) {
        gv_fail(err, GV_EFORMAT, "gpu: GLSL ES 3.00 needs an OpenGL ES context");
        return 0;
    }
    return program_with_head("#version 300 es\n", vertex, fragment, listing, err);
}
