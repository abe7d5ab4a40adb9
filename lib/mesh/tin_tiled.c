/*
 * tin_tiled.c - one TIN of a grid made of independent tiles, meshed in
 * parallel.
 *
 * The grid is cut into tiles of `tile` x `tile` cells that share their
 * border samples (tile i spans samples i*tile .. (i+1)*tile).  Each tile is
 * meshed by gv_tin_build with border-first insertion, so two tiles choose
 * the same vertices on the edge they share (tin.h), and the tiles join
 * without cracks; the mesh is their union, shared vertices merged.  Tiles
 * run on a thread pool (lib/base/pool.h) and are stitched in tile order,
 * so the result does not depend on the thread count.  Smaller tiles also
 * mean less work in all: the expected cost O((m+n) log m) of Garland &
 * Heckbert section 4.4.1 falls with m per tile, at the price of the
 * vertices the tile borders force.
 */
#include "mesh/tin.h"

#include <stdlib.h>
#include <string.h>

#include "base/pool.h"

struct job {
    const float *h;
    size_t stride;
    uint32_t w, hgt, tile, tx, ty;
    struct gv_tin_params p;
    struct gv_mesh *tins;
    struct gv_error *errs;
    int *rcs;
};

static void run_tile(void *ctx, size_t i, int worker)
{
    struct job *j = ctx;
    (void)worker;
    uint32_t ix = (uint32_t)(i % j->tx), iy = (uint32_t)(i / j->tx);
    uint32_t x0 = ix * j->tile, y0 = iy * j->tile;
    uint32_t w = x0 + j->tile < j->w ? j->tile + 1 : j->w - x0;
    uint32_t h = y0 + j->tile < j->hgt ? j->tile + 1 : j->hgt - y0;
    j->rcs[i] = gv_tin_build(j->h + (size_t)y0 * j->stride + x0, w, h,
                             j->stride, &j->p, &j->tins[i], &j->errs[i]);
}

int gv_tin_build_tiled(const float *h, uint32_t w, uint32_t hgt, size_t stride,
                       const struct gv_tin_params *p, uint32_t tile,
                       int threads, struct gv_mesh *out, struct gv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!(p->max_error >= 0) || p->max_triangles)
        return gv_fail(err, GV_EINVAL, "mesh: tiles need a maximum error "
                       "and no triangle limit");
    if (tile < 1 || w < 2 || hgt < 2)
        return gv_fail(err, GV_EINVAL, "mesh: bad tile size %u", tile);
    if (w > GV_MESH_MAX_GRID || hgt > GV_MESH_MAX_GRID)
        return gv_fail(err, GV_EINVAL, "mesh: a grid of %ux%u samples is "
                       "over %u a side", w, hgt, GV_MESH_MAX_GRID);
    struct job j = {.h = h, .stride = stride, .w = w, .hgt = hgt, .tile = tile,
                    .p = *p};
    j.p.border_first = 1;
    j.tx = (w - 2) / tile + 1;
    j.ty = (hgt - 2) / tile + 1;
    size_t n = (size_t)j.tx * j.ty;
    j.tins = calloc(n, sizeof *j.tins);
    j.errs = calloc(n, sizeof *j.errs);
    j.rcs = calloc(n, sizeof *j.rcs);
    uint32_t *map = NULL;
    int rc = -1;
    struct gv_pool *pool = NULL;
    if (!j.tins || !j.errs || !j.rcs) {
        gv_fail(err, GV_ENOMEM, "mesh: out of memory");
        goto out;
    }
    pool = gv_pool_new(threads < 1 ? 1 : threads);
    if (!pool) {
        gv_fail(err, GV_ENOMEM, "mesh: cannot start %d threads", threads);
        goto out;
    }
    gv_pool_run(pool, run_tile, &j, n);
    uint64_t nv = 0, nt = 0;
    for (size_t i = 0; i < n; i++) {
        if (j.rcs[i] < 0) {
            *err = j.errs[i];
            goto out;
        }
        nv += j.tins[i].nverts;
        nt += j.tins[i].ntris;
    }
    if (nv > UINT32_MAX || nt > UINT32_MAX / 3) {
        gv_fail(err, GV_ELIMIT, "mesh: too many vertices");
        goto out;
    }
    /* map[sample] = vertex + 1 for the samples on tile borders, where
     * vertices repeat */
    map = calloc((size_t)w * hgt, sizeof *map);
    out->pos = malloc(nv * 3 * sizeof *out->pos);
    out->tris = malloc(nt * 3 * sizeof *out->tris);
    uint32_t *remap = NULL;
    if (!map || !out->pos || !out->tris) {
        gv_fail(err, GV_ENOMEM, "mesh: out of memory");
        goto out;
    }
    out->width = w;
    out->height = hgt;
    for (size_t i = 0; i < n; i++) {
        const struct gv_mesh *t = &j.tins[i];
        uint32_t x0 = (uint32_t)(i % j.tx) * tile;
        uint32_t y0 = (uint32_t)(i / j.tx) * tile;
        free(remap);
        remap = malloc((size_t)t->nverts * sizeof *remap);
        if (!remap) {
            gv_fail(err, GV_ENOMEM, "mesh: out of memory");
            goto out;
        }
        for (uint32_t v = 0; v < t->nverts; v++) {
            uint32_t x = x0 + gv_mesh_gx(t, v), y = y0 + gv_mesh_gy(t, v);
            size_t s = (size_t)y * w + x;
            if (!map[s]) {
                float *o = out->pos + 3 * (size_t)out->nverts;
                o[0] = (float)x;
                o[1] = (float)y;
                o[2] = gv_mesh_gz(t, v);
                map[s] = ++out->nverts;
            }
            remap[v] = map[s] - 1;
        }
        for (uint32_t k = 0; k < 3 * t->ntris; k++)
            out->tris[3 * (size_t)out->ntris + k] = remap[t->tris[k]];
        out->ntris += t->ntris;
        if (t->max_error > out->max_error)
            out->max_error = t->max_error;
    }
    free(remap);
    out->zmin = out->zmax = gv_mesh_gz(out, 0);
    for (uint32_t v = 0; v < out->nverts; v++) {
        float z = gv_mesh_gz(out, v);
        if (z < out->zmin) out->zmin = z;
        if (z > out->zmax) out->zmax = z;
    }
    rc = 0;
out:
    if (rc < 0)
        gv_mesh_free(out);
    if (j.tins)
        for (size_t i = 0; i < n; i++)
            gv_mesh_free(&j.tins[i]);
    free(j.tins);
    free(j.errs);
    free(j.rcs);
    free(map);
    gv_pool_free(pool);
    return rc;
}
