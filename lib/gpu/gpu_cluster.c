/*
 * gpu_cluster.c - vertex-clustering selection on the GPU (gpu_cluster.h):
 * storage buffers for the tree, the leaves and the triangles, the
 * shaders/cluster_select.comp.glsl program, two dispatches per level and
 * a read-back of the clusters, the kept-triangle flags and the selected
 * positions.  Every GL call runs on the context's thread (gv_gpu_call).
 */
#include "gpu/gpu_cluster.h"

#include <stdlib.h>
#include <string.h>

#include <GLES3/gl31.h>

#include "shaders.h"

enum { B_TREE, B_LEAF, B_FACES, B_CLUSTER, B_SELECTED, B_KEEP, NBUF };

struct gv_gpu_cluster {
    struct gv_gpu *gpu;
    const struct gv_cluster_tree *t;
    GLuint prog, buf[NBUF];
    GLint u_T, u_count, u_nnodes, u_pass;
};

struct call {
    struct gv_gpu_cluster *c;
    uint32_t T;
    uint32_t *cluster;
    uint8_t *keep;
    float *vpos;
};

/* Buffer b with `bytes` of data (NULL: uninitialized); an empty buffer
 * gets 16 bytes that nothing reads, never a copy from data. */
static int upload(GLuint b, size_t bytes, const void *data)
{
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, b);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(bytes ? bytes : 16),
                 bytes ? data : NULL, data ? GL_STATIC_DRAW : GL_DYNAMIC_READ);
    return glGetError() == GL_NO_ERROR ? 0 : -1;
}

static int do_new(void *arg, struct gv_error *err)
{
    struct gv_gpu_cluster *c = arg;
    const struct gv_cluster_tree *t = c->t;
    const struct gv_mesh *m = t->mesh;
    if (!gv_gpu_info(c->gpu)->ssbo)
        return gv_fail(err, GV_EUNAVAIL, "cluster: the GPU context has no "
                       "storage buffers");
    GLint64 maxblock = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxblock);
    size_t sizes[NBUF] = {
        32 * (size_t)t->nnodes, 16 * (size_t)m->nverts, 12 * (size_t)m->ntris,
        4 * (size_t)m->nverts, 16 * (size_t)m->nverts, 4 * (size_t)m->ntris,
    };
    for (int i = 0; i < NBUF; i++)
        if ((GLint64)sizes[i] > maxblock)
            return gv_fail(err, GV_ELIMIT, "cluster: a buffer of %zu bytes "
                           "exceeds the GPU's storage block size (%lld)",
                           sizes[i], (long long)maxblock);
    char *listing = NULL;
    c->prog = gv_gpu_compute_program(c->gpu, gv_shader_cluster_select_comp,
                                     &listing, err);
    free(listing);
    if (!c->prog)
        return -1;
    c->u_T = glGetUniformLocation(c->prog, "u_T");
    c->u_count = glGetUniformLocation(c->prog, "u_count");
    c->u_nnodes = glGetUniformLocation(c->prog, "u_nnodes");
    c->u_pass = glGetUniformLocation(c->prog, "u_pass");
    uint32_t *tree = malloc(sizes[B_TREE] ? sizes[B_TREE] : 1);
    uint32_t *leaf = malloc(sizes[B_LEAF] ? sizes[B_LEAF] : 1);
    if (!tree || !leaf) {
        free(tree);
        free(leaf);
        return gv_fail(err, GV_ENOMEM, "cluster: out of memory");
    }
    for (size_t i = 0; i < t->nnodes; i++) {
        memcpy(tree + 8 * i, t->rep + 4 * i, 16);
        tree[8 * i + 4] = t->parent[i];
        tree[8 * i + 5] = t->rank[i];
        tree[8 * i + 6] = tree[8 * i + 7] = 0;
    }
    for (size_t v = 0; v < m->nverts; v++) {
        memcpy(leaf + 4 * v, m->pos + 3 * v, 12);
        leaf[4 * v + 3] = t->leaf_parent[v];
    }
    glGenBuffers(NBUF, c->buf);
    const void *data[NBUF] = {tree, leaf, m->tris, NULL, NULL, NULL};
    int rc = 0;
    for (int i = 0; i < NBUF && rc == 0; i++)
        if (upload(c->buf[i], sizes[i], data[i]) < 0)
            rc = gv_fail(err, GV_ENOMEM, "cluster: GPU buffer of %zu bytes "
                         "refused", sizes[i]);
    free(tree);
    free(leaf);
    return rc;
}

static void dispatch(uint32_t n)
{
    uint32_t groups = (n + 63) / 64, gx = groups, gy = 1;
    if (gx > 65535) {
        gx = 65535;
        gy = (groups + gx - 1) / gx;
    }
    if (groups)
        glDispatchCompute(gx, gy, 1);
}

static int read_back(GLuint b, size_t bytes, void *dst, struct gv_error *err)
{
    if (!bytes)
        return 0;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, b);
    void *p = glMapBufferRange(GL_SHADER_STORAGE_BUFFER, 0, (GLsizeiptr)bytes,
                               GL_MAP_READ_BIT);
    if (!p)
        return gv_fail(err, GV_EIO, "cluster: cannot map a GPU buffer "
                       "(GL error 0x%x)", glGetError());
    memcpy(dst, p, bytes);
    glUnmapBuffer(GL_SHADER_STORAGE_BUFFER);
    return 0;
}

static int do_select(void *arg, struct gv_error *err)
{
    struct call *a = arg;
    struct gv_gpu_cluster *c = a->c;
    const struct gv_mesh *m = c->t->mesh;
    glUseProgram(c->prog);
    for (int i = 0; i < NBUF; i++)
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, (GLuint)i, c->buf[i]);
    glUniform1ui(c->u_T, a->T);
    glUniform1ui(c->u_nnodes, c->t->nnodes);
    glUniform1i(c->u_pass, 0);
    glUniform1ui(c->u_count, m->nverts);
    dispatch(m->nverts);   /* Kanaya 2.5 pass 2 */
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    glUniform1i(c->u_pass, 1);
    glUniform1ui(c->u_count, m->ntris);
    dispatch(m->ntris);    /* pass 3 */
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT |
                    GL_SHADER_STORAGE_BARRIER_BIT);
    int rc = 0;
    uint32_t *keep32 = malloc(m->ntris ? 4 * (size_t)m->ntris : 1);
    if (!keep32)
        return gv_fail(err, GV_ENOMEM, "cluster: out of memory");
    if (read_back(c->buf[B_CLUSTER], 4 * (size_t)m->nverts, a->cluster,
                  err) < 0 ||
        read_back(c->buf[B_SELECTED], 16 * (size_t)m->nverts, a->vpos,
                  err) < 0 ||
        read_back(c->buf[B_KEEP], 4 * (size_t)m->ntris, keep32, err) < 0)
        rc = -1;
    for (size_t f = 0; rc == 0 && f < m->ntris; f++)
        a->keep[f] = (uint8_t)(keep32[f] != 0);
    free(keep32);
    GLenum e = glGetError();
    if (rc == 0 && e != GL_NO_ERROR)
        rc = gv_fail(err, GV_EIO, "cluster: GL error 0x%x", e);
    return rc;
}

static int do_free(void *arg, struct gv_error *err)
{
    (void)err;
    struct gv_gpu_cluster *c = arg;
    if (c->buf[0])
        glDeleteBuffers(NBUF, c->buf);
    if (c->prog)
        glDeleteProgram(c->prog);
    return 0;
}

struct gv_gpu_cluster *gv_gpu_cluster_new(struct gv_gpu *g,
                                          const struct gv_cluster_tree *t,
                                          struct gv_error *err)
{
    struct gv_gpu_cluster *c = calloc(1, sizeof *c);
    if (!c) {
        gv_fail(err, GV_ENOMEM, "cluster: out of memory");
        return NULL;
    }
    c->gpu = g;
    c->t = t;
    if (gv_gpu_call(g, do_new, c, err) < 0) {
        gv_gpu_cluster_free(c);
        return NULL;
    }
    return c;
}

int gv_gpu_cluster_select(struct gv_gpu_cluster *c, uint32_t T,
                          uint32_t *cluster, uint8_t *keep, float *vpos,
                          struct gv_error *err)
{
    struct call a = {c, T, cluster, keep, vpos};
    return gv_gpu_call(c->gpu, do_select, &a, err);
}

void gv_gpu_cluster_free(struct gv_gpu_cluster *c)
{
    if (!c)
        return;
    struct gv_error e = {0};
    gv_gpu_call(c->gpu, do_free, c, &e);
    free(c);
}

int gv_gpu_cluster_run(void *ctx, const struct gv_cluster_tree *t, uint32_t T,
                       uint32_t *cluster, uint8_t *keep, float *vpos,
                       struct gv_error *err)
{
    struct gv_gpu_cluster *c = gv_gpu_cluster_new(ctx, t, err);
    if (!c)
        return -1;
    int rc = gv_gpu_cluster_select(c, T, cluster, keep, vpos, err);
    gv_gpu_cluster_free(c);
    return rc;
}
