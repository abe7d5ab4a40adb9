/*
 * cluster_run.h - one simplification from file bytes to file bytes (read,
 * build, choose the level, select, collect, write), shared by `gigaview
 * simplify` and POST /v1/meshes/simplify.  The selection runs on the CPU,
 * or through a callback (lib/gpu/gpu_cluster.c's gv_gpu_cluster_run),
 * since lib/mesh does not depend on lib/gpu.
 */
#ifndef GV_MESH_CLUSTER_RUN_H
#define GV_MESH_CLUSTER_RUN_H

#include "mesh/cluster.h"
#include "mesh/io/mesh_read.h"
#include "mesh/io/mesh_write.h"

typedef int gv_cluster_select_fn(void *ctx, const struct gv_cluster_tree *t,
                                 uint32_t T, uint32_t *cluster, uint8_t *keep,
                                 float *vpos, struct gv_error *err);

struct gv_simplify_opts {
    uint64_t faces;            /* the request, or 0 to use ratio */
    double ratio;              /* of the input's triangles, in [0, 1] */
    enum gv_cluster_mode mode;
    enum gv_mesh_format format;
    struct gv_mesh_limits lim; /* on the input */
    uint32_t max_faces;        /* refuse a request above this (0: none) */
    double time_limit;         /* seconds for the build (0: none) */
    gv_cluster_select_fn *select;   /* NULL: the CPU reference */
    void *select_ctx;
};

struct gv_simplify_stats {
    uint32_t in_verts, in_tris, out_verts, out_tris;
    uint64_t asked;            /* the face count asked for */
    uint32_t level, nnodes;    /* T and the number of internal nodes */
    double read_ms, build_ms, select_ms, write_ms;
};

/*
 * Simplify the mesh file in[0 .. len-1] (PLY, OBJ or GLB, sniffed) to
 * opts->faces (or ratio) triangles and write it as opts->format into *out
 * (malloc'ed).  Returns 0, or -1 with *err: the reader's codes, GV_EINVAL
 * for a bad request, GV_ELIMIT for faces over max_faces, GV_ETIMEOUT,
 * GV_ENOMEM, the callback's.  Thread-safe.
 */
int gv_simplify(const uint8_t *in, size_t len,
                const struct gv_simplify_opts *opts, uint8_t **out,
                size_t *out_len, struct gv_simplify_stats *st,
                struct gv_error *err);

#endif
