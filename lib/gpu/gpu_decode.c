/*
 * gpu_decode.c - the GPU tile decoder (gpu_decode.h).
 *
 * Two passes per tile, as section 7.5 describes: the parent quarter is
 * copied into mip 1, and the decode shader renders mip 0 from the parent
 * and the tile buffer.  Both draw one viewport-covering triangle into a
 * framebuffer bound to the target mip level.  On the compute path the tile
 * buffer is a shader storage buffer of 32-bit words, and an entropy-coded
 * tile's indices are first decoded by a compute pass (rans_decode); on the
 * WebGL2 path the buffer is an R32UI texture and the indices are decoded
 * on the CPU into an R16UI texture, as the browser does.  A transform-coded
 * tile (layout D, FORMAT.md 4.3) goes the same way with its coefficient
 * streams: decoded by a compute pass (dct_decode) into a coefficient buffer
 * bound where the indices would be, whose inverse transform's row pass a
 * second compute pass (dct_rows, one invocation per 8x8 block) takes in
 * place, the decode shader the column pass; or on the CPU (gv_dct_unpack)
 * into a 520x520 RGBA16I texture, of which the decode shader takes both
 * passes.  Both D shaders' matrix K is the one shaders/dct_matrix.glsl,
 * already in their embedded text (shaders/embed.sh expands the #include),
 * as in the browser's copy of the decode shader.
 *
 * A single tile is a batch of one.  A batch (gv_gpu_decode_batch) runs in
 * one call on the GL thread: on the compute path, in small groups of
 * tiles, each with its own tile and index buffer, whose rANS passes run
 * back to back before a single memory barrier, and then each tile's two
 * draws follow.  Only a group waits, for the one before the previous to
 * finish with the buffers it reuses.
 */
#include <stdlib.h>
#include <string.h>

#include <GLES3/gl31.h>

#include "store/geometry.h"
#include "gpu/gpu_decode.h"
#include "gpu/gpu_module_int.h"
#include "shaders.h"
#include "store/store_format.h"
#include "codec/tile.h"
#include "codec/tile_rans.h"
#include "codec/tile_dct.h"

#define WORDS_WIDTH 1024   /* texels per row of the WebGL2 words texture */

/* Tiles per group on the compute path: the group's tile buffers share one
 * storage buffer and their indices another (16 x 145 KiB and 16 x 258 KiB
 * at most per set).  On llvmpipe the group size changed nothing
 * measurable: the CPU work per tile was the same (0.95 to 1.01x) with
 * groups of 2 and 64 (decode_bench, Dragonfly store). */
#ifndef GV_GPU_GROUP
#define GV_GPU_GROUP 16
#endif
#define GROUP GV_GPU_GROUP

/* Released tile textures a decoder keeps for reuse (32: 45 MiB of GPU
 * memory at most; gpu_cache.c evicts and refills tiles in steady state).
 * On an H100 (bench/README.md) reusing every texture decoded 1.22 to 1.27x
 * the tiles per second of allocating each; the group size (16, 32, 64)
 * changed nothing there. */
#ifndef GV_GPU_SPARES
#define GV_GPU_SPARES 32
#endif
#define SPARE_MAX GV_GPU_SPARES

/* A layout-D coefficient plane on the compute path: 520x520 texels of two
 * uints (dct_decode.comp.glsl). */
#define COEF_BYTES ((size_t)GV_DCT_PLANE * GV_DCT_PLANE * 2 * sizeof(GLuint))

struct gv_gpu_decoder {
    struct gv_gpu *gpu;
    int channels;
    enum gv_gpu_path path;
    GLuint decode, quarter, rans, dct, dct_rows, fbo, vao;
    /* Two sets of storage buffers, a tile buffer and an index buffer per
     * tile of a group, used by alternate groups of tiles; a set is
     * refilled only once the fence after its last group's draws has
     * passed. */
    GLuint ssbo[2], indices[2], tiles[2];
    size_t index_stride;               /* bytes of a tile's indices, aligned */
    /* Layout D: per set, the coefficient planes of up to coef_cap[set]
     * tiles (grown on demand, 2 MiB each) and the dispatch's parameters. */
    GLuint coefs[2], dct_tiles[2];
    size_t coef_cap[2], coef_stride;
    GLsync fence[2];
    int set;
    GLint ssbo_align;                  /* offset alignment of ssbo ranges */
    uint8_t *staging;                  /* a group's tile buffers, packed */
    size_t staging_size;
    /* Released tile textures kept for reuse: allocating a 514x514 texture
     * with its mip costs the H100's driver a fifth of a tile's time. */
    GLuint *spare;
    size_t spares, spare_cap;          /* cap: SPARE_MAX or as reserved */
    GLuint words_tex, indices_tex, coefs_tex;   /* WebGL2 path */
    GLint dec_parent, dec_quadrant, dec_channels, q_parent, q_quadrant;
    GLint dec_words, dec_words_width, dec_indices, dec_coefs;
    uint16_t *cpu_indices;             /* WebGL2 path: rANS decoded here */
    int16_t *cpu_coefs;                /* WebGL2 path: layout D's plane */
    const char *defines;               /* prepended to the decode shader
                                        * (borrowed during set-up only) */
};

struct job {
    struct gv_gpu_decoder *d;
    const uint8_t *buf;
    size_t len;
    const uint8_t *pixels_in;
    uint8_t *pixels_out;
    uint32_t parent, handle;
    int qx, qy, mip;
};

static size_t align_up(size_t n, size_t a)
{
    return (n + a - 1) / a * a;
}

/* The decoder's programs: the quarter copy and the decode pass, and on
 * the compute path the rANS, layout-D stream and row passes.  The
 * decoder's #define lines (tests' changes to the rounding) go before the
 * decode shader and the row pass. */
static int build_programs(struct gv_gpu_decoder *d, struct gv_error *err)
{
    const struct gv_gpu_uniform dec_u[] = {
        {"u_parent", &d->dec_parent}, {"u_quadrant", &d->dec_quadrant},
        {"u_channels", &d->dec_channels}, {"u_words", &d->dec_words},
        {"u_words_width", &d->dec_words_width}, {"u_indices", &d->dec_indices},
        {"u_coefs", &d->dec_coefs}, {NULL, NULL},
    };
    const struct gv_gpu_uniform q_u[] = {
        {"u_parent", &d->q_parent}, {"u_quadrant", &d->q_quadrant}, {NULL, NULL},
    };
    const struct gv_gpu_program_def defs[] = {
        {&d->decode, {{GL_VERTEX_SHADER, {gv_shader_fullscreen_vert}},
                      {GL_FRAGMENT_SHADER, {d->defines, gv_shader_tile_decode_frag}}},
         dec_u},
        {&d->quarter, {{GL_VERTEX_SHADER, {gv_shader_fullscreen_vert}},
                       {GL_FRAGMENT_SHADER, {gv_shader_quarter_copy_frag}}},
         q_u},
        {&d->rans, {{GL_COMPUTE_SHADER, {gv_shader_rans_decode_comp}}}, NULL},
        {&d->dct, {{GL_COMPUTE_SHADER, {gv_shader_dct_decode_comp}}}, NULL},
        {&d->dct_rows, {{GL_COMPUTE_SHADER, {d->defines, gv_shader_dct_rows_comp}}},
         NULL},
    };
    const size_t n = d->path == GV_GPU_PATH_WEBGL2 ? 2 : sizeof defs / sizeof defs[0];
    return gv_gpu_build_programs(d->gpu, d->path, defs, n, err);
}

/* The WebGL2 path's inputs: the words, index and coefficient textures and
 * the CPU's buffers for the indices and the coefficients. */
static int setup_webgl2(struct gv_gpu_decoder *d, struct gv_error *err)
{
    glGenTextures(1, &d->words_tex);
    glGenTextures(1, &d->indices_tex);
    glBindTexture(GL_TEXTURE_2D, d->indices_tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_R16UI, GV_BLOCKS, GV_BLOCKS);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glGenTextures(1, &d->coefs_tex);
    glBindTexture(GL_TEXTURE_2D, d->coefs_tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA16I, GV_DCT_PLANE, GV_DCT_PLANE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    d->cpu_indices = malloc(GV_NBLOCKS * sizeof *d->cpu_indices);
    d->cpu_coefs = malloc((size_t)GV_DCT_PLANE * GV_DCT_PLANE * 4 *
                          sizeof *d->cpu_coefs);
    if (!d->cpu_indices || !d->cpu_coefs)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    return gv_gpu_gl_check(err, "decoder set-up");
}

/* The compute path's two sets of storage buffers. */
static int setup_compute(struct gv_gpu_decoder *d, struct gv_error *err)
{
    /* The index buffers exist even for a fixed-layout tile, whose decode
     * pass has one bound but never reads it. */
    glGetIntegerv(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &d->ssbo_align);
    if (d->ssbo_align < 4)
        d->ssbo_align = 4;
    d->index_stride = align_up(GV_NBLOCKS * sizeof(GLuint), (size_t)d->ssbo_align);
    d->coef_stride = align_up(COEF_BYTES, (size_t)d->ssbo_align);
    for (int k = 0; k < 2; k++) {
        glGenBuffers(1, &d->ssbo[k]);
        glGenBuffers(1, &d->tiles[k]);
        glGenBuffers(1, &d->dct_tiles[k]);
        glGenBuffers(1, &d->coefs[k]);
        glGenBuffers(1, &d->indices[k]);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, d->indices[k]);
        glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(GROUP * d->index_stride),
                     NULL, GL_DYNAMIC_COPY);
    }
    return gv_gpu_gl_check(err, "decoder set-up");
}

static int setup(void *arg, struct gv_error *err)
{
    struct gv_gpu_decoder *d = ((struct job *)arg)->d;
    if (build_programs(d, err) < 0)
        return -1;
    glGenFramebuffers(1, &d->fbo);
    glGenVertexArrays(1, &d->vao);
    return d->path == GV_GPU_PATH_WEBGL2 ? setup_webgl2(d, err)
                                         : setup_compute(d, err);
}

struct gv_gpu_decoder *gv_gpu_decoder_new(struct gv_gpu *g,
                                          const struct gv_gpu_decoder_opts *o,
                                          struct gv_error *err)
{
    struct gv_gpu_decoder *d = calloc(1, sizeof *d);
    if (!d) {
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    d->gpu = g;
    d->channels = o->channels;
    d->path = o->path;
    d->defines = o->defines ? o->defines : "";
    d->spare_cap = SPARE_MAX;
    d->spare = malloc(SPARE_MAX * sizeof *d->spare);
    if (!d->spare) {
        free(d);
        gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        return NULL;
    }
    struct job j = {.d = d};
    if (gv_gpu_call(g, setup, &j, err) < 0) {
        gv_gpu_decoder_free(d);
        return NULL;
    }
    return d;
}

static int teardown(void *arg, struct gv_error *err)
{
    (void)err;
    struct gv_gpu_decoder *d = ((struct job *)arg)->d;
    const struct gv_gpu_objects objects[] = {
        {GV_GPU_PROGRAMS, &d->decode, 1}, {GV_GPU_PROGRAMS, &d->quarter, 1},
        {GV_GPU_PROGRAMS, &d->rans, 1}, {GV_GPU_PROGRAMS, &d->dct, 1},
        {GV_GPU_PROGRAMS, &d->dct_rows, 1},
        {GV_GPU_BUFFERS, d->coefs, 2}, {GV_GPU_BUFFERS, d->dct_tiles, 2},
        {GV_GPU_BUFFERS, d->indices, 2}, {GV_GPU_BUFFERS, d->tiles, 2},
        {GV_GPU_BUFFERS, d->ssbo, 2},
        {GV_GPU_TEXTURES, &d->words_tex, 1}, {GV_GPU_TEXTURES, &d->indices_tex, 1},
        {GV_GPU_TEXTURES, &d->coefs_tex, 1}, {GV_GPU_TEXTURES, d->spare, d->spares},
        {GV_GPU_FRAMEBUFFERS, &d->fbo, 1}, {GV_GPU_VERTEX_ARRAYS, &d->vao, 1},
    };
    gv_gpu_delete_objects(objects, sizeof objects / sizeof objects[0]);
    d->spares = 0;
    for (int k = 0; k < 2; k++)
        if (d->fence[k])
            glDeleteSync(d->fence[k]);
    return 0;
}

void gv_gpu_decoder_free(struct gv_gpu_decoder *d)
{
    if (!d)
        return;
    struct job j = {.d = d};
    gv_gpu_call(d->gpu, teardown, &j, NULL);
    free(d->cpu_indices);
    free(d->cpu_coefs);
    free(d->staging);
    free(d->spare);
    free(d);
}

/* GL halves mip sizes rounding down, so a 513-texel level 0 would have a
 * 256-texel level 1; like the thesis (eq. 7.1) the texture is 514 wide so
 * that level 1 holds the 257 texels of the parent quarter.  Column and row
 * 513 of level 0 are never written or read. */
#define TEX_SIZE (GV_TILE + 1)

/* A tile texture: a released one when `reuse` and one is kept, else a new
 * one.  Only draws reuse: a CPU upload (glTexSubImage2D) into a texture
 * whose earlier rendering was still queued lost against that rendering on
 * llvmpipe (test_gpu_cache saw a re-uploaded root overwritten). */
static GLuint new_tile_texture_fresh(void)
{
    GLuint tex;
    glGenTextures(1, &tex);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 2, GL_RGBA8UI, TEX_SIZE, TEX_SIZE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST_MIPMAP_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 1);
    return tex;
}

static GLuint new_tile_texture(struct gv_gpu_decoder *d, int reuse)
{
    if (reuse && d->spares > 0)
        return d->spare[--d->spares];
    return new_tile_texture_fresh();
}

/* Expand C-channel rows to RGBA (gray replicated, alpha 255). */
static void to_rgba(const uint8_t *src, int channels, size_t n, uint8_t *dst)
{
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++)
            dst[4 * i + c] = src[i * channels + (channels == 3 ? c : 0)];
        dst[4 * i + 3] = 255;
    }
}

static int upload(void *arg, struct gv_error *err)
{
    struct job *j = arg;
    const size_t n = (size_t)GV_TILE * GV_TILE;
    uint8_t *rgba = malloc(n * 4);
    if (!rgba)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    to_rgba(j->pixels_in, j->d->channels, n, rgba);
    GLuint tex = new_tile_texture(j->d, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GV_TILE, GV_TILE, GL_RGBA_INTEGER,
                    GL_UNSIGNED_BYTE, rgba);
    /* Mip 1 of an uploaded (root) tile: its own 2x2 box reduction. */
    uint8_t *half = malloc((size_t)257 * 257 * 4);
    if (half) {
        gv_box_reduce(rgba, GV_TILE, GV_TILE, 4, half);
        glTexSubImage2D(GL_TEXTURE_2D, 1, 0, 0, 257, 257, GL_RGBA_INTEGER,
                        GL_UNSIGNED_BYTE, half);
    }
    free(half);
    free(rgba);
    j->handle = tex;
    return gv_gpu_gl_check(err, "tile upload");
}

int gv_gpu_upload_tile(struct gv_gpu_decoder *d, const uint8_t *pixels,
                       uint32_t *handle, struct gv_error *err)
{
    struct job j = {.d = d, .pixels_in = pixels};
    if (gv_gpu_call(d->gpu, upload, &j, err) < 0)
        return -1;
    *handle = j.handle;
    return 0;
}

static void draw_into(GLuint fbo, GLuint tex, int mip, int size)
{
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D,
                           tex, mip);
    glViewport(0, 0, size, size);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

/* WebGL2 path: the tile buffer as an R32UI texture (texture unit 1) and,
 * for an entropy-coded tile, its indices decoded here as R16UI (unit 2),
 * for a transform-coded one its coefficients as RGBA16I (unit 3). */
static int upload_webgl2(struct gv_gpu_decoder *d, const uint8_t *buf,
                         size_t len, struct gv_error *err)
{
    const size_t words = len / 4;
    const size_t rows = (words + WORDS_WIDTH - 1) / WORDS_WIDTH;
    uint32_t *padded = calloc(rows * WORDS_WIDTH, sizeof *padded);
    if (!padded)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    for (size_t i = 0; i < words; i++)
        padded[i] = gv_get32(buf + 4 * i);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, d->words_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R32UI, WORDS_WIDTH, (GLsizei)rows, 0,
                 GL_RED_INTEGER, GL_UNSIGNED_INT, padded);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    free(padded);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, d->indices_tex);
    if (buf[0] & GV_TILE_ENTROPY) {
        if (gv_rans_unpack(buf, len, buf[0] & 0x0f, d->channels, d->cpu_indices,
                           err) < 0)
            return -1;
        glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GV_BLOCKS, GV_BLOCKS,
                        GL_RED_INTEGER, GL_UNSIGNED_SHORT, d->cpu_indices);
    }
    glActiveTexture(GL_TEXTURE3);
    glBindTexture(GL_TEXTURE_2D, d->coefs_tex);
    if (gv_tile_is_dct(buf[0])) {
        if (gv_dct_unpack(buf, len, d->channels, d->cpu_coefs, err) < 0)
            return -1;
        glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GV_DCT_PLANE, GV_DCT_PLANE,
                        GL_RGBA_INTEGER, GL_SHORT, d->cpu_coefs);
    }
    return 0;
}

/* Pass 1 of a tile: the parent quarter into mip 1 of tex. */
static void draw_quarter(struct gv_gpu_decoder *d, GLuint tex, GLuint parent,
                         int qx, int qy)
{
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, parent);
    glUseProgram(d->quarter);
    glUniform1i(d->q_parent, 0);
    glUniform2i(d->q_quadrant, qx, qy);
    draw_into(d->fbo, tex, 1, 257);
}

/* Pass 2: prediction plus residual into mip 0, the decode program's
 * inputs bound (parent on unit 0). */
static void draw_decode(struct gv_gpu_decoder *d, GLuint tex, GLuint parent,
                        int qx, int qy)
{
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, parent);
    glUseProgram(d->decode);
    glUniform1i(d->dec_parent, 0);
    glUniform2i(d->dec_quadrant, qx, qy);
    glUniform1i(d->dec_channels, d->channels);
    draw_into(d->fbo, tex, 0, GV_TILE);
}

/* The parent texture of job i of the batch: a handle, or an earlier job's
 * texture (parent_job counts from the batch's first job). */
static GLuint parent_of(const struct gv_gpu_tile_job *jobs, size_t i)
{
    return jobs[i].parent_job >= 0 ? jobs[jobs[i].parent_job].handle
                                   : jobs[i].parent;
}

/* WebGL2 path: tile by tile (each buffer and index texture uploaded just
 * before its draw, as the browser does), still within one call. */
static int decode_webgl2(struct gv_gpu_decoder *d, struct gv_gpu_tile_job *jobs,
                         size_t n, struct gv_error *err)
{
    glBindVertexArray(d->vao);
    for (size_t i = 0; i < n; i++) {
        GLuint tex = new_tile_texture(d, 1), parent = parent_of(jobs, i);
        jobs[i].handle = tex;
        draw_quarter(d, tex, parent, jobs[i].qx, jobs[i].qy);
        if (upload_webgl2(d, jobs[i].buf, jobs[i].len, err) < 0)
            return -1;
        glUseProgram(d->decode);
        glUniform1i(d->dec_words, 1);
        glUniform1i(d->dec_words_width, WORDS_WIDTH);
        glUniform1i(d->dec_indices, 2);
        glUniform1i(d->dec_coefs, 3);
        draw_decode(d, tex, parent, jobs[i].qx, jobs[i].qy);
    }
    return 0;
}


/*
 * Compute path, a group of at most GROUP tiles: the tile buffers uploaded
 * together into the set's storage buffer, one rANS compute dispatch for
 * all entropy-coded tiles, one barrier, then the two draws of each tile
 * (a parent earlier in the batch is rendered before its children read
 * it).  Nothing waits for the GPU except for the set's previous group.
 */
/* One compute pass over a group's entropy-coded streams (rans_decode or
 * dct_decode): the per-tile parameters uploaded to `tiles`, the tile
 * buffers at binding 0, the output at 1, the parameters at 2. */
static void dispatch_streams(GLuint prog, GLuint words, GLuint out, GLuint tiles,
                             const void *params, size_t bytes, GLuint gx,
                             GLuint gy)
{
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, tiles);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)bytes, params,
                 GL_STREAM_DRAW);
    glUseProgram(prog);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, words);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, tiles);
    glDispatchCompute(gx, gy, 1);
}

/* Transform-coded tiles of a group (nd of its n, tile i at offset off[i]
 * of the set's storage buffer, in coefficient plane dslot[i] or -1):
 * every such tile's 65 coefficient streams in one dispatch, one
 * invocation per row of 8x8 blocks, then the inverse transform's row pass
 * in place. */
static void dispatch_dct(struct gv_gpu_decoder *d, int set,
                         const struct gv_gpu_tile_job *jobs, size_t n,
                         const size_t *off, const long *dslot, size_t nd)
{
    if (nd > d->coef_cap[set]) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, d->coefs[set]);
        glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(nd * d->coef_stride),
                     NULL, GL_DYNAMIC_COPY);
        d->coef_cap[set] = nd;
    }
    GLint params[GROUP][4];
    for (size_t i = 0; i < n; i++) {
        if (dslot[i] < 0)
            continue;
        params[dslot[i]][0] = (GLint)(off[i] / 4);
        params[dslot[i]][1] = (GLint)jobs[i].len;
        params[dslot[i]][2] = (GLint)((size_t)dslot[i] * d->coef_stride / sizeof(GLuint));
        params[dslot[i]][3] = d->channels;
    }
    dispatch_streams(d->dct, d->ssbo[set], d->coefs[set], d->dct_tiles[set],
                     params, (size_t)nd * sizeof params[0], 1, (GLuint)nd);
    /* The inverse transform's row pass, in place, once the planes are
     * written: one invocation per block (same buffers bound). */
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glUseProgram(d->dct_rows);
    glDispatchCompute((GV_DCT_BLOCKS * GV_DCT_BLOCKS + 63) / 64, (GLuint)nd, 1);
}

static int decode_group(struct gv_gpu_decoder *d, struct gv_gpu_tile_job *all,
                        size_t first, size_t n, struct gv_error *err)
{
    struct gv_gpu_tile_job *jobs = all + first;
    /* This group's set of buffers, once the GPU is done with its previous
     * group: shader storage is not ordered after earlier draws' reads
     * (llvmpipe, which runs compute passes at once but defers draws, showed
     * an earlier tile reading a later group's data). */
    const int set = d->set;
    d->set ^= 1;
    if (d->fence[set]) {
        while (glClientWaitSync(d->fence[set], GL_SYNC_FLUSH_COMMANDS_BIT,
                                1000000000) == GL_TIMEOUT_EXPIRED)
            ;
        glDeleteSync(d->fence[set]);
        d->fence[set] = 0;
    }
    /* The group's tile buffers packed into one storage buffer, each at an
     * aligned offset: one upload instead of one buffer per tile. */
    size_t off[GROUP], total = 0;
    for (size_t i = 0; i < n; i++) {
        off[i] = total;
        total = align_up(total + jobs[i].len, (size_t)d->ssbo_align);
    }
    if (total > d->staging_size) {
        uint8_t *p = realloc(d->staging, total);
        if (!p)
            return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        d->staging = p;
        d->staging_size = total;
    }
    int entropy = 0, inner = 0;
    long dslot[GROUP];                 /* layout D: the tile's coefficient plane */
    size_t nd = 0;
    for (size_t i = 0; i < n; i++) {
        memcpy(d->staging + off[i], jobs[i].buf, jobs[i].len);
        entropy |= (jobs[i].buf[0] & GV_TILE_ENTROPY) != 0;
        inner |= jobs[i].parent_job >= (long)first;
        dslot[i] = gv_tile_is_dct(jobs[i].buf[0]) ? (long)nd++ : -1;
    }
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, d->ssbo[set]);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)total, d->staging,
                 GL_STREAM_DRAW);
    /* A tile's buffer and its indices (or coefficients), for the decode
     * pass. */
#define BIND_TILE(i)                                                         \
    do {                                                                     \
        glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 0, d->ssbo[set],         \
                          (GLintptr)off[i],                                  \
                          (GLsizeiptr)align_up(jobs[i].len, 4));             \
        if (dslot[i] >= 0)                                                   \
            glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, d->coefs[set],    \
                              (GLintptr)((size_t)dslot[i] * d->coef_stride), \
                              (GLsizeiptr)COEF_BYTES);                       \
        else                                                                 \
            glBindBufferRange(GL_SHADER_STORAGE_BUFFER, 1, d->indices[set],  \
                              (GLintptr)((i) * d->index_stride),             \
                              (GLsizeiptr)(GV_NBLOCKS * sizeof(GLuint)));     \
    } while (0)
    /* Entropy-coded indices: every such tile of the group in one dispatch,
     * one invocation per row of blocks, one row of work groups per tile. */
    if (entropy) {
        GLint params[GROUP][4];
        GLuint m = 0;
        for (size_t i = 0; i < n; i++) {
            if (!(jobs[i].buf[0] & GV_TILE_ENTROPY))
                continue;
            params[m][0] = (GLint)(off[i] / 4);
            params[m][1] = jobs[i].buf[0] & 0x0f;
            params[m][2] = (GLint)gv_rans_tables_at(jobs[i].buf, d->channels);
            params[m][3] = (GLint)(i * d->index_stride / sizeof(GLuint));
            m++;
        }
        dispatch_streams(d->rans, d->ssbo[set], d->indices[set], d->tiles[set],
                         params, m * sizeof params[0], (GV_BLOCKS + 63) / 64,
                         (GLuint)m);
    }
    if (nd > 0)
        dispatch_dct(d, set, jobs, n, off, dslot, nd);
    if (entropy || nd > 0)
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glBindVertexArray(d->vao);
    for (size_t i = 0; i < n; i++)
        jobs[i].handle = new_tile_texture(d, 1);
    /* With no parent inside the group, every quarter pass first and then
     * every decode pass: two program switches per group, not per tile.
     * Otherwise tile by tile, a parent rendered before its children. */
    for (size_t i = 0; i < n; i++) {
        const GLuint tex = jobs[i].handle, parent = parent_of(all, first + i);
        draw_quarter(d, tex, parent, jobs[i].qx, jobs[i].qy);
        if (inner) {
            BIND_TILE(i);
            draw_decode(d, tex, parent, jobs[i].qx, jobs[i].qy);
        }
    }
    for (size_t i = 0; i < n && !inner; i++) {
        BIND_TILE(i);
        draw_decode(d, jobs[i].handle, parent_of(all, first + i), jobs[i].qx,
                    jobs[i].qy);
    }
#undef BIND_TILE
    d->fence[set] = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    return 0;
}

struct batch {
    struct gv_gpu_decoder *d;
    struct gv_gpu_tile_job *jobs;
    size_t n;
};

static int decode_batch(void *arg, struct gv_error *err)
{
    struct batch *b = arg;
    struct gv_gpu_decoder *d = b->d;
    for (size_t i = 0; i < b->n; i++)
        b->jobs[i].handle = 0;
    int rc = 0;
    if (d->path == GV_GPU_PATH_WEBGL2)
        rc = decode_webgl2(d, b->jobs, b->n, err);
    else
        for (size_t i = 0; i < b->n && rc == 0; i += GROUP)
            rc = decode_group(d, b->jobs, i, b->n - i < GROUP ? b->n - i : GROUP, err);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glActiveTexture(GL_TEXTURE0);
    if (rc == 0)
        rc = gv_gpu_gl_check(err, "tile decode");
    if (rc < 0)
        for (size_t i = 0; i < b->n; i++)
            if (b->jobs[i].handle) {
                GLuint tex = b->jobs[i].handle;
                glDeleteTextures(1, &tex);
                b->jobs[i].handle = 0;
            }
    return rc;
}

int gv_gpu_decode_batch(struct gv_gpu_decoder *d, struct gv_gpu_tile_job *jobs,
                        size_t n, struct gv_error *err)
{
    for (size_t i = 0; i < n; i++) {
        if (jobs[i].parent_job >= (long)i)
            return gv_fail(err, GV_EINVAL, "gpu: job %zu's parent is not an "
                           "earlier job", i);
        if (gv_tilebuf_check(jobs[i].buf, jobs[i].len, d->channels, err) < 0)
            return -1;
    }
    if (n == 0)
        return 0;
    struct batch b = {.d = d, .jobs = jobs, .n = n};
    return gv_gpu_call(d->gpu, decode_batch, &b, err);
}

int gv_gpu_decode_tile(struct gv_gpu_decoder *d, const uint8_t *buf,
                       size_t len, uint32_t parent, int qx, int qy,
                       uint32_t *handle, struct gv_error *err)
{
    struct gv_gpu_tile_job j = {.buf = buf, .len = len, .parent = parent,
                                .parent_job = -1, .qx = qx, .qy = qy};
    if (gv_gpu_decode_batch(d, &j, 1, err) < 0)
        return -1;
    *handle = j.handle;
    return 0;
}

static int readback(void *arg, struct gv_error *err)
{
    struct job *j = arg;
    const int size = j->mip ? 257 : GV_TILE;
    const size_t n = (size_t)size * size;
    GLuint *px = malloc(n * 4 * sizeof *px);
    if (!px)
        return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
    glBindFramebuffer(GL_FRAMEBUFFER, j->d->fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D,
                           j->handle, j->mip);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    /* RGBA_INTEGER + UNSIGNED_INT is the combination ES 3.0 guarantees for
     * unsigned integer colour buffers. */
    glReadPixels(0, 0, size, size, GL_RGBA_INTEGER, GL_UNSIGNED_INT, px);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    const int c = j->d->channels;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < c; k++)
            j->pixels_out[i * c + k] = (uint8_t)px[4 * i + k];
    free(px);
    return gv_gpu_gl_check(err, "tile read-back");
}

int gv_gpu_read_tile(struct gv_gpu_decoder *d, uint32_t handle, int mip,
                     uint8_t *pixels, struct gv_error *err)
{
    struct job j = {.d = d, .handle = handle, .mip = mip, .pixels_out = pixels};
    return gv_gpu_call(d->gpu, readback, &j, err);
}

static int release(void *arg, struct gv_error *err)
{
    (void)err;
    struct job *j = arg;
    GLuint tex = j->handle;
    if (j->d->spares < j->d->spare_cap)
        j->d->spare[j->d->spares++] = tex;
    else
        glDeleteTextures(1, &tex);
    return 0;
}

static int reserve(void *arg, struct gv_error *err)
{
    struct job *j = arg;
    struct gv_gpu_decoder *d = j->d;
    const size_t want = j->handle;
    if (want > d->spare_cap) {
        GLuint *p = realloc(d->spare, want * sizeof *p);
        if (!p)
            return gv_fail(err, GV_ENOMEM, "gpu: out of memory");
        d->spare = p;
        d->spare_cap = want;
    }
    while (d->spares < want)
        d->spare[d->spares++] = new_tile_texture_fresh();
    return gv_gpu_gl_check(err, "texture reserve");
}

int gv_gpu_reserve(struct gv_gpu_decoder *d, size_t tiles, struct gv_error *err)
{
    if (tiles > UINT32_MAX)
        return gv_fail(err, GV_ELIMIT, "gpu: cannot reserve %zu tiles", tiles);
    struct job j = {.d = d, .handle = (uint32_t)tiles};
    return gv_gpu_call(d->gpu, reserve, &j, err);
}

void gv_gpu_release(struct gv_gpu_decoder *d, uint32_t handle)
{
    struct job j = {.d = d, .handle = handle};
    gv_gpu_call(d->gpu, release, &j, NULL);
}
