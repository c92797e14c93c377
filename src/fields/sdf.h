/* Whole-grid operations on SDF (and other) grids: sphere initialisation, separable Gaussian
 * smoothing with its adjoint, resampling to a new resolution, and the total-variation regulariser.
 * All operate on channel-last grids described by struct esr_grid (fields/grid.h). */
#ifndef ESR_FIELDS_SDF_H
#define ESR_FIELDS_SDF_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

/* data = |x_n| - radius for every voxel, x_n the voxel position mapped to [-1,1]^3 by the grid's
 * box (METHOD.md coarse stage: radius 1). g must have 1 channel. */
int esr_sdf_init_sphere(const struct esr_grid *g, float *data, float radius);

/* Separable Gaussian smoothing, taps x = -ksize/2..ksize/2 with weights exp(-x^2/(2 sigma^2))
 * normalised to sum 1 (Voxurf: ksize 5, sigma 0.8), applied along x, y, z per channel.
 * Beyond the box the field is extended by point reflection about the boundary voxel
 * (f(-j) = 2 f(0) - f(j)), so constant and linear fields pass through unchanged everywhere
 * (Voxurf pads by replication, which bends an SDF's slope at the box faces).
 * dst and scratch hold esr_grid_count(g) floats each; src may equal dst. Requires ksize odd,
 * 1 <= ksize, every n > ksize/2, sigma > 0. */
int esr_grid_smooth_fwd(const struct esr_grid *g, const float *src, float *dst, float *scratch,
                        int ksize, float sigma);
/* Adjoint of esr_grid_smooth_fwd (the operator is linear): d_src += S^T d_dst. d_dst is
 * consumed as scratch space (overwritten). scratch as above. Lets the renderer see the smoothed
 * SDF while the optimiser updates the raw one. */
int esr_grid_smooth_bwd(const struct esr_grid *g, float *d_dst, float *d_src, float *scratch,
                        int ksize, float sigma);

/* dst (lattice dst_g, same channel count) = trilinear interpolation of src at every dst voxel
 * position; used to grow the SDF / feature grids between stages. Exact for linear fields. */
int esr_grid_resample(const struct esr_grid *src_g, const float *src, const struct esr_grid *dst_g,
                      float *dst);

/* Total variation with DVGO's Huber form: loss = w / V * sum over axis-neighbour pairs (p, q)
 * and channels of h(v_p - v_q), h(d) = d^2/2 for |d| <= 1 else |d| - 1/2, V = voxel count.
 * Adds d loss / d v into grad; *loss (may be NULL) receives the loss. Parallel and deterministic
 * (per-plane partial sums added in order). */
int esr_grid_tv_add_grad(const struct esr_grid *g, const float *data, float weight, float *grad,
                         double *loss);

/* Floats of work space esr_sdf_grad_tv_add_grad needs: 8 * esr_grid_voxels(g). */
size_t esr_sdf_grad_tv_work(const struct esr_grid *g);
/* Voxurf-style smoothed-gradient TV: G = D(S(f)), with S the Gaussian smoothing above
 * (ksize, sigma; ksize 1 = none) and D the central-difference gradient (one-sided at the box
 * faces, in world units), regularised by esr_grid_tv_add_grad on the 3-channel field G with
 * weight. Adds the exact gradient S^T D^T dG into grad; *loss (may be NULL) gets the
 * loss. g must have 1 channel; work holds esr_sdf_grad_tv_work(g) floats. */
int esr_sdf_grad_tv_add_grad(const struct esr_grid *g, const float *sdf, float weight, int ksize,
                             float sigma, float *work, float *grad, double *loss);

#ifdef __cplusplus
}
#endif
#endif
