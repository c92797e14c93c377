/* The SDF values the renderer sees (internal to src/train): the raw grid, or in the coarse stage
 * its Gaussian-smoothed copy (METHOD.md stage 2; the optimiser updates the raw grid through the
 * smoothing's adjoint). */
#ifndef ESR_MODEL_RENDER_SDF_H
#define ESR_MODEL_RENDER_SDF_H

#include "model/model.h"

/* out (and scratch) hold esr_grid_count(&m->sdf) floats; raw may not alias out. */
int esr_model_view_sdf(const struct esr_model *m, const float *raw, float *out, float *scratch);

#endif
