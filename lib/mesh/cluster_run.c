/*
 * cluster_run.c - gv_simplify: the whole simplification of one file
 * (cluster_run.h), timed step by step.
 */
#include "mesh/cluster_run.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double ms_since(const struct timespec *t0)
{
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (double)(t1.tv_sec - t0->tv_sec) * 1e3 +
           (double)(t1.tv_nsec - t0->tv_nsec) * 1e-6;
}

int gv_simplify(const uint8_t *in, size_t len,
                const struct gv_simplify_opts *o, uint8_t **out,
                size_t *out_len, struct gv_simplify_stats *st,
                struct gv_error *err)
{
    struct gv_mesh m = {0}, res = {0};
    struct gv_cluster_tree t = {0};
    uint32_t *cluster = NULL;
    uint8_t *keep = NULL;
    float *vpos = NULL;
    struct timespec t0;
    int rc = -1;
    memset(st, 0, sizeof *st);
    if (!o->faces && !(o->ratio >= 0 && o->ratio <= 1))
        return gv_fail(err, GV_EINVAL, "simplify: ratio must be in [0, 1]");
    if (o->max_faces && o->faces > o->max_faces)
        return gv_fail(err, GV_ELIMIT, "simplify: %llu faces asked, the "
                       "limit is %u", (unsigned long long)o->faces,
                       o->max_faces);
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (gv_mesh_read(in, len, GV_MESH_IN_AUTO, &o->lim, &m, err) < 0)
        return -1;
    st->read_ms = ms_since(&t0);
    st->in_verts = m.nverts;
    st->in_tris = m.ntris;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (gv_cluster_build(&m, o->time_limit, &t, err) < 0)
        goto out;
    st->build_ms = ms_since(&t0);
    st->nnodes = t.nnodes;
    st->asked = o->faces ? o->faces : (uint64_t)llround(o->ratio * m.ntris);
    if (o->max_faces && st->asked > o->max_faces) {
        gv_fail(err, GV_ELIMIT, "simplify: %llu faces asked, the limit is %u",
                (unsigned long long)st->asked, o->max_faces);
        goto out;
    }
    st->level = gv_cluster_level(&t, st->asked, o->mode, NULL);
    cluster = malloc((m.nverts ? m.nverts : 1) * sizeof *cluster);
    keep = malloc(m.ntris ? m.ntris : 1);
    if (o->select)
        vpos = malloc((m.nverts ? m.nverts : 1) * 4 * sizeof *vpos);
    if (!cluster || !keep || (o->select && !vpos)) {
        gv_fail(err, GV_ENOMEM, "simplify: out of memory");
        goto out;
    }
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (o->select) {
        if (o->select(o->select_ctx, &t, st->level, cluster, keep, vpos,
                      err) < 0)
            goto out;
    } else {
        gv_cluster_select(&t, st->level, cluster, keep);
    }
    if (gv_cluster_collect(&t, cluster, keep, vpos, &res, err) < 0)
        goto out;
    st->select_ms = ms_since(&t0);
    st->out_verts = res.nverts;
    st->out_tris = res.ntris;
    char comment[160];
    snprintf(comment, sizeof comment, "%u of %u triangles (asked %llu), "
             "level %u of %u", res.ntris, m.ntris,
             (unsigned long long)st->asked, st->level, t.nnodes);
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (gv_mesh_encode(o->format, &res, NULL, comment, out, out_len,
                       err) < 0)
        goto out;
    st->write_ms = ms_since(&t0);
    rc = 0;
out:
    free(cluster);
    free(keep);
    free(vpos);
    gv_mesh_free(&res);
    gv_cluster_tree_free(&t);
    gv_mesh_free(&m);
    return rc;
}
