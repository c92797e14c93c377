/* Trace layer 1 of 3, "march": rays -> samples -> geometry -> alpha -> weights -> kept list.
 *
 *   rays (per-ray t range and random stream) --sampler + mask cache--> samples
 *   --> SDF value and point gradient in one fused pass (or DVGO density) --> NeuS alpha from the
 *   mid-point section estimate (or density alpha) --> weights and final transmittance
 *   --> the kept list: samples whose weight exceeds ESR_COMPOSITE_THRES, the only ones a colour
 *   head is evaluated on (a fine-stage ray marches ~28 samples but keeps ~3-5).
 *
 * It knows no model: the caller describes the geometry (grid, values, alpha model, step) in
 * struct esr_march_geometry. Layer 2 (model/point_fields.h) evaluates heads on the kept rows;
 * layer 3 is compositing (volume/composite.h, which reads kept rows through `kept_row`). The
 * primary rays of training and rendering are one composition of the three (model/trace.h);
 * secondary rays will be another.
 *
 * Backward: the caller fills d_alpha (per sample, from the composite's backward), then
 * esr_march_bwd turns it into the gradient of the grid values (fused value + point-gradient
 * adjoint for the SDF). Buffers grow to the high-water mark of the first batches and are reused. */
#ifndef ESR_VOLUME_MARCH_H
#define ESR_VOLUME_MARCH_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"
#include "fields/mask.h"
#include "volume/sampler.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_march_alpha { ESR_MARCH_DENSITY, ESR_MARCH_NEUS };

struct esr_march_geometry {
    enum esr_march_alpha alpha;
    const struct esr_grid *grid;  /* 1-channel density or SDF lattice */
    const float *values;          /* its values (the SDF the renderer sees) */
    float density_shift;          /* ESR_MARCH_DENSITY: DVGO act_shift */
    float density_step_vox;       /*   and its alpha's step in voxels */
    float inv_s;                  /* ESR_MARCH_NEUS: NeuS s */
    float step;                   /* sample spacing along t (world units, unit directions) */
    const struct esr_mask *mask;  /* mask cache, or NULL: every voxel possibly occupied */
    float bmin[3], bmax[3];       /* samples only inside this box */
};

struct esr_march_rays {
    int n;
    const float *origins, *dirs;  /* [n * 3]; dirs unit length */
    const float *t_min, *t_max;   /* [n] each, or NULL: from 0 / unbounded (the box clips) */
    const uint64_t *streams;      /* [n] jitter stream of each ray, or NULL: the ray index */
    uint64_t seed;
    int jitter;                   /* 1: jittered sample positions (training) */
};

struct esr_march {
    int train;                    /* 1: keep what backward needs */
    int max_rays;
    size_t cap_samples, cap_kept;
    struct esr_samples smp;       /* positions, t, ray of every sample, grouped by ray */
    /* per sample [cap_samples] (x3 where noted) */
    float *f, *grad3, *fp, *fn, *alpha, *weight, *d_alpha, *d_f, *d_grad3;
    uint32_t *kept_row;           /* kept row of a kept sample (undefined for the others) */
    /* per ray [max_rays] */
    float *t_last;                /* final transmittance */
    size_t *kept_start;           /* [max_rays + 1]: kept rows of ray r are [start[r], start[r+1]) */
    /* kept rows [cap_kept], in sample order (so grouped by ray) */
    size_t n_kept;
    uint32_t *kidx;               /* sample index of kept row k */
    int32_t *kray;                /* ray of kept row k */
    float *kpos3, *kdir3;         /* its position and ray direction */
    /* the last forward */
    int n_rays;
    const float *dirs;
    struct esr_march_geometry geom;
};

/* Workspace for batches of up to max_rays rays. */
int esr_march_init(struct esr_march *mc, int max_rays, int train);
void esr_march_free(struct esr_march *mc);

/* Forward: fills samples, alpha, weights, t_last and the kept list (compacted in parallel over
 * rays). The geometry and the rays' direction array must stay alive until the backward. */
int esr_march_fwd(struct esr_march *mc, const struct esr_march_geometry *geom,
                  const struct esr_march_rays *rays);
/* Clears d_alpha for a backward pass (composites then add into it). */
void esr_march_zero_d_alpha(struct esr_march *mc);
/* Backward of the last forward given mc->d_alpha: ADDS d loss/d values into g_values (the grid
 * of the geometry passed to the forward). */
void esr_march_bwd(struct esr_march *mc, float *g_values);

/* The kept row of ray r with the largest weight (the ray's surface sample): its weight, and the
 * row in *row; 0 (row untouched) when the ray kept no sample. */
float esr_march_strongest_kept(const struct esr_march *mc, int r, size_t *row);

/* Composite arguments over the last forward for `channels` values per kept row, with bg NULL, a
 * constant (C floats) or one per ray (bg_per_ray). Feed them to esr_composite_fwd/bwd. */
struct esr_composite_args;
void esr_march_composite_args(const struct esr_march *mc, const float *kept_values, int channels,
                              const float *bg, int bg_per_ray, struct esr_composite_args *out);

#ifdef __cplusplus
}
#endif
#endif
