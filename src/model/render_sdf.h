/* The SDF values the renderer sees (internal to src/train): the raw grid, or in the coarse stage
 * its Gaussian-smoothed copy (METHOD.md stage 2; the optimiser updates the raw grid through the
 * smoothing's adjoint). */
#ifndef ESR_MODEL_RENDER_SDF_H
#define ESR_MODEL_RENDER_SDF_H

#include "model/model.h"

/* out (and scratch) hold esr_grid_count(&m->sdf) floats; raw may not alias out. */
int esr_model_view_sdf(const struct esr_model *m, const float *raw, float *out, float *scratch);
/* The SDF whose gradient gives the model's normals (rendered normal maps, and what the shading
 * stages will light with): the raw grid smoothed by options normal_ksize/normal_sigma, or NULL in
 * *out when that is off (then the normals are the marched SDF's own gradient). *out is allocated;
 * the caller frees it. */
int esr_model_normal_sdf(const struct esr_model *m, float **out);

#endif
