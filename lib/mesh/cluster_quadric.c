/*
 * cluster_quadric.c - quadric-optimal representatives of vertex
 * clustering (cluster_int.h): the alternative Kanaya et al. name in their
 * section 2.2 ("It is possible to use [Lindstrom 2000] instead ... for
 * accuracy improvement"; ../shared/reference/gpu-vertex-clustering.md).
 *
 * Lindstrom's out-of-core clustering: every triangle's plane gives the
 * quadric Q = (n n^T, d n, d^2) of the squared distance to it, n the
 * unnormalized normal (a weight of the square of twice the area, and no
 * square root per triangle), and Q is added to the cell of each of its
 * three corners; a cell's representative minimizes the sum.  Here a cell
 * is an octree node, so each triangle goes to the nodes holding its
 * corners as leaves, and a pass from the deepest node up (node ids grow
 * with depth) adds every node into its parent: each node then has the
 * quadrics of every triangle touching one of its vertices, counted once
 * per corner.
 *
 * The minimum solves A x = -b, A the 3 x 3 part.  A cell whose triangles
 * are near one plane (most cells of a smooth surface) or one line has A
 * nearly singular, so A is diagonalized (Jacobi) and the step from the
 * cell's mean goes along the eigenvectors of the well-conditioned
 * eigenvalues only (the pseudo-inverse about the mean, as Lindstrom does
 * with the SVD; COND_MIN): along the others the point keeps the mean,
 * and with no well-conditioned direction it is the mean
 * (Kanaya 2.2's synthesis).  A flat cell thus gets its mean moved onto
 * its plane.  The result is clamped to the bounding box of the cell's
 * vertices, so it never leaves the cell.  Everything is in doubles about
 * the centre of the root's box; cells with a non-finite result keep the
 * mean.
 */
#include "mesh/cluster_int.h"

#include <math.h>
#include <stdlib.h>

/* An eigenvalue under this share of the largest is taken as zero: planes within
 * about 6 degrees of each other (sin^2 6deg ~ 1.1e-2) do not pin a point
 * along their common plane (1e-3 let cells holding two sheets of a
 * surface put their point between them: bench/simplify-speed.sh's
 * volume surface, 1.6 to 2.5 times the Hausdorff error). */
#define COND_MIN 1e-2
#define NQ 9   /* A's upper triangle (xx xy xz yy yz zz), then b */

/* One Jacobi rotation zeroing apq of the symmetric matrix (app aqq apq;
 * arp arq the third row's entries), applied to the columns p and q of
 * the eigenvectors v (Numerical Recipes' jacobi, section 11.1). */
#define ROT(app, aqq, apq, arp, arq, p, q)                                 \
    do {                                                                   \
        if (apq != 0) {                                                    \
            double th = (aqq - app) / (2 * apq);                           \
            double t = 1 / (fabs(th) + sqrt(th * th + 1));                 \
            if (th < 0)                                                    \
                t = -t;                                                    \
            double c = 1 / sqrt(t * t + 1), s = t * c, tau = s / (1 + c);  \
            app -= t * apq;                                                \
            aqq += t * apq;                                                \
            apq = 0;                                                       \
            double x = arp, y = arq;                                       \
            arp = x - s * (y + tau * x);                                   \
            arq = y + s * (x - tau * y);                                   \
            for (int k = 0; k < 3; k++) {                                  \
                x = v[k][p];                                               \
                y = v[k][q];                                               \
                v[k][p] = x - s * (y + tau * x);                           \
                v[k][q] = y + s * (x - tau * y);                           \
            }                                                              \
        }                                                                  \
    } while (0)

/* Eigenvalues w and eigenvectors (the columns of v) of the symmetric
 * matrix q = (xx xy xz yy yz zz) by cyclic Jacobi rotations, until the
 * off-diagonal part is under 1e-12 of the diagonal (far below a float's
 * precision; 2 to 4 sweeps). */
static void eigen3(const double *q, double w[3], double v[3][3])
{
    double a00 = q[0], a01 = q[1], a02 = q[2], a11 = q[3], a12 = q[4],
           a22 = q[5];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 12; sweep++) {
        double off = a01 * a01 + a02 * a02 + a12 * a12;
        double on = a00 * a00 + a11 * a11 + a22 * a22;
        if (!(off > 1e-24 * on))
            break;
        ROT(a00, a11, a01, a02, a12, 0, 1);
        ROT(a00, a22, a02, a01, a12, 0, 2);
        ROT(a11, a22, a12, a01, a02, 1, 2);
    }
    w[0] = a00;
    w[1] = a11;
    w[2] = a22;
}

/* The representative of one node from its quadric q, its mean rep[0..2]
 * and its box; o the origin of q: the mean plus the pseudo-inverse step,
 * A's eigenvalues under COND_MIN of the largest taken as zero. */
static void place(const double *q, const float *box, const double o[3],
                  float *rep)
{
    double m[3], r[3], x[3], w[3], v[3][3];
    for (int k = 0; k < 3; k++)
        m[k] = rep[k] - o[k];
    r[0] = q[0] * m[0] + q[1] * m[1] + q[2] * m[2] + q[6];
    r[1] = q[1] * m[0] + q[3] * m[1] + q[4] * m[2] + q[7];
    r[2] = q[2] * m[0] + q[4] * m[1] + q[5] * m[2] + q[8];
    eigen3(q, w, v);
    double wmax = fmax(w[0], fmax(w[1], w[2]));
    if (!(wmax > 0))
        return;   /* no plane: the mean */
    for (int k = 0; k < 3; k++)
        x[k] = m[k];
    for (int i = 0; i < 3; i++) {
        if (!(w[i] > COND_MIN * wmax))
            continue;
        double d = (v[0][i] * r[0] + v[1][i] * r[1] + v[2][i] * r[2]) / w[i];
        for (int k = 0; k < 3; k++)
            x[k] -= d * v[k][i];
    }
    for (int k = 0; k < 3; k++) {
        double y = x[k] + o[k];
        if (!isfinite(y))
            return;   /* keep the mean */
        x[k] = y < box[k] ? box[k] : y > box[3 + k] ? box[3 + k] : y;
    }
    for (int k = 0; k < 3; k++)
        rep[k] = (float)x[k];
}

int gv_cluster_quadric_reps(struct gv_cluster_tree *t, const float *box,
                            struct gv_error *err)
{
    const struct gv_mesh *m = t->mesh;
    uint32_t nn = t->nnodes;
    if (nn == 0)
        return 0;
    double *Q = calloc((size_t)nn * NQ, sizeof *Q);
    if (!Q)
        return gv_fail(err, GV_ENOMEM, "cluster: out of memory for the "
                       "quadrics of %u nodes", nn);
    double o[3];
    for (int k = 0; k < 3; k++)
        o[k] = 0.5 * ((double)box[k] + box[3 + k]);
    for (uint32_t f = 0; f < m->ntris; f++) {
        const uint32_t *c = m->tris + 3 * (size_t)f;
        double p[3][3];
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                p[i][k] = m->pos[3 * (size_t)c[i] + k] - o[k];
        double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1],
                        p[1][2] - p[0][2]};
        double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1],
                        p[2][2] - p[0][2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1],
                       e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        /* n n^T with n unnormalized: the plane's quadric weighted by
         * the square of twice the area, and no square root. */
        double d = -(n[0] * p[0][0] + n[1] * p[0][1] + n[2] * p[0][2]);
        double fq[NQ] = {n[0] * n[0], n[0] * n[1], n[0] * n[2],
                         n[1] * n[1], n[1] * n[2], n[2] * n[2],
                         d * n[0], d * n[1], d * n[2]};
        for (int i = 0; i < 3; i++) {
            uint32_t id = t->leaf_parent[c[i]];
            if (id == GV_CLUSTER_NONE)
                continue;
            double *dst = Q + (size_t)id * NQ;
            for (int j = 0; j < NQ; j++)
                dst[j] += fq[j];
        }
    }
    for (uint32_t id = nn - 1; id > 0; id--) {   /* children before parents */
        const double *s = Q + (size_t)id * NQ;
        double *dst = Q + (size_t)t->parent[id] * NQ;
        for (int j = 0; j < NQ; j++)
            dst[j] += s[j];
    }
    for (uint32_t id = 0; id < nn; id++)
        place(Q + (size_t)id * NQ, box + 6 * (size_t)id, o,
              t->rep + 4 * (size_t)id);
    free(Q);
    return 0;
}
