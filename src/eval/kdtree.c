#include "eval/kdtree.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

/* Leaves hold up to this many points: scanning a few points is cheaper than descending further. */
#define LEAF_SIZE 8

/* Node i covers points [begin, end); an inner node splits them at the median along `axis`, its
 * children are nodes 2i+1 (coordinates <= split) and 2i+2 (>= split). */
struct esr_kdnode {
    size_t begin, end;
    float split;
    int axis; /* -1 for a leaf */
};

static void swap_points(float *p, size_t i, size_t j)
{
    for (int k = 0; k < 3; k++) {
        float t = p[i * 3 + k];
        p[i * 3 + k] = p[j * 3 + k];
        p[j * 3 + k] = t;
    }
}

/* Quickselect: reorders p[lo..hi) so that the point at index `nth` has its sorted value along
 * `axis`, smaller-or-equal ones before it and greater-or-equal ones after it. */
static void select_nth(float *p, size_t lo, size_t hi, size_t nth, int axis)
{
    while (hi - lo > 1) {
        float pivot = p[((lo + hi) / 2) * 3 + axis];
        size_t i = lo, j = hi - 1;
        while (i <= j) { /* Hoare partition around the pivot value */
            while (p[i * 3 + axis] < pivot)
                i++;
            while (p[j * 3 + axis] > pivot)
                j--;
            if (i <= j) {
                swap_points(p, i, j);
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        /* now [lo, j] <= pivot <= [i, hi) and anything between equals the pivot */
        if (nth <= j)
            hi = j + 1;
        else if (nth >= i)
            lo = i;
        else
            return;
    }
}

static void build_node(struct esr_kdtree *t, size_t node, size_t begin, size_t end)
{
    struct esr_kdnode *nd = &t->nodes[node];
    nd->begin = begin;
    nd->end = end;
    nd->axis = -1;
    if (end - begin <= LEAF_SIZE || 2 * node + 2 >= t->n_nodes)
        return;
    float lo[3] = {FLT_MAX, FLT_MAX, FLT_MAX}, hi[3] = {-FLT_MAX, -FLT_MAX, -FLT_MAX};
    for (size_t i = begin; i < end; i++)
        for (int k = 0; k < 3; k++) {
            float v = t->pts[i * 3 + k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    int axis = 0; /* split the widest extent */
    for (int k = 1; k < 3; k++)
        if (hi[k] - lo[k] > hi[axis] - lo[axis])
            axis = k;
    size_t mid = begin + (end - begin) / 2;
    select_nth(t->pts, begin, end, mid, axis);
    nd->axis = axis;
    nd->split = t->pts[mid * 3 + axis];
    build_node(t, 2 * node + 1, begin, mid);
    build_node(t, 2 * node + 2, mid, end);
}

int esr_kdtree_build(struct esr_kdtree *t, const float *pts, size_t n)
{
    memset(t, 0, sizeof *t);
    if (n == 0)
        return ESR_FAIL("nearest-neighbour index over an empty point set");
    /* a complete binary tree deep enough that every leaf has at most LEAF_SIZE points */
    size_t leaves = 1;
    while (leaves * LEAF_SIZE < n)
        leaves *= 2;
    t->n = n;
    t->n_nodes = 2 * leaves - 1;
    t->pts = malloc(n * 3 * sizeof(float));
    t->nodes = calloc(t->n_nodes, sizeof *t->nodes);
    if (!t->pts || !t->nodes) {
        esr_kdtree_free(t);
        return ESR_FAIL("out of memory for a nearest-neighbour index of %zu points", n);
    }
    memcpy(t->pts, pts, n * 3 * sizeof(float));
    for (int k = 0; k < 3; k++)
        t->lo[k] = FLT_MAX, t->hi[k] = -FLT_MAX;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            const float v = pts[i * 3 + k];
            t->lo[k] = v < t->lo[k] ? v : t->lo[k];
            t->hi[k] = v > t->hi[k] ? v : t->hi[k];
        }
    build_node(t, 0, 0, n);
    return ESR_OK;
}

/* Depth-first search with the incremental distance of Arya and Mount: rd is the squared distance
 * from q to the node's cell (the bounding box cut by the splits above it), off[k] q's offset from
 * that cell along axis k. A subtree is skipped when its cell is no closer than the best point
 * found. Pruning by the split plane alone (|q_axis - split|) ignores how far q lies outside the
 * points along the other axes, so for a query far from all of them (a floater, a ground plane
 * beyond the reconstruction) it visits most of the tree: O(n) per query. */
static void nearest_in(const struct esr_kdtree *t, size_t node, const float *q, float rd, float off[3],
                       float *best)
{
    const struct esr_kdnode *nd = &t->nodes[node];
    if (nd->axis < 0) {
        for (size_t i = nd->begin; i < nd->end; i++) {
            const float *p = t->pts + i * 3;
            float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            float d = dx * dx + dy * dy + dz * dz;
            *best = d < *best ? d : *best;
        }
        return;
    }
    const int a = nd->axis;
    const float diff = q[a] - nd->split;
    const size_t near = diff <= 0.0f ? 2 * node + 1 : 2 * node + 2;
    const size_t far = diff <= 0.0f ? 2 * node + 2 : 2 * node + 1;
    nearest_in(t, near, q, rd, off, best);
    const float old = off[a];
    const float far_rd = rd - old * old + diff * diff; /* the far cell's box is diff away along a */
    if (far_rd < *best) {
        off[a] = diff;
        nearest_in(t, far, q, far_rd, off, best);
        off[a] = old;
    }
}

float esr_kdtree_nearest_sq(const struct esr_kdtree *t, const float q[3])
{
    float best = FLT_MAX, off[3], rd = 0.0f;
    for (int k = 0; k < 3; k++) { /* q's offset from the root cell along each axis */
        off[k] = q[k] < t->lo[k] ? q[k] - t->lo[k] : q[k] > t->hi[k] ? q[k] - t->hi[k] : 0.0f;
        rd += off[k] * off[k];
    }
    nearest_in(t, 0, q, rd, off, &best);
    return best;
}

void esr_kdtree_free(struct esr_kdtree *t)
{
    free(t->pts);
    free(t->nodes);
    memset(t, 0, sizeof *t);
}
