/* Geometry metrics between two surfaces given as triangle meshes: both are sampled uniformly by
 * area and compared with nearest-neighbour distances (the DTU convention: accuracy = mean
 * distance from predicted samples to the ground truth, completeness = the reverse, Chamfer =
 * their mean). */
#ifndef ESR_EVAL_CHAMFER_H
#define ESR_EVAL_CHAMFER_H

#include <stddef.h>
#include <stdint.h>

#include "core/mesh.h"

struct esr_chamfer_result {
    double accuracy;     /* mean distance pred -> gt */
    double completeness; /* mean distance gt -> pred */
    double chamfer;      /* (accuracy + completeness) / 2 */
    size_t n_samples;    /* samples taken on each mesh */
};

/* Draws n points uniformly by area on m's triangles into pts[n*3]; deterministic in seed.
 * Fails on a mesh without area. */
int esr_mesh_sample_surface(const struct esr_mesh *m, size_t n, uint64_t seed, float *pts);

/* Mean nearest-neighbour distance from each of the na points in a to the point set b. */
int esr_mean_nearest_distance(const float *a, size_t na, const float *b, size_t nb, double *out);

/* Samples n points on each mesh and computes the metrics. */
int esr_chamfer_meshes(const struct esr_mesh *pred, const struct esr_mesh *gt, size_t n, uint64_t seed,
                       struct esr_chamfer_result *out);

#endif
