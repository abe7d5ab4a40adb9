/*
 * gpu_height.c - the GPU decoder of codes (see gpu_height.h).
 *
 * A tile is a 513x513xC R16UI array texture (shaders/height_decode.frag.glsl
 * with GV_LAYERED, as the browser compiles it), each layer decoded from the
 * same layer of its parent, a channel at a time.  One tile per call, or
 * a batch of them in one call to the GL thread (the image decoder's job
 * shape).  On the compute path the storage buffers are reused from layer
 * to layer and tile to tile, so each layer waits for a fence after its
 * draw: shader storage is not ordered after earlier draws' reads (the
 * image decoder, gpu_decode.c, found llvmpipe deferring draws past a
 * later compute pass).
 */
#include <stdlib.h>

#include <GLES3/gl31.h>

#include "base/byteorder.h"
#include "codec/height_tile.h"
#include "codec/samples_tile.h"
#include "gpu/gpu_height.h"
#include "gpu/gpu_module_int.h"
#include "shaders.h"

struct gv_gpu_height {
    struct gv_gpu *gpu;
    enum gv_gpu_path path;
    int channels;                      /* layers of a tile */
    GLuint decode, rans, fbo, vao, words, qbuf, qtex;
    GLint u_parent, u_quadrant, u_e, u_coded, u_q, u_layer;
    int32_t *cpu_q;                    /* WebGL2 path */
};

struct job {
    struct gv_gpu_height *h;
    const uint8_t *part[GV_SAMPLES_MAX_CHANNELS];   /* a buffer a channel */
    size_t part_len[GV_SAMPLES_MAX_CHANNELS];
    const uint16_t *codes_in;
    uint16_t *codes_out;
    uint32_t parent, handle;
    int qx, qy;
};

static int setup(void *arg, struct gv_error *err)
{
    struct gv_gpu_height *h = ((struct job *)arg)->h;
    const struct gv_gpu_uniform decode_u[] = {
        {"u_parent", &h->u_parent}, {"u_quadrant", &h->u_quadrant},
        {"u_e", &h->u_e}, {"u_coded", &h->u_coded}, {"u_q", &h->u_q},
        {"u_layer", &h->u_layer}, {NULL, NULL},
    };
    const struct gv_gpu_program_def defs[] = {
        {&h->decode, {{GL_VERTEX_SHADER, {gv_shader_fullscreen_vert}},
                      {GL_FRAGMENT_SHADER, {"#define GV_LAYERED 1\n",
                                            gv_shader_height_decode_frag}}},
         decode_u},
        {&h->rans, {{GL_COMPUTE_SHADER, {gv_shader_height_rans_comp}}}, NULL},
    };
    const int webgl2 = h->path == GV_GPU_PATH_WEBGL2;
    if (gv_gpu_build_programs(h->gpu, h->path, defs, webgl2 ? 1 : 2, err) < 0)
        return -1;
    glGenFramebuffers(1, &h->fbo);
    glGenVertexArrays(1, &h->vao);
    if (webgl2) {
        glGenTextures(1, &h->qtex);
        glBindTexture(GL_TEXTURE_2D, h->qtex);
        glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32I, GV_HT_SIDE, GV_HT_SIDE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        h->cpu_q = malloc(sizeof *h->cpu_q * GV_HT_SAMPLES);
        if (!h->cpu_q)
            return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    } else {
        glGenBuffers(1, &h->words);
        glGenBuffers(1, &h->qbuf);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, h->qbuf);
        glBufferData(GL_SHADER_STORAGE_BUFFER, GV_HT_SAMPLES * sizeof(GLint), NULL,
                     GL_DYNAMIC_COPY);
    }
    return gv_gpu_gl_check(err, "height decoder set-up");
}

struct gv_gpu_height *gv_gpu_height_new(struct gv_gpu *g,
                                        const struct gv_gpu_height_opts *o,
                                        struct gv_error *err)
{
    const enum gv_gpu_path path = o ? o->path : GV_GPU_PATH_COMPUTE;
    const int channels = o && o->channels ? o->channels : 1;
    if (channels < 1 || channels > GV_SAMPLES_MAX_CHANNELS) {
        gv_fail(err, GV_EINVAL, "gpu: %d channels of codes (1 to %d)", channels,
                GV_SAMPLES_MAX_CHANNELS);
        return NULL;
    }
    struct gv_gpu_height *h = calloc(1, sizeof *h);
    if (!h) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    h->gpu = g;
    h->path = path;
    h->channels = channels;
    if (path == GV_GPU_PATH_WEBGL2 && !gv_gpu_info(g)->es) {
        gv_fail(err, GV_EFORMAT, "gpu: the WebGL2 path needs OpenGL ES");
        free(h);
        return NULL;
    }
    struct job j = {.h = h};
    if (gv_gpu_call(g, setup, &j, err) < 0) {
        gv_gpu_height_free(h);
        return NULL;
    }
    return h;
}

static int teardown(void *arg, struct gv_error *err)
{
    (void)err;
    struct gv_gpu_height *h = ((struct job *)arg)->h;
    const struct gv_gpu_objects objects[] = {
        {GV_GPU_PROGRAMS, &h->decode, 1}, {GV_GPU_PROGRAMS, &h->rans, 1},
        {GV_GPU_BUFFERS, &h->words, 1}, {GV_GPU_BUFFERS, &h->qbuf, 1},
        {GV_GPU_TEXTURES, &h->qtex, 1}, {GV_GPU_FRAMEBUFFERS, &h->fbo, 1},
        {GV_GPU_VERTEX_ARRAYS, &h->vao, 1},
    };
    gv_gpu_delete_objects(objects, sizeof objects / sizeof objects[0]);
    return 0;
}

void gv_gpu_height_free(struct gv_gpu_height *h)
{
    if (!h)
        return;
    struct job j = {.h = h};
    gv_gpu_call(h->gpu, teardown, &j, NULL);
    free(h->cpu_q);
    free(h);
}

/* A new tile texture of h->channels layers, bound on the active unit. */
static GLuint new_texture(const struct gv_gpu_height *h)
{
    GLuint tex;
    glGenTextures(1, &tex);
    glBindTexture(GL_TEXTURE_2D_ARRAY, tex);
    glTexStorage3D(GL_TEXTURE_2D_ARRAY, 1, GL_R16UI, GV_HT_SIDE, GV_HT_SIDE,
                   h->channels);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return tex;
}

static int upload(void *arg, struct gv_error *err)
{
    struct job *j = arg;
    const int c = j->h->channels;
    uint16_t *plane = malloc(sizeof *plane * GV_HT_SAMPLES);
    if (!plane)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    GLuint tex = new_texture(j->h);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
    for (int k = 0; k < c; k++) {
        for (size_t i = 0; i < GV_HT_SAMPLES; i++)
            plane[i] = j->codes_in[i * (size_t)c + (size_t)k];
        glTexSubImage3D(GL_TEXTURE_2D_ARRAY, 0, 0, 0, k, GV_HT_SIDE, GV_HT_SIDE, 1,
                        GL_RED_INTEGER, GL_UNSIGNED_SHORT, plane);
    }
    free(plane);
    j->handle = tex;
    return gv_gpu_gl_check(err, "height tile upload");
}

int gv_gpu_height_upload(struct gv_gpu_height *h, const uint16_t *codes,
                         uint32_t *handle, struct gv_error *err)
{
    struct job j = {.h = h, .codes_in = codes};
    if (gv_gpu_call(h->gpu, upload, &j, err) < 0)
        return -1;
    *handle = j.handle;
    return 0;
}

/* Channel k of job j's tile into layer k of texture tex (bound to the
 * framebuffer here), from layer k of the parent. */
static int decode_layer(struct job *j, GLuint tex, int k, struct gv_error *err)
{
    struct gv_gpu_height *h = j->h;
    const uint8_t *buf = j->part[k];
    const size_t len = j->part_len[k];
    const int coded = buf[0] == 1;
    if (coded && h->path == GV_GPU_PATH_WEBGL2) {
        int e;
        if (gv_height_tile_residuals(buf, len, h->cpu_q, &e, err) < 0)
            return -1;
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, h->qtex);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GV_HT_SIDE, GV_HT_SIDE,
                        GL_RED_INTEGER, GL_INT, h->cpu_q);
    } else if (coded) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, h->words);
        glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)len, buf, GL_STREAM_DRAW);
        glUseProgram(h->rans);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, h->words);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, h->qbuf);
        glDispatchCompute((GV_HT_STREAMS + 63) / 64, 1, 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }

    glBindVertexArray(h->vao);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, j->parent);
    glUseProgram(h->decode);
    glUniform1i(h->u_parent, 0);
    glUniform1i(h->u_layer, k);
    glUniform2i(h->u_quadrant, j->qx, j->qy);
    glUniform1i(h->u_e, gv_get16(buf + 2));
    glUniform1i(h->u_coded, coded);
    if (h->path == GV_GPU_PATH_WEBGL2)
        glUniform1i(h->u_q, 1);
    else
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, h->qbuf);
    glBindFramebuffer(GL_FRAMEBUFFER, h->fbo);
    glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, tex, 0, k);
    glViewport(0, 0, GV_HT_SIDE, GV_HT_SIDE);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    /* The next channel or tile reuses the buffers: wait for this draw. */
    GLsync fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    while (glClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, 1000000000) ==
           GL_TIMEOUT_EXPIRED)
        ;
    glDeleteSync(fence);
    return 0;
}

/* Decode job j into a new texture, j->handle.  GL thread. */
static int decode_one(struct job *j, struct gv_error *err)
{
    /* The target first: new_texture binds it on the active unit. */
    glActiveTexture(GL_TEXTURE0);
    GLuint tex = new_texture(j->h);
    for (int k = 0; k < j->h->channels; k++)
        if (decode_layer(j, tex, k, err) < 0) {
            glDeleteTextures(1, &tex);
            return -1;
        }
    j->handle = tex;
    return 0;
}

struct batch {
    struct job *jobs;             /* split and checked, parents unresolved */
    struct gv_gpu_tile_job *out;
    size_t n;
};

static int decode_many(void *arg, struct gv_error *err)
{
    struct batch *b = arg;
    size_t done = 0;
    int rc = 0;
    for (; done < b->n && rc == 0; done++) {
        struct job *j = &b->jobs[done];
        if (b->out[done].parent_job >= 0)
            j->parent = b->jobs[b->out[done].parent_job].handle;
        rc = decode_one(j, err);
    }
    if (rc == 0)
        rc = gv_gpu_gl_check(err, "height tile batch");
    if (rc < 0)   /* no texture made: those done go */
        for (size_t i = 0; i < done; i++)
            if (b->jobs[i].handle)
                glDeleteTextures(1, &b->jobs[i].handle);
    return rc;
}

int gv_gpu_height_decode_batch(struct gv_gpu_height *h, struct gv_gpu_tile_job *jobs,
                               size_t n, struct gv_error *err)
{
    struct job *j = n ? calloc(n, sizeof *j) : NULL;
    if (n && !j)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        if (jobs[i].parent_job >= (long)i)
            rc = gv_fail(err, GV_EINVAL, "gpu: batch job %zu names job %ld as its "
                         "parent (not an earlier one)", i, jobs[i].parent_job);
        else if (gv_samples_tile_check(jobs[i].buf, jobs[i].len, h->channels, err) < 0 ||
                 gv_samples_tile_split(jobs[i].buf, jobs[i].len, h->channels, j[i].part,
                                       j[i].part_len, err) < 0)
            rc = -1;
        j[i].h = h;
        j[i].parent = jobs[i].parent;
        j[i].qx = jobs[i].qx;
        j[i].qy = jobs[i].qy;
    }
    struct batch b = {j, jobs, n};
    if (rc == 0 && n)
        rc = gv_gpu_call(h->gpu, decode_many, &b, err);
    for (size_t i = 0; i < n && rc == 0; i++)
        jobs[i].handle = j[i].handle;
    free(j);
    return rc;
}

int gv_gpu_height_decode(struct gv_gpu_height *h, const uint8_t *buf,
                         size_t len, uint32_t parent, int qx, int qy,
                         uint32_t *handle, struct gv_error *err)
{
    struct gv_gpu_tile_job job = {.buf = buf, .len = len, .parent = parent,
                                  .parent_job = -1, .qx = qx, .qy = qy};
    if (gv_gpu_height_decode_batch(h, &job, 1, err) < 0)
        return -1;
    *handle = job.handle;
    return 0;
}

static int readback(void *arg, struct gv_error *err)
{
    struct job *j = arg;
    const int c = j->h->channels;
    GLuint *rgba = malloc(sizeof *rgba * 4 * GV_HT_SAMPLES);
    if (!rgba)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    glBindFramebuffer(GL_FRAMEBUFFER, j->h->fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    for (int k = 0; k < c; k++) {
        glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, j->handle, 0, k);
        glReadPixels(0, 0, GV_HT_SIDE, GV_HT_SIDE, GL_RGBA_INTEGER, GL_UNSIGNED_INT, rgba);
        for (size_t i = 0; i < GV_HT_SAMPLES; i++)
            j->codes_out[i * (size_t)c + (size_t)k] = (uint16_t)rgba[4 * i];
    }
    free(rgba);
    return gv_gpu_gl_check(err, "height tile read-back");
}

int gv_gpu_height_read(struct gv_gpu_height *h, uint32_t handle,
                       uint16_t *codes, struct gv_error *err)
{
    struct job j = {.h = h, .handle = handle, .codes_out = codes};
    return gv_gpu_call(h->gpu, readback, &j, err);
}

static int release(void *arg, struct gv_error *err)
{
    (void)err;
    GLuint tex = ((struct job *)arg)->handle;
    glDeleteTextures(1, &tex);
    return 0;
}

void gv_gpu_height_release(struct gv_gpu_height *h, uint32_t handle)
{
    struct job j = {.h = h, .handle = handle};
    gv_gpu_call(h->gpu, release, &j, NULL);
}
