/*
 * gpu_program.c - compiling the embedded GLSL for the current context
 * (gpu.h, gv_gpu_program).
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

#include "gpu.h"

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

static GLuint compile(GLenum type, const char *src, char **listing,
                      struct gv_error *err)
{
    GLuint sh = glCreateShader(type);
    glShaderSource(sh, 1, &src, NULL);
    glCompileShader(sh);
    GLint ok = 0;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (ok)
        return sh;
    char log[4096] = "";
    glGetShaderInfoLog(sh, sizeof log, NULL, log);
    if (listing)
        *listing = number_lines(src, log);
    gv_fail(err, GV_EINVAL, "gpu: %s shader does not compile: %.200s",
            type == GL_VERTEX_SHADER ? "vertex" : "fragment", log);
    glDeleteShader(sh);
    return 0;
}

unsigned gv_gpu_program(const struct gv_gpu *g, const char *vertex,
                        const char *fragment, char **listing,
                        struct gv_error *err)
{
    const struct gv_gpu_info *in = gv_gpu_info(g);
    const char *head = in->es ? "#version 310 es\n#define GV_SSBO 1\n"
                              : "#version 430 core\n#define GV_SSBO 1\n";
    char *vs = malloc(strlen(head) + strlen(vertex) + 1);
    char *fs = malloc(strlen(head) + strlen(fragment) + 1);
    GLuint prog = 0, v = 0, f = 0;
    if (!vs || !fs) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        goto out;
    }
    strcat(strcpy(vs, head), vertex);
    strcat(strcpy(fs, head), fragment);
    if (!(v = compile(GL_VERTEX_SHADER, vs, listing, err)) ||
        !(f = compile(GL_FRAGMENT_SHADER, fs, listing, err)))
        goto out;
    prog = glCreateProgram();
    glAttachShader(prog, v);
    glAttachShader(prog, f);
    glLinkProgram(prog);
    GLint ok = 0;
    glGetProgramiv(prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[4096] = "";
        glGetProgramInfoLog(prog, sizeof log, NULL, log);
        if (listing)
            *listing = number_lines(fs, log);
        gv_fail(err, GV_EINVAL, "gpu: program does not link: %.200s", log);
        glDeleteProgram(prog);
        prog = 0;
    }
out:
    if (v)
        glDeleteShader(v);
    if (f)
        glDeleteShader(f);
    free(vs);
    free(fs);
    return prog;
}
