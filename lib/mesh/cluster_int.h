/*
 * cluster_int.h - what cluster.c shares with cluster_quadric.c but not
 * with callers: the quadric-optimal placement of the representatives.
 */
#ifndef GV_MESH_CLUSTER_INT_H
#define GV_MESH_CLUSTER_INT_H

#include "mesh/cluster.h"

/*
 * Move every node's representative of tree t (on entry t->rep holds the
 * mean of the node's vertices; t->nnodes, t->parent and t->leaf_parent
 * are set) to the point that minimizes the node's quadric error, kept in
 * box (6 floats per node: the lowest x, y, z then the highest x, y, z of
 * the node's vertices).  Returns 0, or -1 with *err (GV_ENOMEM), t->rep
 * then unchanged.  Thread-safe.
 */
int gv_cluster_quadric_reps(struct gv_cluster_tree *t, const float *box,
                            struct gv_error *err);

#endif
