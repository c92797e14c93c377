/* Weighted k-means of a few low-dimensional points, deterministic, with the number of clusters
 * decided by the data: farthest-first centres (the first the weighted mean) are added while the
 * point farthest from every centre lies at least min_separation from them, up to k_max; Lloyd
 * iterations then move them; a cluster left with under min_share of the total weight is dropped
 * and its points go to the nearest kept centre. Used to split an exported mesh into a few
 * materials (render/model_gltf.c). */
#ifndef ESR_CORE_KMEANS_H
#define ESR_CORE_KMEANS_H

#include <stddef.h>
#include <stdint.h>

#define ESR_KMEANS_MAX_DIM 4
#define ESR_KMEANS_MAX_K 32

struct esr_kmeans_params {
    const float *x;       /* [n * dim] points */
    const float *w;       /* [n] non-negative weights, or NULL for 1 each */
    size_t n;
    int dim;              /* 1..ESR_KMEANS_MAX_DIM */
    int k_max;            /* 1..ESR_KMEANS_MAX_K */
    float min_separation; /* Euclidean; centres nearer than this are not added */
    float min_share;      /* of the total weight, in [0, 1) */
    int iters;            /* Lloyd iterations at most (stops when no point moves) */
};

/* Clusters p's points: centres [k * dim] (k_max * dim floats), assign [n] (cluster of each
 * point), weights [k] (k_max doubles, or NULL: each cluster's total weight), *k_out the number
 * of clusters (1 when n is 0 or every weight is 0: the centre then is the plain mean, or 0, and
 * its weight 0). Clusters are numbered by decreasing weight. */
int esr_kmeans(const struct esr_kmeans_params *p, float *centres, int32_t *assign,
               double *weights, int *k_out);

#endif
