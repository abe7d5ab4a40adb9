/*
 * gpu_zfield.c - the z-field sweep on the GL thread (gpu_zfield.h): the
 * heights and the enabled states in storage buffers, one dispatch of
 * shaders/zfield_sweep.comp.glsl per level with a barrier between, one
 * packing dispatch, one read-back of n^2 / 32 words.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl31.h>

#include "gpu/gpu_zfield.h"
#include "shaders.h"

/* Work groups along x of a dispatch (64 invocations each); more
 * invocations go to further rows (ES guarantees 65535 per dimension). */
#define ROW_GROUPS 1024

struct gv_gpu_zfield {
    struct gv_gpu *gpu;
    GLuint sweep, pack, heights, enabled, packed;
    uint32_t n;
    GLint u_n, u_level, u_count, u_mode, u_thr2, u_tau2, u_halfk, u_xy, u_eye;
    GLint pk_n, pk_count;
};

struct call {
    struct gv_gpu_zfield *zf;
    const float *z;
    uint32_t n;
    const struct gv_zfield_params *p;
    uint8_t *enabled;
};

static int gl_failed(struct gv_error *err, const char *what)
{
    const GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return 0;
    return gv_fail(err, GV_EIO, "gpu zfield: %s failed (GL error 0x%04x)", what, e);
}

static int setup(void *arg, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = ((struct call *)arg)->zf;
    char *listing = NULL;
    zf->sweep = gv_gpu_compute_program(zf->gpu, gv_shader_zfield_sweep_comp, &listing, err);
    if (zf->sweep) {
        const char *def = "#define GV_ZFIELD_PACK 1\n";
        char *src = malloc(strlen(def) + strlen(gv_shader_zfield_sweep_comp) + 1);
        if (!src)
            return gv_fail(err, GV_ENOMEM, "gpu zfield: out of memory");
        strcpy(src, def);
        strcat(src, gv_shader_zfield_sweep_comp);
        zf->pack = gv_gpu_compute_program(zf->gpu, src, &listing, err);
        free(src);
    }
    if (!zf->sweep || !zf->pack) {
        if (listing)
            fprintf(stderr, "%s", listing);
        free(listing);
        return -1;
    }
    static const char *names[] = {"u_n", "u_level", "u_count", "u_mode", "u_thr2",
                                  "u_tau2", "u_halfk", "u_xy", "u_eye"};
    GLint *locs[] = {&zf->u_n, &zf->u_level, &zf->u_count, &zf->u_mode, &zf->u_thr2,
                     &zf->u_tau2, &zf->u_halfk, &zf->u_xy, &zf->u_eye};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        *locs[i] = glGetUniformLocation(zf->sweep, names[i]);
    zf->pk_n = glGetUniformLocation(zf->pack, "u_n");
    zf->pk_count = glGetUniformLocation(zf->pack, "u_count");
    glGenBuffers(1, &zf->heights);
    glGenBuffers(1, &zf->enabled);
    glGenBuffers(1, &zf->packed);
    return gl_failed(err, "set-up");
}

struct gv_gpu_zfield *gv_gpu_zfield_new(struct gv_gpu *g, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = calloc(1, sizeof *zf);
    if (!zf) {
        gv_fail(err, GV_ENOMEM, "gpu zfield: out of memory");
        return NULL;
    }
    zf->gpu = g;
    struct call c = {.zf = zf};
    if (gv_gpu_call(g, setup, &c, err) < 0) {
        gv_gpu_zfield_free(zf);
        return NULL;
    }
    return zf;
}

static int teardown(void *arg, struct gv_error *err)
{
    (void)err;
    struct gv_gpu_zfield *zf = ((struct call *)arg)->zf;
    if (zf->sweep)
        glDeleteProgram(zf->sweep);
    if (zf->pack)
        glDeleteProgram(zf->pack);
    GLuint b[3] = {zf->heights, zf->enabled, zf->packed};
    for (int i = 0; i < 3; i++)
        if (b[i])
            glDeleteBuffers(1, &b[i]);
    return 0;
}

void gv_gpu_zfield_free(struct gv_gpu_zfield *zf)
{
    if (!zf)
        return;
    struct call c = {.zf = zf};
    gv_gpu_call(zf->gpu, teardown, &c, NULL);
    free(zf);
}

static int upload(void *arg, struct gv_error *err)
{
    struct call *c = arg;
    struct gv_gpu_zfield *zf = c->zf;
    const size_t cells = (size_t)c->n * c->n;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->heights);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(cells * sizeof(float)), c->z,
                 GL_STATIC_DRAW);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->enabled);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(cells * sizeof(GLuint)), NULL,
                 GL_DYNAMIC_COPY);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->packed);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)((cells + 31) / 32 * sizeof(GLuint)),
                 NULL, GL_DYNAMIC_READ);
    zf->n = c->n;
    return gl_failed(err, "height upload");
}

int gv_gpu_zfield_heights(struct gv_gpu_zfield *zf, const float *z, uint32_t n,
                          struct gv_error *err)
{
    if (!gv_zfield_side_ok(n))
        return gv_fail(err, GV_EINVAL, "gpu zfield: the grid must be (2^k+1) x (2^k+1) "
                       "samples, not %u", n);
    struct call c = {.zf = zf, .z = z, .n = n};
    return gv_gpu_call(zf->gpu, upload, &c, err);
}

/* Dispatch enough groups of 64 for `count` invocations. */
static void dispatch(uint64_t count)
{
    const uint64_t groups = (count + 63) / 64;
    const GLuint gx = groups < ROW_GROUPS ? (GLuint)groups : ROW_GROUPS;
    const GLuint gy = (GLuint)((groups + gx - 1) / gx);
    glDispatchCompute(gx, gy, 1);
}

static int run(void *arg, struct gv_error *err)
{
    struct call *c = arg;
    struct gv_gpu_zfield *zf = c->zf;
    const struct gv_zfield_params *p = c->p;
    const uint32_t n = zf->n;
    const float xy = p->xy_scale > 0 ? p->xy_scale : 1.0f;
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, zf->heights);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, zf->enabled);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, zf->packed);
    glUseProgram(zf->sweep);
    glUniform1i(zf->u_n, (GLint)n);
    glUniform1i(zf->u_mode, p->mode == GV_ZFIELD_SCREEN);
    glUniform1f(zf->u_thr2, 2.0f * p->threshold);
    glUniform1f(zf->u_tau2, p->threshold * p->threshold);
    glUniform1f(zf->u_halfk, 0.5f * p->k);
    glUniform1f(zf->u_xy, xy);
    glUniform3f(zf->u_eye, p->eye[0], p->eye[1], p->eye[2]);
    const int levels = gv_zfield_levels(n);
    for (int lev = 0; lev < levels; lev++) {
        const uint64_t count = gv_zfield_level_count(n, lev);
        glUniform1i(zf->u_level, lev);
        glUniform1i(zf->u_count, (GLint)count);
        dispatch(count);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
    const size_t cells = (size_t)n * n, words = (cells + 31) / 32;
    glUseProgram(zf->pack);
    glUniform1i(zf->pk_n, (GLint)n);
    glUniform1i(zf->pk_count, (GLint)words);
    dispatch(words);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->packed);
    const GLuint *bits = glMapBufferRange(GL_SHADER_STORAGE_BUFFER, 0,
                                          (GLsizeiptr)(words * sizeof(GLuint)),
                                          GL_MAP_READ_BIT);
    if (!bits)
        return gl_failed(err, "read-back") < 0 ? -1
               : gv_fail(err, GV_EIO, "gpu zfield: read-back failed");
    for (size_t i = 0; i < cells; i++)
        c->enabled[i] = (uint8_t)((bits[i / 32] >> (i % 32)) & 1u);
    glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
    /* The corners are always enabled (the sweep never visits them). */
    c->enabled[0] = c->enabled[n - 1] = 1;
    c->enabled[(size_t)(n - 1) * n] = c->enabled[cells - 1] = 1;
    return gl_failed(err, "sweep");
}

int gv_gpu_zfield_enable(struct gv_gpu_zfield *zf, const struct gv_zfield_params *p,
                         uint8_t *enabled, struct gv_error *err)
{
    if (!zf->n)
        return gv_fail(err, GV_EINVAL, "gpu zfield: no heights uploaded");
    if (!(p->threshold >= 0) || (p->mode == GV_ZFIELD_SCREEN && !(p->k > 0)))
        return gv_fail(err, GV_EINVAL, "gpu zfield: bad threshold or camera");
    struct call c = {.zf = zf, .p = p, .enabled = enabled};
    return gv_gpu_call(zf->gpu, run, &c, err);
}
