/* Primary rays through the model, forward and backward: the composition of the three trace
 * layers that training and rendering share.
 *   1. march (volume/march.h): samples, SDF value + gradient (fused), NeuS alpha, weights, the
 *      kept list; DVGO density alpha in the alphamask stage
 *   2. point fields (model/point_fields.h): the stage's head on the kept rows, each row with its
 *      ray's lighting flag
 *   3. composite (volume/composite.h): tone-mapped / LDR colour and linear radiance over each ray
 *      on a white background, or on the learned one (fields/background.h) when the model has it
 * The backward pass runs them in reverse into the flat gradient and the SDF gradient. Buffers
 * grow to the high-water mark of the first batches and are then reused: the training loop
 * allocates nothing in steady state. */
#ifndef ESR_MODEL_TRACE_H
#define ESR_MODEL_TRACE_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "model/point_fields.h"
#include "volume/march.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_trace {
    int train;               /* 1: keep what backward needs (MLP contexts, jittered samples) */
    int max_rays;
    struct esr_march march;  /* layer 1 */
    struct esr_point_fields fields; /* layer 2 */
    size_t cap_rows;
    uint8_t *row_on;         /* [cap_rows] lighting flag of each kept row (its ray's) */
    float *d_tone_rows, *d_lin_rows; /* [cap_rows * 3] gradients of the kept rows' values */
    const uint8_t *lights_on; /* per ray, of the last forward */
    const float *d_t_last;   /* per ray, or NULL: a loss gradient on the final transmittances
                                for the next backward (set after the forward; consumed) */
    const float *dirs;       /* per ray, of the last forward */
    int has_bg;              /* the last forward composited on the model's learned background */
    /* per ray [max_rays * 3] */
    float *rgb3;             /* tone-mapped / LDR colour on the background */
    float *lin_rgb3;         /* linear HDR on the background (= rgb3 for the LDR heads) */
    float *bg3, *d_bg3;      /* the learned background seen by each ray, and its gradient */
    float *bg_lin3;          /* bg3 decoded to linear (sRGB): what the linear composite blends */
};

/* Workspace for batches of up to max_rays rays of model m's current stage. */
int esr_trace_init(struct esr_trace *t, const struct esr_model *m, int max_rays, int train);
void esr_trace_free(struct esr_trace *t);

/* The geometry layer 1 marches for m: density (alphamask) or the SDF `sdf` (the values the
 * renderer sees: m's raw grid, or its smoothed copy in the coarse stage), m's step, inv-s and
 * mask cache. */
void esr_trace_geometry(const struct esr_model *m, const float *sdf, struct esr_march_geometry *g);

/* Forward pass of n rays with per-ray lighting flags lights_on[n] (1 = lights on). Jitter uses
 * (seed, ray index) when t->train. Fills t->rgb3, t->lin_rgb3 and the layers' state. */
int esr_trace_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                  const float *origins, const float *dirs, const uint8_t *lights_on, int n,
                  uint64_t seed);
/* Layers 2 and 3 again on the last forward's march with other lighting flags (n of that
 * forward): both lightings of one view from one march (the geometry does not depend on the
 * lights). Replaces rgb3, lin_rgb3 and the layers' state: a backward then runs for these flags. */
int esr_trace_shade(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                    const uint8_t *lights_on);
/* Backward of the last forward given d loss/d rgb and d loss/d lin (per ray x3; lin may be NULL)
 * and t->d_t_last when set:
 * adds into g_sdf (SDF gradient w.r.t. the values passed to forward; the density gradient in
 * the alphamask stage goes into grads) and into grads (the flat gradient base). */
int esr_trace_bwd(struct esr_trace *t, const struct esr_model *m, float *g_sdf, float *grads,
                  const float *d_rgb3, const float *d_lin3);

/* Per-ray extras of the last forward for rendering (any output may be NULL): expected distance,
 * composited unit SDF normal, opacity. The normals are the gradient of normal_sdf (values on the
 * SDF grid, see esr_model_normal_sdf) at the kept samples, or of the marched SDF when NULL. */
void esr_trace_extras(struct esr_trace *t, const float *normal_sdf, float *depth, float *normal3,
                      float *opacity);

#ifdef __cplusplus
}
#endif
#endif
