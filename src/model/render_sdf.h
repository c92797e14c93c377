/* The SDF values the renderer sees (internal to the library): the raw grid, or in the coarse stage
 * its Gaussian-smoothed copy (METHOD.md stage 2; the optimiser updates the raw grid through the
 * smoothing's adjoint). */
#ifndef ESR_MODEL_RENDER_SDF_H
#define ESR_MODEL_RENDER_SDF_H

#include <stdint.h>

#include "fields/mask.h"
#include "model/model.h"

/* out (and scratch) hold esr_grid_count(&m->sdf) floats; raw may not alias out. */
int esr_model_view_sdf(const struct esr_model *m, const float *raw, float *out, float *scratch);
/* The SDF whose gradient gives the model's normals (rendered normal maps, and what the shading
 * stages will light with): the raw grid smoothed by options normal_ksize/normal_sigma, or NULL in
 * *out when that is off (then the normals are the marched SDF's own gradient). *out is allocated;
 * the caller frees it. */
int esr_model_normal_sdf(const struct esr_model *m, float **out);

/* Whether the renderer samples at p: m has no mask cache yet, or p's nearest mask point is
 * occupied (volume/sampler.h drops every other sample). */
static inline int esr_model_renders_at(const struct esr_model *m, const float p[3])
{
    return !m->has_mask || esr_mask_query(&m->mask, p);
}

/* What the renderer makes of each lattice point of m's SDF grid: it samples there, or the
 * point's nearest mask-cache point is empty and it drops every sample there. Skipped space was
 * never trained by an image: its values drift to ~0 (a trained default scene has sign changes
 * in mid-air between its objects; 94% of the shadow rays they stopped ended outside the mask),
 * and a march for the first hit finds surfaces no render shows. Skipped regions (6-connected)
 * that touch rendered space outside a surface, or the grid's edge, are empty space; the others
 * are enclosed by solid (a band mask skips the inside of every thick solid). */
enum { ESR_SDF_RENDERED = 0, ESR_SDF_SKIPPED_EMPTY = 1, ESR_SDF_SKIPPED_INSIDE = 2 };
/* skipped[i] (esr_grid_voxels bytes) = one of the above. */
int esr_model_sdf_skipped(const struct esr_model *m, uint8_t *skipped);
/* out = sdf raised to at least a voxel in skipped empty space and lowered to at most minus a
 * voxel in skipped insides: the SDF as a march for the first hit (shadow rays, the first-hit
 * estimator, free-space carving) and the mesh must see it to agree with the renders, with no
 * shell where a band mask ends inside a solid. out may alias sdf. */
void esr_model_sdf_lift_skipped(const struct esr_model *m, const float *sdf, const uint8_t *skipped,
                                float *out);
/* Both for the model's own SDF: *out allocated, the caller frees it. */
int esr_model_first_hit_sdf(const struct esr_model *m, float **out);

#endif
