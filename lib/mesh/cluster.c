/*
 * cluster.c - the octree, levels and face counts of vertex clustering
 * (Kanaya et al. 2.1-2.3), the CPU selection (2.5, passes 2 and 3) and the
 * mesh made from a selection.  cluster.h describes the method.
 *
 * The octree is built breadth first: the node array is its own queue, so
 * node ids grow with depth.  A cell's vertices are a range of perm[],
 * cut in place by quickselect under the total order (coordinate, vertex
 * index), so the cut is the same whatever the select does inside.
 */
#include "mesh/cluster.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define NONE GV_CLUSTER_NONE
#define ILEVEL_CAP 1000u   /* i_level of a cell whose vertices coincide */

struct key {               /* a vertex under the split order of one axis */
    float c;
    uint32_t v;
};

static int key_less(struct key a, struct key b)
{
    return a.c < b.c || (a.c == b.c && a.v < b.v);
}

/* Put the k smallest of a[0 .. n-1] first (quickselect, median of three,
 * Lomuto partition; the keys are distinct, so the cut is unique and every
 * round places its pivot for good). */
static void select_k(struct key *a, size_t n, size_t k)
{
    size_t lo = 0, hi = n;   /* the k-th smallest lies in [lo, hi) */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2, pi;
        struct key x = a[lo], y = a[mid], z = a[hi - 1];
        if (key_less(x, y))
            pi = key_less(y, z) ? mid : key_less(x, z) ? hi - 1 : lo;
        else
            pi = key_less(x, z) ? lo : key_less(y, z) ? hi - 1 : mid;
        struct key p = a[pi], t;
        a[pi] = a[hi - 1];
        a[hi - 1] = p;
        size_t s = lo;
        for (size_t i = lo; i < hi - 1; i++)
            if (key_less(a[i], p)) {
                t = a[i];
                a[i] = a[s];
                a[s] = t;
                s++;
            }
        a[hi - 1] = a[s];
        a[s] = p;
        if (k == s)
            return;
        if (k < s)
            hi = s;
        else
            lo = s + 1;
    }
}

struct build {
    const struct gv_mesh *m;
    uint32_t *perm;
    struct key *keys;
    uint32_t *first, *count;   /* per node: its range of perm */
    float *len;                /* per node: longest bbox edge */
    uint32_t *ilevel;
};

/* Split perm[first .. first+count) at the median of axis into two. */
static void split_axis(struct build *b, uint32_t first, uint32_t count,
                       int axis)
{
    if (count < 2)
        return;
    struct key *k = b->keys;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t v = b->perm[first + i];
        k[i].c = b->m->pos[3 * (size_t)v + axis];
        k[i].v = v;
    }
    select_k(k, count, count / 2);
    for (uint32_t i = 0; i < count; i++)
        b->perm[first + i] = k[i].v;
}

static int cmp_node_order(const void *pa, const void *pb, void *ctx);

struct order_ctx { const struct build *b; const uint32_t *depth; };
static _Thread_local struct order_ctx g_ctx;

static int cmp_nodes(const void *pa, const void *pb)
{
    return cmp_node_order(pa, pb, &g_ctx);
}

/* r_level order (Kanaya eq. 2): i_level ascending, then length descending,
 * then depth, then id (so a parent always precedes its children). */
static int cmp_node_order(const void *pa, const void *pb, void *ctx)
{
    const struct order_ctx *c = ctx;
    uint32_t a = *(const uint32_t *)pa, b = *(const uint32_t *)pb;
    const struct build *bd = c->b;
    if (bd->ilevel[a] != bd->ilevel[b])
        return bd->ilevel[a] < bd->ilevel[b] ? -1 : 1;
    if (bd->len[a] != bd->len[b])
        return bd->len[a] > bd->len[b] ? -1 : 1;
    if (c->depth[a] != c->depth[b])
        return c->depth[a] < c->depth[b] ? -1 : 1;
    return a < b ? -1 : a > b;
}

void gv_cluster_tree_free(struct gv_cluster_tree *t)
{
    if (!t)
        return;
    free(t->parent);
    free(t->rank);
    free(t->depth);
    free(t->rep);
    free(t->leaf_parent);
    free(t->faces_at);
    free(t->rank_ilevel);
    memset(t, 0, sizeof *t);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static uint32_t lca_rank(const struct gv_cluster_tree *t, uint32_t u,
                         uint32_t v)
{
    if (u == v)
        return NONE;
    uint32_t a = t->leaf_parent[u], b = t->leaf_parent[v];
    while (t->depth[a] > t->depth[b])
        a = t->parent[a];
    while (t->depth[b] > t->depth[a])
        b = t->parent[b];
    while (a != b) {
        a = t->parent[a];
        b = t->parent[b];
    }
    return t->rank[a];
}

/* Kanaya 2.1, 2.2 for node id: its extent, representative, and its
 * eight cells of equal vertex counts, appended to the queue at *nn (or
 * made leaves). */
static void split_node(struct build *b, struct gv_cluster_tree *t,
                       uint32_t id, uint32_t *nn)
{
    const struct gv_mesh *m = t->mesh;
    uint32_t f = b->first[id], c = b->count[id];
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double sum[3] = {0, 0, 0};
    for (uint32_t i = f; i < f + c; i++) {
        const float *p = m->pos + 3 * (size_t)b->perm[i];
        for (int k = 0; k < 3; k++) {
            double x = p[k];
            sum[k] += x;
            if (x < lo[k]) lo[k] = x;
            if (x > hi[k]) hi[k] = x;
        }
    }
    double L = 0;
    for (int k = 0; k < 3; k++)
        if (hi[k] - lo[k] > L)
            L = hi[k] - lo[k];
    b->len[id] = (float)L;
    for (int k = 0; k < 3; k++)   /* Kanaya 2.2: the mean */
        t->rep[4 * (size_t)id + k] = (float)(sum[k] / c);
    /* Kanaya 2.1 step 2 and 4: eight cells of equal vertex counts. */
    uint32_t cut[9];
    cut[0] = f;
    cut[8] = f + c;
    cut[4] = f + c / 2;
    split_axis(b, f, c, 0);
    for (int h = 0; h < 2; h++) {
        uint32_t a = cut[4 * h], e = cut[4 * h + 4];
        cut[4 * h + 2] = a + (e - a) / 2;
        split_axis(b, a, e - a, 1);
    }
    for (int q = 0; q < 4; q++) {
        uint32_t a = cut[2 * q], e = cut[2 * q + 2];
        cut[2 * q + 1] = a + (e - a) / 2;
        split_axis(b, a, e - a, 2);
    }
    for (int s = 0; s < 8; s++) {
        uint32_t a = cut[s], cc = cut[s + 1] - cut[s];
        if (cc == 1) {
            t->leaf_parent[b->perm[a]] = id;
        } else if (cc > 1) {
            b->first[*nn] = a;
            b->count[*nn] = cc;
            t->parent[*nn] = id;
            t->depth[*nn] = t->depth[id] + 1;
            (*nn)++;
        }
    }
}

/* Kanaya 2.3 / pass 1: each triangle's threshold, counted into
 * t->faces_at. */
static void count_faces(struct gv_cluster_tree *t)
{
    for (uint32_t i = 0; i < t->mesh->ntris; i++) {
        const uint32_t *c = t->mesh->tris + 3 * (size_t)i;
        uint32_t r0 = lca_rank(t, c[0], c[1]);
        uint32_t r1 = lca_rank(t, c[1], c[2]);
        uint32_t r2 = lca_rank(t, c[0], c[2]);
        if (r0 == NONE || r1 == NONE || r2 == NONE)
            continue;
        uint32_t r = r0 > r1 ? r0 : r1;
        r = r > r2 ? r : r2;
        t->faces_at[r + 1]++;   /* survives once T > r */
    }
    for (uint32_t T = 1; T <= t->nnodes; T++)
        t->faces_at[T] += t->faces_at[T - 1];
}

/* Free the working arrays of a build and the vertex order. */
static void free_build(struct build *b, uint32_t *order)
{
    free(order);
    free(b->perm);
    free(b->keys);
    free(b->first);
    free(b->count);
    free(b->len);
    free(b->ilevel);
}

int gv_cluster_build(const struct gv_mesh *m, double time_limit,
                     struct gv_cluster_tree *t, struct gv_error *err)
{
    memset(t, 0, sizeof *t);
    t->mesh = m;
    uint32_t n = m->nverts;
    size_t cap = n > 1 ? n - 1 : 1;   /* internal nodes of a tree with n leaves */
    struct build b = {.m = m};
    uint32_t *order = NULL;
    double t0 = now();
    b.perm = malloc((n ? n : 1) * sizeof *b.perm);
    b.keys = malloc((n ? n : 1) * sizeof *b.keys);
    b.first = malloc(cap * sizeof *b.first);
    b.count = malloc(cap * sizeof *b.count);
    b.len = malloc(cap * sizeof *b.len);
    b.ilevel = malloc(cap * sizeof *b.ilevel);
    t->parent = malloc(cap * sizeof *t->parent);
    t->rank = malloc(cap * sizeof *t->rank);
    t->depth = malloc(cap * sizeof *t->depth);
    t->rep = malloc(cap * 4 * sizeof *t->rep);
    t->leaf_parent = malloc((n ? n : 1) * sizeof *t->leaf_parent);
    order = malloc(cap * sizeof *order);
    if (!b.perm || !b.keys || !b.first || !b.count || !b.len || !b.ilevel ||
        !t->parent || !t->rank || !t->depth || !t->rep || !t->leaf_parent ||
        !order)
        goto oom;
    for (uint32_t v = 0; v < n; v++) {
        b.perm[v] = v;
        t->leaf_parent[v] = NONE;
    }
    uint32_t nn = 0;
    if (n >= 2) {
        b.first[0] = 0;
        b.count[0] = n;
        t->parent[0] = NONE;
        t->depth[0] = 0;
        nn = 1;
    }
    /* Kanaya 2.1: breadth first; the node array is the queue. */
    for (uint32_t id = 0; id < nn; id++) {
        if (time_limit > 0 && (id & 1023) == 0 && now() - t0 > time_limit) {
            gv_cluster_tree_free(t);
            gv_fail(err, GV_ETIMEOUT, "cluster: octree over %.3g s",
                    time_limit);
            goto fail;
        }
        split_node(&b, t, id, &nn);
    }
    t->nnodes = nn;
    /* Kanaya eq. 1 and 2: i_level, then the rank in r_level order. */
    double lmax = nn ? b.len[0] : 0;
    for (uint32_t id = 0; id < nn; id++) {
        double L = b.len[id];
        uint32_t il;
        if (L >= lmax)
            il = 0;
        else if (L <= 0)
            il = ILEVEL_CAP;
        else {
            double x = floor(log2(lmax / L));
            il = x > ILEVEL_CAP - 1 ? ILEVEL_CAP - 1 : (uint32_t)x;
        }
        b.ilevel[id] = il;
        order[id] = id;
    }
    g_ctx.b = &b;
    g_ctx.depth = t->depth;
    qsort(order, nn, sizeof *order, cmp_nodes);
    t->rank_ilevel = malloc((nn + 1) * sizeof *t->rank_ilevel);
    t->faces_at = calloc((size_t)nn + 1, sizeof *t->faces_at);
    if (!t->rank_ilevel || !t->faces_at)
        goto oom;
    for (uint32_t r = 0; r < nn;) {   /* ranks, and r_level per node */
        uint32_t il = b.ilevel[order[r]], e = r;
        while (e < nn && b.ilevel[order[e]] == il)
            e++;
        for (uint32_t k = r; k < e; k++) {
            t->rank[order[k]] = k;
            t->rank_ilevel[k] = il;
            t->rep[4 * (size_t)order[k] + 3] =
                (float)(il + (double)(k - r) / (e - r));
        }
        t->max_ilevel = il;
        r = e;
    }
    count_faces(t);
    free_build(&b, order);
    return 0;
oom:
    gv_cluster_tree_free(t);
    gv_fail(err, GV_ENOMEM, "cluster: out of memory for %u vertices", n);
fail:
    free_build(&b, order);
    return -1;
}

/* The first rank whose i_level is >= i. */
static uint32_t first_rank_of(const struct gv_cluster_tree *t, uint32_t i)
{
    uint32_t lo = 0, hi = t->nnodes;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (t->rank_ilevel[mid] < i)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* The number of ranks whose r_level <= i (integer i): every rank of a
 * lower i_level, and the first of i_level i (r_level exactly i). */
static uint32_t T_at_integer(const struct gv_cluster_tree *t, uint32_t i)
{
    uint32_t lo = first_rank_of(t, i);
    if (lo < t->nnodes && t->rank_ilevel[lo] == i)
        lo++;
    return lo;
}

uint32_t gv_cluster_level(const struct gv_cluster_tree *t, uint64_t faces,
                          enum gv_cluster_mode mode, uint32_t *expect)
{
    uint32_t K = t->nnodes, T;
    const uint32_t *F = t->faces_at;
    if (faces >= F[K]) {
        T = K;
    } else if (mode == GV_CLUSTER_EXACT) {
        uint32_t lo = 0, hi = K;   /* smallest T with F[T] >= faces */
        while (lo < hi) {
            uint32_t mid = lo + (hi - lo) / 2;
            if (F[mid] < faces)
                lo = mid + 1;
            else
                hi = mid;
        }
        T = lo;
        if (T > 0 && faces - F[T - 1] <= F[T] - faces)
            T--;   /* nearer below, or a tie: the smaller mesh */
    } else {
        /* Kanaya eq. 3 between the integer levels i and i + 1. */
        uint32_t i = 0, Ti = T_at_integer(t, 0), Tn = K;
        for (; i <= t->max_ilevel; i++) {
            Tn = i + 1 > t->max_ilevel ? K : T_at_integer(t, i + 1);
            if (F[Tn] > faces)
                break;
            Ti = Tn;
        }
        double fi = F[Ti], fn = F[Tn];
        double r = i + (fn > fi ? ((double)faces - fi) / (fn - fi) : 0);
        /* T = the ranks whose r_level <= r: those below i_level i, and
         * those of i_level i with k / number_i <= r - i. */
        uint32_t base = first_rank_of(t, i), end = first_rank_of(t, i + 1);
        T = base;
        if (end > base) {
            double k = floor((r - i) * (end - base)) + 1;
            T = base + (k <= 0 ? 0 : k >= end - base ? end - base
                                                   : (uint32_t)k);
        }
    }
    if (expect)
        *expect = F[T];
    return T;
}

void gv_cluster_select(const struct gv_cluster_tree *t, uint32_t T,
                       uint32_t *cluster, uint8_t *keep)
{
    const struct gv_mesh *m = t->mesh;
    for (uint32_t v = 0; v < m->nverts; v++) {   /* pass 2 */
        uint32_t p = t->leaf_parent[v];
        if (p == NONE || t->rank[p] < T) {
            cluster[v] = t->nnodes + v;
            continue;
        }
        while (t->parent[p] != NONE && t->rank[t->parent[p]] >= T)
            p = t->parent[p];
        cluster[v] = p;
    }
    for (uint32_t f = 0; f < m->ntris; f++) {    /* pass 3 */
        const uint32_t *c = m->tris + 3 * (size_t)f;
        uint32_t a = cluster[c[0]], b = cluster[c[1]], d = cluster[c[2]];
        keep[f] = a != b && b != d && a != d;
    }
}

int gv_cluster_collect(const struct gv_cluster_tree *t, const uint32_t *cluster,
                       const uint8_t *keep, const float *vpos,
                       struct gv_mesh *out, struct gv_error *err)
{
    const struct gv_mesh *m = t->mesh;
    memset(out, 0, sizeof *out);
    size_t ids = (size_t)t->nnodes + m->nverts;
    uint32_t *remap = malloc((ids ? ids : 1) * sizeof *remap);
    uint32_t nt = 0;
    for (uint32_t f = 0; f < m->ntris; f++)
        nt += keep[f] != 0;
    out->tris = malloc((nt ? 3 * (size_t)nt : 1) * sizeof *out->tris);
    if (!remap || !out->tris)
        goto oom;
    for (size_t i = 0; i < ids; i++)
        remap[i] = 0;
    for (uint32_t f = 0; f < m->ntris; f++)
        if (keep[f])
            for (int k = 0; k < 3; k++)
                remap[cluster[m->tris[3 * (size_t)f + k]]] = 1;
    uint32_t nv = 0;
    for (size_t i = 0; i < ids; i++)
        remap[i] = remap[i] ? nv++ : NONE;
    out->pos = malloc((nv ? 3 * (size_t)nv : 1) * sizeof *out->pos);
    if (!out->pos)
        goto oom;
    if (vpos) {
        for (uint32_t v = 0; v < m->nverts; v++) {
            uint32_t o = remap[cluster[v]];
            if (o != NONE)
                memcpy(out->pos + 3 * (size_t)o, vpos + 4 * (size_t)v,
                       3 * sizeof(float));
        }
    } else {
        for (size_t i = 0; i < ids; i++) {
            if (remap[i] == NONE)
                continue;
            const float *p = i < t->nnodes
                ? t->rep + 4 * i : m->pos + 3 * (i - t->nnodes);
            memcpy(out->pos + 3 * (size_t)remap[i], p, 3 * sizeof(float));
        }
    }
    out->nverts = nv;
    for (uint32_t f = 0; f < m->ntris; f++)
        if (keep[f]) {
            for (int k = 0; k < 3; k++)
                out->tris[3 * (size_t)out->ntris + k] =
                    remap[cluster[m->tris[3 * (size_t)f + k]]];
            out->ntris++;
        }
    free(remap);
    return 0;
oom:
    free(remap);
    gv_mesh_free(out);
    return gv_fail(err, GV_ENOMEM, "cluster: out of memory for the result");
}
