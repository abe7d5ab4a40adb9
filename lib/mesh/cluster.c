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

#include "mesh/cluster_int.h"

#define NONE GV_CLUSTER_NONE
#define ILEVEL_CAP 1000u   /* i_level of a cell whose vertices coincide */

/* A vertex as the build carries it: its position beside its index, so a
 * cell's range is read in order, never gathered through the index. */
struct rec {
    float p[3];
    uint32_t v;
};

/* The split order of one axis as one integer: the coordinate's bits made
 * monotone (-0 read as +0, as the float comparison does), then the
 * vertex index for ties. */
static inline uint64_t rkey(const struct rec *r, int axis)
{
    float c = r->p[axis];
    uint32_t u;
    if (c == 0)
        c = 0;
    memcpy(&u, &c, 4);
    u ^= (u >> 31) ? 0xffffffffu : 0x80000000u;
    return (uint64_t)u << 32 | r->v;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return a < b ? -1 : a > b;
}

/* Put the k smallest of a[0 .. n-1] under axis first (the keys are
 * distinct, so which vertices go first is unique whatever the steps).
 * Large ranges: Floyd and Rivest's select, two keys of an evenly spaced
 * sample bracketing rank k, then one pass that keeps the keys below them
 * in place at the front and sends the others through tmp (n records) to
 * the middle and the back, again on the part holding rank k; about 1.1
 * passes over a range instead of quickselect's 3.4.  Small ranges:
 * quickselect, median of three, the same branch-free pass through tmp. */
static void select_k(struct rec *a, size_t n, size_t k, int axis,
                     struct rec *tmp)
{
    size_t lo = 0, hi = n;   /* the k-th smallest lies in [lo, hi) */
    uint64_t sample[1024];
    while (hi - lo > 256) {
        size_t m = hi - lo, ns = (size_t)sqrt((double)m);
        ns = ns > 1024 ? 1024 : ns;
        for (size_t i = 0; i < ns; i++)
            sample[i] = rkey(a + lo + i * m / ns, axis);
        qsort(sample, ns, sizeof *sample, cmp_u64);
        /* rank k's place in the sample, +- about 2 standard deviations */
        size_t r = (k - lo) * ns / m, d = (size_t)(sqrt((double)ns) + 1);
        uint64_t p1 = sample[r > d ? r - d : 0];
        uint64_t p2 = sample[r + d < ns ? r + d : ns - 1];
        size_t nl = 0, nm = 0, nr = 0;
        struct rec *base = a + lo;
        for (size_t i = 0; i < m; i++) {
            struct rec t = base[i];
            uint64_t key = rkey(&t, axis);
            size_t isl = key < p1, isr = key > p2;
            base[nl] = t;         /* nl <= i: already read */
            tmp[nm] = t;
            tmp[m - 1 - nr] = t;
            nl += isl;
            nr += isr;
            nm += 1 - isl - isr;
        }
        memcpy(base + nl, tmp, nm * sizeof *tmp);
        memcpy(base + nl + nm, tmp + m - nr, nr * sizeof *tmp);
        if (nm == m)
            break;   /* the sample held the extremes: no progress */
        if (k < lo + nl)
            hi = lo + nl;
        else if (k < lo + nl + nm) {
            hi = lo + nl + nm;
            lo = lo + nl;
        } else
            lo = lo + nl + nm;
    }
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2, pi;
        uint64_t x = rkey(a + lo, axis), y = rkey(a + mid, axis),
                 z = rkey(a + hi - 1, axis);
        if (x < y)
            pi = y < z ? mid : x < z ? hi - 1 : lo;
        else
            pi = x < z ? lo : y < z ? hi - 1 : mid;
        /* out of place through tmp, the pivot left between the parts */
        struct rec p = a[pi];
        a[pi] = a[hi - 1];
        uint64_t pk = rkey(&p, axis);
        size_t m = hi - lo - 1, nl = 0, nr = 0;
        for (size_t i = 0; i < m; i++) {
            struct rec t = a[lo + i];
            size_t lt = rkey(&t, axis) < pk;
            tmp[nl] = t;
            tmp[m - nr] = t;
            nl += lt;
            nr += 1 - lt;
        }
        tmp[nl] = p;
        memcpy(a + lo, tmp, (m + 1) * sizeof *tmp);
        size_t s = lo + nl;
        if (k == s)
            return;
        if (k < s)
            hi = s;
        else
            lo = s + 1;
    }
}

struct build {
    struct rec *r;             /* the vertices, cells as ranges */
    struct rec *tmp;           /* as many, for select_k */
    uint32_t *first, *count;   /* per node: its range of r */
    float *len;                /* per node: longest bbox edge */
    float *box;                /* per node: lowest then highest x, y, z */
};

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

/* Kanaya 2.1, 2.2 for node id: its extent, mean, and its eight cells of
 * equal vertex counts, appended to the queue at *nn (or made leaves). */
static void split_node(struct build *b, struct gv_cluster_tree *t,
                       uint32_t id, uint32_t *nn)
{
    uint32_t f = b->first[id], c = b->count[id];
    struct rec *r = b->r + f;
    float lo[3], hi[3];
    double sum[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++)
        lo[k] = hi[k] = r[0].p[k];
    for (uint32_t i = 0; i < c; i++)
        for (int k = 0; k < 3; k++) {
            float x = r[i].p[k];
            sum[k] += x;
            lo[k] = x < lo[k] ? x : lo[k];
            hi[k] = x > hi[k] ? x : hi[k];
        }
    double L = 0;
    for (int k = 0; k < 3; k++) {
        if ((double)hi[k] - lo[k] > L)
            L = (double)hi[k] - lo[k];
        b->box[6 * (size_t)id + k] = lo[k];
        b->box[6 * (size_t)id + 3 + k] = hi[k];
    }
    b->len[id] = (float)L;
    for (int k = 0; k < 3; k++)   /* Kanaya 2.2: the mean */
        t->rep[4 * (size_t)id + k] = (float)(sum[k] / c);
    if (c <= 8) {   /* the halvings leave at most one vertex per cell */
        for (uint32_t i = 0; i < c; i++)
            t->leaf_parent[r[i].v] = id;
        return;
    }
    /* Kanaya 2.1 step 2 and 4: eight cells of equal vertex counts. */
    uint32_t cut[9];
    cut[0] = 0;
    cut[8] = c;
    cut[4] = c / 2;
    select_k(r, c, cut[4], 0, b->tmp);
    for (int h = 0; h < 2; h++) {
        uint32_t a = cut[4 * h], e = cut[4 * h + 4];
        cut[4 * h + 2] = a + (e - a) / 2;
        select_k(r + a, e - a, (e - a) / 2, 1, b->tmp);
    }
    for (int q = 0; q < 4; q++) {
        uint32_t a = cut[2 * q], e = cut[2 * q + 2];
        cut[2 * q + 1] = a + (e - a) / 2;
        select_k(r + a, e - a, (e - a) / 2, 2, b->tmp);
    }
    for (int s = 0; s < 8; s++) {
        uint32_t a = cut[s], cc = cut[s + 1] - cut[s];
        if (cc == 1) {
            t->leaf_parent[r[a].v] = id;
        } else if (cc > 1) {
            b->first[*nn] = f + a;
            b->count[*nn] = cc;
            t->parent[*nn] = id;
            t->depth[*nn] = t->depth[id] + 1;
            (*nn)++;
        }
    }
}

/* Kanaya 2.3 / pass 1: each triangle's threshold, counted into
 * t->faces_at.  A triangle survives once T exceeds the ranks of its
 * corners' pairwise lowest common ancestors; ranks grow downwards, so
 * the largest is the deepest of the three, which is the one with the
 * largest id (ids grow with depth too).  Walking up from the three
 * leaf nodes, always moving the largest id (it cannot be an ancestor of
 * the others), the first node two of them reach together is it. */
static void count_faces(struct gv_cluster_tree *t)
{
    const uint32_t *par = t->parent, *lp = t->leaf_parent;
    for (uint32_t i = 0; i < t->mesh->ntris; i++) {
        const uint32_t *c = t->mesh->tris + 3 * (size_t)i;
        if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
            continue;
        uint32_t a = lp[c[0]], b = lp[c[1]], d = lp[c[2]];
        if (a == NONE || b == NONE || d == NONE)
            continue;
        while (a != b && b != d && a != d) {
            if (a > b && a > d)
                a = par[a];
            else if (b > d)
                b = par[b];
            else
                d = par[d];
        }
        uint32_t l = a == b || a == d ? a : b;
        t->faces_at[t->rank[l] + 1]++;   /* survives once T > rank */
    }
    for (uint32_t T = 1; T <= t->nnodes; T++)
        t->faces_at[T] += t->faces_at[T - 1];
}

/* Kanaya eq. 1: the i_level of a cell of longest edge L. */
static uint32_t ilevel_of(double L, double lmax)
{
    if (L >= lmax)
        return 0;
    if (L <= 0)
        return ILEVEL_CAP;
    double x = floor(log2(lmax / L));
    return x > ILEVEL_CAP - 1 ? ILEVEL_CAP - 1 : (uint32_t)x;
}

/*
 * The node ids in r_level order (Kanaya eq. 2): i_level ascending, then
 * length descending, then depth, then id, so that a parent precedes its
 * children.  i_level falls as the length grows, and depth grows with the
 * id, so this is the order of descending length with ties in id order:
 * a stable radix sort (two 16-bit digits) of the lengths' bits, which
 * sort as integers since no length is negative.
 */
static int rank_order(const float *len, uint32_t nn, uint32_t *order)
{
    uint32_t *key = malloc(((size_t)nn * 2 + 1) * sizeof *key);
    uint32_t *tmp = malloc(((size_t)nn + 1) * sizeof *tmp);
    uint32_t *cnt = malloc(65536 * sizeof *cnt);
    if (!key || !tmp || !cnt) {
        free(key);
        free(tmp);
        free(cnt);
        return -1;
    }
    uint32_t *k2 = key + nn;
    for (uint32_t i = 0; i < nn; i++) {
        uint32_t u;
        memcpy(&u, &len[i], 4);
        key[i] = ~u;   /* descending */
        order[i] = i;
    }
    uint32_t *src = order, *dst = tmp, *ks = key, *kd = k2;
    for (int shift = 0; shift < 32; shift += 16) {
        memset(cnt, 0, 65536 * sizeof *cnt);
        for (uint32_t i = 0; i < nn; i++)
            cnt[(ks[i] >> shift) & 0xffff]++;
        uint32_t sum = 0;
        for (uint32_t d = 0; d < 65536; d++) {
            uint32_t x = cnt[d];
            cnt[d] = sum;
            sum += x;
        }
        for (uint32_t i = 0; i < nn; i++) {
            uint32_t p = cnt[(ks[i] >> shift) & 0xffff]++;
            dst[p] = src[i];
            kd[p] = ks[i];
        }
        uint32_t *x = src; src = dst; dst = x;
        x = ks; ks = kd; kd = x;
    }
    /* two passes: the result is back in order[] */
    free(key);
    free(tmp);
    free(cnt);
    return 0;
}

/* Free the working arrays of a build and the vertex order. */
static void free_build(struct build *b, uint32_t *order)
{
    free(order);
    free(b->r);
    free(b->tmp);
    free(b->first);
    free(b->count);
    free(b->len);
    free(b->box);
}

int gv_cluster_build(const struct gv_mesh *m, double time_limit,
                     struct gv_cluster_tree *t, struct gv_error *err)
{
    memset(t, 0, sizeof *t);
    t->mesh = m;
    uint32_t n = m->nverts;
    size_t cap = n > 1 ? n - 1 : 1;   /* internal nodes of a tree with n leaves */
    struct build b = {0};
    uint32_t *order = NULL;
    double t0 = now();
    b.r = malloc((n ? n : 1) * sizeof *b.r);
    b.tmp = malloc((n ? n : 1) * sizeof *b.tmp);
    b.first = malloc(cap * sizeof *b.first);
    b.count = malloc(cap * sizeof *b.count);
    b.len = malloc(cap * sizeof *b.len);
    b.box = malloc(cap * 6 * sizeof *b.box);
    t->parent = malloc(cap * sizeof *t->parent);
    t->rank = malloc(cap * sizeof *t->rank);
    t->depth = malloc(cap * sizeof *t->depth);
    t->rep = malloc(cap * 4 * sizeof *t->rep);
    t->leaf_parent = malloc((n ? n : 1) * sizeof *t->leaf_parent);
    if (!b.r || !b.tmp || !b.first || !b.count || !b.len || !b.box || !t->parent ||
        !t->rank || !t->depth || !t->rep || !t->leaf_parent)
        goto oom;
    for (uint32_t v = 0; v < n; v++) {
        memcpy(b.r[v].p, m->pos + 3 * (size_t)v, 3 * sizeof(float));
        b.r[v].v = v;
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
    free(b.r);
    free(b.tmp);
    b.r = b.tmp = NULL;
    /* Kanaya 2.2 with Lindstrom's placement (cluster_quadric.c). */
    if (gv_cluster_quadric_reps(t, b.box, err) < 0) {
        gv_cluster_tree_free(t);
        goto fail;
    }
    /* Kanaya eq. 1 and 2: the rank in r_level order, then i_level and
     * r_level by runs of equal i_level (found by bisection: i_level
     * never falls along the order). */
    order = malloc((nn ? nn : 1) * sizeof *order);
    t->rank_ilevel = malloc((nn + 1) * sizeof *t->rank_ilevel);
    t->faces_at = calloc((size_t)nn + 1, sizeof *t->faces_at);
    if (!order || !t->rank_ilevel || !t->faces_at ||
        rank_order(b.len, nn, order) < 0)
        goto oom;
    double lmax = nn ? b.len[0] : 0;
    for (uint32_t r = 0; r < nn;) {
        uint32_t il = ilevel_of(b.len[order[r]], lmax), lo = r + 1, hi = nn;
        while (lo < hi) {   /* the first rank of a higher i_level */
            uint32_t mid = lo + (hi - lo) / 2;
            if (ilevel_of(b.len[order[mid]], lmax) == il)
                lo = mid + 1;
            else
                hi = mid;
        }
        uint32_t e = lo;
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
