/*
 * gpu_zfield.c - the z-field sweep on the GL thread (gpu_zfield.h).
 *
 * Compute path: the heights and every vertex's state in storage buffers,
 * one dispatch of shaders/zfield_sweep.comp.glsl per level with a barrier
 * between, one packing dispatch, one read-back of n^2 / 32 words.
 *
 * Fragment path (the paper's own, and what WebGL2 can run): the heights in
 * an R32F texture, the states in two R8UI n x n targets that alternate by
 * level (a vertex's children are one level below, so each pass reads only
 * the other target), one draw of GL_POINTS per level (one point per
 * vertex, placed by gl_VertexID), then a pass that packs 128 states into
 * an RGBA32UI texel, read back.  Both programs are shaders/
 * zfield_rules.glsl followed by the variant's main file.
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
    enum gv_zfield_path path;
    GLuint sweep, pack;
    GLuint heights, enabled, packed;          /* compute: buffers */
    GLuint ztex, state[2], ptex, fbo[3], vao; /* fragment: textures */
    uint32_t n;
    GLint u_n, u_level, u_count, u_mode, u_thr2, u_tau2, u_halfk, u_xy, u_eye;
    GLint u_z, u_prev;
    GLint pk_n, pk_count, pk_prev, pk_other;
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

/* head + zfield_rules.glsl + body, malloc'ed. */
static char *source(const char *head, const char *body)
{
    const char *rules = gv_shader_zfield_rules;
    char *s = malloc(strlen(head) + strlen(rules) + strlen(body) + 1);
    if (s) {
        strcpy(s, head);
        strcat(s, rules);
        strcat(s, body);
    }
    return s;
}

static int setup(void *arg, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = ((struct call *)arg)->zf;
    const char *pack_def = "#define GV_ZFIELD_PACK 1\n";
    char *listing = NULL;
    char *a = NULL, *b = NULL, *c = NULL;
    if (zf->path == GV_ZFIELD_COMPUTE) {
        a = source("", gv_shader_zfield_sweep_comp);
        b = source(pack_def, gv_shader_zfield_sweep_comp);
        if (!a || !b)
            goto oom;
        zf->sweep = gv_gpu_compute_program(zf->gpu, a, &listing, err);
        if (zf->sweep)
            zf->pack = gv_gpu_compute_program(zf->gpu, b, &listing, err);
    } else {
        a = source("", gv_shader_zfield_points_vert);
        b = source("", gv_shader_zfield_sweep_frag);
        c = source(pack_def, gv_shader_zfield_sweep_frag);
        if (!a || !b || !c)
            goto oom;
        zf->sweep = gv_gpu_program_es300(zf->gpu, a, b, &listing, err);
        if (zf->sweep)
            zf->pack = gv_gpu_program_es300(zf->gpu, gv_shader_fullscreen_vert, c,
                                            &listing, err);
    }
    free(a), free(b), free(c);
    if (!zf->sweep || !zf->pack) {
        if (listing)
            fprintf(stderr, "%s", listing);
        free(listing);
        return -1;
    }
    static const char *names[] = {"u_n", "u_level", "u_count", "u_mode", "u_thr2",
                                  "u_tau2", "u_halfk", "u_xy", "u_eye", "u_z", "u_prev"};
    GLint *locs[] = {&zf->u_n, &zf->u_level, &zf->u_count, &zf->u_mode, &zf->u_thr2,
                     &zf->u_tau2, &zf->u_halfk, &zf->u_xy, &zf->u_eye, &zf->u_z, &zf->u_prev};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        *locs[i] = glGetUniformLocation(zf->sweep, names[i]);
    zf->pk_n = glGetUniformLocation(zf->pack, "u_n");
    zf->pk_count = glGetUniformLocation(zf->pack, "u_count");
    zf->pk_prev = glGetUniformLocation(zf->pack, "u_prev");
    zf->pk_other = glGetUniformLocation(zf->pack, "u_other");
    if (zf->path == GV_ZFIELD_COMPUTE) {
        glGenBuffers(1, &zf->heights);
        glGenBuffers(1, &zf->enabled);
        glGenBuffers(1, &zf->packed);
    } else {
        glGenTextures(1, &zf->ztex);
        glGenTextures(2, zf->state);
        glGenTextures(1, &zf->ptex);
        glGenFramebuffers(3, zf->fbo);
        glGenVertexArrays(1, &zf->vao);
    }
    return gl_failed(err, "set-up");
oom:
    free(a), free(b), free(c);
    return gv_fail(err, GV_ENOMEM, "gpu zfield: out of memory");
}

struct gv_gpu_zfield *gv_gpu_zfield_new_path(struct gv_gpu *g, enum gv_zfield_path path,
                                             struct gv_error *err)
{
    struct gv_gpu_zfield *zf = calloc(1, sizeof *zf);
    if (!zf) {
        gv_fail(err, GV_ENOMEM, "gpu zfield: out of memory");
        return NULL;
    }
    zf->gpu = g;
    zf->path = path;
    struct call c = {.zf = zf};
    if (gv_gpu_call(g, setup, &c, err) < 0) {
        gv_gpu_zfield_free(zf);
        return NULL;
    }
    return zf;
}

struct gv_gpu_zfield *gv_gpu_zfield_new(struct gv_gpu *g, struct gv_error *err)
{
    return gv_gpu_zfield_new_path(g, GV_ZFIELD_COMPUTE, err);
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
    GLuint t[4] = {zf->ztex, zf->state[0], zf->state[1], zf->ptex};
    for (int i = 0; i < 4; i++)
        if (t[i])
            glDeleteTextures(1, &t[i]);
    for (int i = 0; i < 3; i++)
        if (zf->fbo[i])
            glDeleteFramebuffers(1, &zf->fbo[i]);
    if (zf->vao)
        glDeleteVertexArrays(1, &zf->vao);
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

/* A new immutable texture of one level, nearest sampling. */
static void texture(GLuint tex, GLenum format, GLsizei w, GLsizei h)
{
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, format, w, h);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

static int upload(void *arg, struct gv_error *err)
{
    struct call *c = arg;
    struct gv_gpu_zfield *zf = c->zf;
    const size_t cells = (size_t)c->n * c->n;
    if (zf->path == GV_ZFIELD_COMPUTE) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->heights);
        glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(cells * sizeof(float)), c->z,
                     GL_STATIC_DRAW);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->enabled);
        glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(cells * sizeof(GLuint)), NULL,
                     GL_DYNAMIC_COPY);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, zf->packed);
        glBufferData(GL_SHADER_STORAGE_BUFFER,
                     (GLsizeiptr)((cells + 31) / 32 * sizeof(GLuint)), NULL, GL_DYNAMIC_READ);
    } else {
        /* Immutable textures are made once per size: new names for a new
         * grid. */
        if (zf->n) {
            glDeleteTextures(1, &zf->ztex);
            glDeleteTextures(2, zf->state);
            glDeleteTextures(1, &zf->ptex);
            glGenTextures(1, &zf->ztex);
            glGenTextures(2, zf->state);
            glGenTextures(1, &zf->ptex);
        }
        const GLsizei n = (GLsizei)c->n;
        texture(zf->ztex, GL_R32F, n, n);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, n, n, GL_RED, GL_FLOAT, c->z);
        GLuint targets[3] = {zf->state[0], zf->state[1], zf->ptex};
        for (int i = 0; i < 3; i++) {
            texture(targets[i], i < 2 ? GL_R8UI : GL_RGBA32UI, i < 2 ? n : (n + 127) / 128, n);
            glBindFramebuffer(GL_FRAMEBUFFER, zf->fbo[i]);
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D,
                                   targets[i], 0);
            if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
                glBindFramebuffer(GL_FRAMEBUFFER, 0);
                return gv_fail(err, GV_EFORMAT, "gpu zfield: R8UI/RGBA32UI targets "
                               "not renderable here");
            }
        }
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
    }
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

static void set_uniforms(const struct gv_gpu_zfield *zf, const struct gv_zfield_params *p)
{
    glUniform1i(zf->u_n, (GLint)zf->n);
    glUniform1i(zf->u_mode, p->mode == GV_ZFIELD_SCREEN);
    glUniform1f(zf->u_thr2, 2.0f * p->threshold);
    glUniform1f(zf->u_tau2, p->threshold * p->threshold);
    glUniform1f(zf->u_halfk, 0.5f * p->k);
    glUniform1f(zf->u_xy, p->xy_scale > 0 ? p->xy_scale : 1.0f);
    glUniform3f(zf->u_eye, p->eye[0], p->eye[1], p->eye[2]);
}

static void unpack(const GLuint *bits, size_t cells, uint8_t *enabled)
{
    for (size_t i = 0; i < cells; i++)
        enabled[i] = (uint8_t)((bits[i / 32] >> (i % 32)) & 1u);
}

static int run_compute(struct call *c, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = c->zf;
    const uint32_t n = zf->n;
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, zf->heights);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, zf->enabled);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, zf->packed);
    glUseProgram(zf->sweep);
    set_uniforms(zf, c->p);
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
    unpack(bits, cells, c->enabled);
    glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
    return 0;
}

static int run_fragment(struct call *c, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = c->zf;
    const uint32_t n = zf->n;
    const GLuint zero[4] = {0, 0, 0, 0};
    for (int i = 0; i < 2; i++) {
        glBindFramebuffer(GL_FRAMEBUFFER, zf->fbo[i]);
        glClearBufferuiv(GL_COLOR, 0, zero);
    }
    glBindVertexArray(zf->vao);
    glViewport(0, 0, (GLsizei)n, (GLsizei)n);
    glUseProgram(zf->sweep);
    set_uniforms(zf, c->p);
    glUniform1i(zf->u_z, 0);
    glUniform1i(zf->u_prev, 1);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, zf->ztex);
    const int levels = gv_zfield_levels(n);
    for (int lev = 0; lev < levels; lev++) {
        glBindFramebuffer(GL_FRAMEBUFFER, zf->fbo[lev & 1]);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, zf->state[(lev + 1) & 1]);
        glUniform1i(zf->u_level, lev);
        glDrawArrays(GL_POINTS, 0, (GLsizei)gv_zfield_level_count(n, lev));
    }
    /* Pack: 128 states of a row per RGBA32UI texel, from both targets. */
    const GLsizei pw = (GLsizei)((n + 127) / 128);
    glBindFramebuffer(GL_FRAMEBUFFER, zf->fbo[2]);
    glViewport(0, 0, pw, (GLsizei)n);
    glUseProgram(zf->pack);
    glUniform1i(zf->pk_n, (GLint)n);
    glUniform1i(zf->pk_prev, 1);
    glUniform1i(zf->pk_other, 2);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, zf->state[0]);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, zf->state[1]);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    GLuint *px = malloc((size_t)pw * n * 4 * sizeof *px);
    if (!px)
        return gv_fail(err, GV_ENOMEM, "gpu zfield: out of memory");
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, pw, (GLsizei)n, GL_RGBA_INTEGER, GL_UNSIGNED_INT, px);
    for (uint32_t y = 0; y < n; y++)
        for (uint32_t x = 0; x < n; x++) {
            const GLuint w = px[((size_t)y * (size_t)pw + x / 128) * 4 + (x % 128) / 32];
            c->enabled[(size_t)y * n + x] = (uint8_t)((w >> (x % 32)) & 1u);
        }
    free(px);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    return 0;
}

static int run(void *arg, struct gv_error *err)
{
    struct call *c = arg;
    const int rc = c->zf->path == GV_ZFIELD_COMPUTE ? run_compute(c, err)
                                                   : run_fragment(c, err);
    if (rc < 0)
        return rc;
    /* The corners are always enabled (the sweep never visits them). */
    const uint32_t n = c->zf->n;
    const size_t cells = (size_t)n * n;
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
