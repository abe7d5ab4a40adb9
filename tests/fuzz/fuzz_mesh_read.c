/*
 * fuzz_mesh_read.c - libFuzzer target for the mesh readers
 * (lib/mesh/io/mesh_read.h: PLY ascii and binary, OBJ, GLB) and the
 * simplifier behind them (lib/mesh/cluster.h).
 *
 * Byte 0 picks the reader (0: sniffed, 1: PLY, 2: OBJ, 3: GLB, modulo 4);
 * the rest is the file, in its own exactly-sized allocation so that a read
 * past its end is caught.  Limits: 2^16 vertices and triangles, 1 MiB.
 * Checked: a failure fills the message; a mesh that reads has every index
 * below its vertex count, finite positions and counts within the limits;
 * its tree builds, its face counts never decrease with the level, and the
 * selection at a middle level keeps exactly the precomputed count.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "mesh/cluster.h"
#include "mesh/io/mesh_read.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > (1u << 20))
        return 0;
    static const enum gv_mesh_in ins[4] = {GV_MESH_IN_AUTO, GV_MESH_IN_PLY,
                                           GV_MESH_IN_OBJ, GV_MESH_IN_GLB};
    enum gv_mesh_in in = ins[data[0] & 3];
    size_t len = size - 1;
    uint8_t *buf = malloc(len ? len : 1);
    if (!buf)
        return 0;
    memcpy(buf, data + 1, len);
    struct gv_mesh_limits lim = {.max_bytes = 1u << 20, .max_verts = 1u << 16,
                                 .max_tris = 1u << 16};
    struct gv_mesh m;
    struct gv_error err = {0};
    err.text[0] = 0;
    if (gv_mesh_read(buf, len, in, &lim, &m, &err) < 0) {
        if (!err.text[0])
            abort();
        free(buf);
        return 0;
    }
    if (m.nverts > lim.max_verts || m.ntris > lim.max_tris)
        abort();
    for (size_t i = 0; i < 3 * (size_t)m.ntris; i++)
        if (m.tris[i] >= m.nverts)
            abort();
    for (size_t i = 0; i < 3 * (size_t)m.nverts; i++)
        if (!isfinite(m.pos[i]))
            abort();
    struct gv_cluster_tree t;
    if (gv_cluster_build(&m, 0, &t, &err) == 0) {
        for (uint32_t T = 1; T <= t.nnodes; T++)
            if (t.faces_at[T] < t.faces_at[T - 1])
                abort();
        uint32_t T = t.nnodes / 2;
        uint32_t *cl = malloc((m.nverts ? m.nverts : 1) * sizeof *cl);
        uint8_t *keep = malloc(m.ntris ? m.ntris : 1);
        if (cl && keep) {
            gv_cluster_select(&t, T, cl, keep);
            uint32_t n = 0;
            for (uint32_t f = 0; f < m.ntris; f++)
                n += keep[f];
            if (n != t.faces_at[T])
                abort();
            struct gv_mesh r;
            if (gv_cluster_collect(&t, cl, keep, NULL, &r, &err) == 0) {
                if (r.ntris != n)
                    abort();
                gv_mesh_free(&r);
            }
        }
        free(cl);
        free(keep);
        gv_cluster_tree_free(&t);
    }
    gv_mesh_free(&m);
    free(buf);
    return 0;
}
