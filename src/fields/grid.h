/* Dense voxel grids: C channels on an (nx, ny, nz) lattice whose corner voxels sit exactly on the
 * world bounding box (DVGO's align_corners=True convention), stored channels-last:
 *     data[((iz * ny + iy) * nx + ix) * C + c]
 * The grid struct only describes the lattice; the values live in a caller-owned flat buffer
 * (normally a range of struct esr_nn_params), so one optimiser loop covers every parameter.
 *
 * Per-point trilinear maths is in fields/trilerp.h (pure, per element, C/C++ common subset);
 * this file holds the batch loops over it. Points outside the box are CLAMPED to the box (the
 * value is the boundary value and the derivative w.r.t. the point along a clamped axis is 0).
 *
 * Backward passes are deterministic for any thread count without atomics: each thread owns a
 * range of z-planes of the gradient buffer and scans all points, scattering only into its own
 * planes, so every gradient entry receives its contributions in point order. (A GPU backend
 * would use atomics instead; the per-element scatter helpers take the plane range as input.) */
#ifndef ESR_FIELDS_GRID_H
#define ESR_FIELDS_GRID_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

struct esr_grid {
    int channels;    /* C >= 1 */
    int nx, ny, nz;  /* lattice points per axis, each >= 2 */
    float bmin[3];   /* world position of voxel (0,0,0) */
    float bmax[3];   /* world position of voxel (nx-1, ny-1, nz-1) */
};

/* Fills *g after checking the arguments (channels >= 1, every n >= 2, bmax > bmin). */
int esr_grid_init(struct esr_grid *g, int channels, int nx, int ny, int nz, const float bmin[3],
                  const float bmax[3]);
/* Number of floats the grid's values occupy: nx*ny*nz*C. */
size_t esr_grid_count(const struct esr_grid *g);
/* Number of lattice points nx*ny*nz. */
size_t esr_grid_voxels(const struct esr_grid *g);
/* World-space spacing between lattice points along axis a (0..2). */
float esr_grid_voxel_size(const struct esr_grid *g, int axis);
/* Index of lattice point (x, y, z) among the nx*ny*nz (x fastest). */
static inline size_t esr_grid_index(const struct esr_grid *g, int x, int y, int z)
{
    return ((size_t)z * (size_t)g->ny + (size_t)y) * (size_t)g->nx + (size_t)x;
}
/* World position of lattice point (ix, iy, iz). */
void esr_grid_voxel_pos(const struct esr_grid *g, int ix, int iy, int iz, float pos[3]);

/* out[i*C + c] = trilinear value of channel c at pts[i*3 .. i*3+2], for i < n. Parallel. */
void esr_grid_sample_fwd(const struct esr_grid *g, const float *data, const float *pts, size_t n,
                         float *out);
/* Adjoint of esr_grid_sample_fwd: grad[...] += sum_i dvalue_i/ddata * d_out[i*C + c].
 * Accumulates (never overwrites); deterministic (z-plane ownership, see above). */
void esr_grid_sample_bwd(const struct esr_grid *g, const float *pts, size_t n, const float *d_out,
                         float *grad);
/* Spatial gradient of channel `ch` of the trilinear field at each point:
 * dpts[i*3 + a] = d value_ch / d pts_a (0 along clamped axes). Used for analytic SDF normals. */
void esr_grid_sample_dpoint(const struct esr_grid *g, const float *data, int ch, const float *pts,
                            size_t n, float *dpts);
/* For a 1-channel grid (the SDF): value and spatial gradient in one pass, out[i] and
 * dpts[i*3 + a]; same results as esr_grid_sample_fwd + esr_grid_sample_dpoint, cheaper. */
void esr_grid_sample_value_dpoint(const struct esr_grid *g, const float *data, const float *pts,
                                  size_t n, float *out, float *dpts);
/* Adjoint of esr_grid_sample_value_dpoint: grad += (d value/d data)^T d_out
 * + (d dpts/d data)^T d_dpts in one pass (1-channel grid). Accumulates, deterministic. */
void esr_grid_sample_value_dpoint_bwd(const struct esr_grid *g, const float *pts, size_t n,
                                      const float *d_out, const float *d_dpts, float *grad);
/* Adjoint of esr_grid_sample_dpoint w.r.t. the grid values: for channel ch,
 * grad += sum_i sum_a d_dpts[i*3+a] * d(dvalue/dpts_a)/ddata  (the point-gradient is linear in
 * the grid values). Accumulates, deterministic. Lets a loss on normals train the SDF grid. */
void esr_grid_sample_dpoint_bwd(const struct esr_grid *g, int ch, const float *pts, size_t n,
                                const float *d_dpts, float *grad);

/* Inside an OpenMP parallel region: the z-planes [*lo, *hi) of g that the calling thread owns in
 * a deterministic backward pass (contiguous, disjoint, covering 0..nz-1 over the team). */
void esr_grid_own_planes(const struct esr_grid *g, int *lo, int *hi);

#ifdef __cplusplus
}
#endif
#endif
