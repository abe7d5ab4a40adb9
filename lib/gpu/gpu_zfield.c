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
#include <stdlib.h>

#include <GLES3/gl31.h>

#include "gpu/gpu_zfield.h"
#include "gpu/gpu_module_int.h"
#include "shaders.h"

/* Work groups along x of a dispatch (64 invocations each); more
 * invocations go to further rows (ES guarantees 65535 per dimension). */
#define ROW_GROUPS 1024

struct gv_gpu_zfield {
    struct gv_gpu *gpu;
    enum gv_gpu_path path;
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

/* The sweep and the packing pass: zfield_rules.glsl then the variant's
 * main file, the packing pass with GV_ZFIELD_PACK defined first. */
static int build_programs(struct gv_gpu_zfield *zf, struct gv_error *err)
{
    static const char pack_def[] = "#define GV_ZFIELD_PACK 1\n";
    const char *rules = gv_shader_zfield_rules;
    const struct gv_gpu_uniform sweep_u[] = {
        {"u_n", &zf->u_n}, {"u_level", &zf->u_level}, {"u_count", &zf->u_count},
        {"u_mode", &zf->u_mode}, {"u_thr2", &zf->u_thr2}, {"u_tau2", &zf->u_tau2},
        {"u_halfk", &zf->u_halfk}, {"u_xy", &zf->u_xy}, {"u_eye", &zf->u_eye},
        {"u_z", &zf->u_z}, {"u_prev", &zf->u_prev}, {NULL, NULL},
    };
    const struct gv_gpu_uniform pack_u[] = {
        {"u_n", &zf->pk_n}, {"u_count", &zf->pk_count}, {"u_prev", &zf->pk_prev},
        {"u_other", &zf->pk_other}, {NULL, NULL},
    };
    const struct gv_gpu_program_def compute[] = {
        {&zf->sweep, {{GL_COMPUTE_SHADER, {rules, gv_shader_zfield_sweep_comp}}},
         sweep_u},
        {&zf->pack, {{GL_COMPUTE_SHADER,
                      {pack_def, rules, gv_shader_zfield_sweep_comp}}}, pack_u},
    };
    const struct gv_gpu_program_def fragment[] = {
        {&zf->sweep, {{GL_VERTEX_SHADER, {rules, gv_shader_zfield_points_vert}},
                      {GL_FRAGMENT_SHADER, {rules, gv_shader_zfield_sweep_frag}}},
         sweep_u},
        {&zf->pack, {{GL_VERTEX_SHADER, {gv_shader_fullscreen_vert}},
                     {GL_FRAGMENT_SHADER,
                      {pack_def, rules, gv_shader_zfield_sweep_frag}}}, pack_u},
    };
    return gv_gpu_build_programs(zf->gpu, zf->path,
                                 zf->path == GV_GPU_PATH_COMPUTE ? compute : fragment,
                                 2, err);
}

static int setup(void *arg, struct gv_error *err)
{
    struct gv_gpu_zfield *zf = ((struct call *)arg)->zf;
    if (build_programs(zf, err) < 0)
        return -1;
    if (zf->path == GV_GPU_PATH_COMPUTE) {
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
    return gv_gpu_gl_check(err, "zfield set-up");
}

struct gv_gpu_zfield *gv_gpu_zfield_new(struct gv_gpu *g,
                                        const struct gv_gpu_zfield_opts *o,
                                        struct gv_error *err)
{
    const enum gv_gpu_path path = o ? o->path : GV_GPU_PATH_COMPUTE;
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

static int teardown(void *arg, struct gv_error *err)
{
    (void)err;
    struct gv_gpu_zfield *zf = ((struct call *)arg)->zf;
    const struct gv_gpu_objects objects[] = {
        {GV_GPU_PROGRAMS, &zf->sweep, 1}, {GV_GPU_PROGRAMS, &zf->pack, 1},
        {GV_GPU_BUFFERS, &zf->heights, 1}, {GV_GPU_BUFFERS, &zf->enabled, 1},
        {GV_GPU_BUFFERS, &zf->packed, 1}, {GV_GPU_TEXTURES, &zf->ztex, 1},
        {GV_GPU_TEXTURES, zf->state, 2}, {GV_GPU_TEXTURES, &zf->ptex, 1},
        {GV_GPU_FRAMEBUFFERS, zf->fbo, 3}, {GV_GPU_VERTEX_ARRAYS, &zf->vao, 1},
    };
    gv_gpu_delete_objects(objects, sizeof objects / sizeof objects[0]);
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
    if (zf->path == GV_GPU_PATH_COMPUTE) {
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
    return gv_gpu_gl_check(err, "zfield height upload");
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
        return gv_gpu_gl_fail(err, "zfield read-back");
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
    const int rc = c->zf->path == GV_GPU_PATH_COMPUTE ? run_compute(c, err)
                                                   : run_fragment(c, err);
    if (rc < 0)
        return rc;
    /* The corners are always enabled (the sweep never visits them). */
    const uint32_t n = c->zf->n;
    const size_t cells = (size_t)n * n;
    c->enabled[0] = c->enabled[n - 1] = 1;
    c->enabled[(size_t)(n - 1) * n] = c->enabled[cells - 1] = 1;
    return gv_gpu_gl_check(err, "zfield sweep");
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
