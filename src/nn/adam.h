/* Adam over a flat parameter range (nn/params.h): one loop, its own learning rate per range, so
 * a model with grids and MLPs steps each component's range with its own lr and schedule.
 *
 * Sparse variant (DVGO/Voxurf "masked Adam"): an entry whose gradient is exactly 0 this step is
 * left completely alone: its moments do not decay and its value does not move. Voxel grids see
 * gradients only where rays passed, and plain Adam would keep moving untouched voxels on stale
 * momentum and decay their moments. Bias correction uses the range's global step count t for every
 * entry, as DVGO does (per-entry step counts would cost another buffer for no measured gain). */
#ifndef ESR_NN_ADAM_H
#define ESR_NN_ADAM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

struct esr_adam_hp {
    float lr;     /* step size for this range (after schedule) */
    float beta1;  /* 0.9 */
    float beta2;  /* 0.999 (DVGO/Voxurf use 0.99 for grids) */
    float eps;    /* 1e-8 (1e-15 in tiny-cuda-nn) */
    int sparse;   /* 1 = skip entries whose gradient is exactly zero */
};

/* Moments for a whole flat parameter buffer: same layout as esr_nn_params.w. */
struct esr_adam {
    float *m;
    float *v;
    size_t count;
};

/* Zeroed moments for count parameters. */
int esr_adam_init(struct esr_adam *a, size_t count);
void esr_adam_free(struct esr_adam *a);
/* Grows the moments (new entries zero) after the parameter buffer grew. */
int esr_adam_resize(struct esr_adam *a, size_t count);

/* One Adam step (t >= 1, the 1-based step count of this range) on entries [offset, offset+n)
 * of w, using g and the moments at the same offsets:
 *   m = b1 m + (1-b1) g;  v = b2 v + (1-b2) g^2;
 *   w -= lr * (m / (1-b1^t)) / (sqrt(v / (1-b2^t)) + eps).
 * Gradients are read only (zero them separately). Parallel, deterministic. */
void esr_adam_step(const struct esr_adam_hp *hp, long t, struct esr_adam *a, float *w,
                   const float *g, size_t offset, size_t n);

#ifdef __cplusplus
}
#endif
#endif
