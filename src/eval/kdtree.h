/* A static k-d tree over 3D points for exact nearest-neighbour queries (geometry metrics).
 * Chosen over a uniform grid because query points can lie far from the indexed set (a poor
 * reconstruction's floaters): a grid then scans shells of cells whose number grows with the
 * cube of the distance, while the tree prunes whole subtrees by the distance to their cells. */
#ifndef ESR_EVAL_KDTREE_H
#define ESR_EVAL_KDTREE_H

#include <stddef.h>

struct esr_kdtree {
    size_t n;
    float *pts;      /* [n*3] points reordered so every subtree is a contiguous range */
    size_t n_nodes;
    struct esr_kdnode *nodes;
    float lo[3], hi[3]; /* bounding box of all points: the root cell */
};

/* Builds the tree over pts[n*3] (copied). Fails on n = 0 or out of memory. */
int esr_kdtree_build(struct esr_kdtree *t, const float *pts, size_t n);
/* Squared distance from q to its nearest indexed point (exact). Thread-safe. */
float esr_kdtree_nearest_sq(const struct esr_kdtree *t, const float q[3]);
void esr_kdtree_free(struct esr_kdtree *t);

#endif
