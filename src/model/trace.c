/* Batch forward/backward through the model (see trace.h): buffers, geometry (sampling, SDF or
 * density alpha, weights, pruning), compositing and the geometry backward. The colour heads of
 * the three stages are in trace_heads.c. */
#include "model/trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/density.h"
#include "fields/grid.h"
#include "volume/composite.h"
#include "volume/neus.h"
#include "model/trace_heads.h"

#define TRACE_MAX_PER_RAY 2048

static void free_samples(struct esr_trace *t)
{
    float **bufs[] = {&t->f,          &t->grad3,     &t->fp,          &t->fn,
                      &t->alpha,      &t->weight,    &t->d_alpha,     &t->d_f,
                      &t->d_grad3,    &t->val_tone3, &t->val_lin3,    &t->d_val_tone3,
                      &t->d_val_lin3};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++) {
        free(*bufs[i]);
        *bufs[i] = NULL;
    }
    esr_samples_free(&t->smp);
    t->cap_samples = 0;
}

/* (Re)allocates the per-sample buffers for `cap` samples. */
static int grow_samples(struct esr_trace *t, size_t cap)
{
    free_samples(t);
    ESR_TRY(esr_samples_alloc(&t->smp, cap, t->max_rays));
    float **one[] = {&t->f, &t->fp, &t->fn, &t->alpha, &t->weight, &t->d_alpha, &t->d_f};
    float **three[] = {&t->grad3, &t->d_grad3, &t->val_tone3, &t->val_lin3, &t->d_val_tone3,
                       &t->d_val_lin3};
    int ok = 1;
    for (size_t i = 0; i < sizeof one / sizeof one[0]; i++)
        ok &= (*one[i] = malloc(cap * sizeof(float))) != NULL;
    for (size_t i = 0; i < sizeof three / sizeof three[0]; i++)
        ok &= (*three[i] = malloc(cap * 3 * sizeof(float))) != NULL;
    if (!ok) {
        free_samples(t);
        return ESR_FAIL("trace: out of memory for %zu ray samples", cap);
    }
    t->cap_samples = cap;
    return ESR_OK;
}

int esr_trace_init(struct esr_trace *t, const struct esr_model *m, int max_rays, int train)
{
    memset(t, 0, sizeof(*t));
    if (max_rays < 1)
        return ESR_FAIL("trace: max_rays %d must be >= 1", max_rays);
    t->train = train;
    t->max_rays = max_rays;
    esr_trace_heads_dims(t, m);
    float **per_ray[] = {&t->t_last, &t->rgb3, &t->lin_rgb3};
    int ok = 1;
    for (size_t i = 0; i < sizeof per_ray / sizeof per_ray[0]; i++)
        ok &= (*per_ray[i] = malloc((size_t)max_rays * 3 * sizeof(float))) != NULL;
    int rc = ok ? ESR_OK : ESR_FAIL("trace: out of memory for %d rays", max_rays);
    if (rc == ESR_OK)
        rc = grow_samples(t, (size_t)max_rays * 64);
    if (rc == ESR_OK)
        rc = esr_trace_heads_grow(t, m, (size_t)max_rays * 8);
    if (rc != ESR_OK)
        esr_trace_free(t);
    return rc;
}

void esr_trace_free(struct esr_trace *t)
{
    free_samples(t);
    esr_trace_heads_free(t);
    free(t->t_last);
    free(t->rgb3);
    free(t->lin_rgb3);
    memset(t, 0, sizeof(*t));
}

static float stage_step(const struct esr_model *m)
{
    if (m->stage == ESR_STAGE_ALPHAMASK)
        return m->cfg.alphamask.step_vox * esr_grid_voxel_size(&m->density, 0);
    const struct esr_stage_config *s = m->stage == ESR_STAGE_COARSE ? &m->cfg.coarse : &m->cfg.fine;
    return s->step_vox * esr_grid_voxel_size(&m->sdf, 0);
}

/* Marches the rays, growing the sample buffers when a batch needs more. */
static int march(struct esr_trace *t, const struct esr_model *m, const float *origins,
                 const float *dirs, int n, uint64_t seed)
{
    struct esr_sample_params sp;
    memset(&sp, 0, sizeof sp);
    for (int a = 0; a < 3; a++) {
        sp.bmin[a] = m->scene_min[a];
        sp.bmax[a] = m->scene_max[a];
    }
    sp.near = 0.0f;
    sp.far = 1e30f;
    sp.step = t->step;
    sp.jitter = t->train;
    sp.seed = seed;
    sp.max_per_ray = TRACE_MAX_PER_RAY;
    sp.mask = m->has_mask ? &m->mask : NULL;
    if (esr_sample_rays(&sp, origins, dirs, n, &t->smp) == ESR_OK)
        return ESR_OK;
    if (t->smp.count <= t->cap_samples)
        return ESR_ERR;
    esr_error_clear();
    ESR_TRY(grow_samples(t, t->smp.count + t->smp.count / 4));
    return esr_sample_rays(&sp, origins, dirs, n, &t->smp);
}

/* alpha of every sample: DVGO density (alphamask) or NeuS from the SDF mid-point section. */
static void sample_alpha(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                         const float *dirs)
{
    size_t n = t->smp.count;
    const float *w = m->params.w;
    if (m->stage == ESR_STAGE_ALPHAMASK) {
        esr_grid_sample_fwd(&m->density, w + m->density_off, t->smp.pos, n, t->f);
        esr_density_alpha_batch_fwd(t->f, n, m->density_shift, m->cfg.alphamask.step_vox, t->alpha);
        return;
    }
    esr_grid_sample_fwd(&m->sdf, sdf, t->smp.pos, n, t->f);
    esr_grid_sample_dpoint(&m->sdf, sdf, 0, t->smp.pos, n, t->grad3);
    const float dt = t->step, s = m->inv_s;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = dirs + (size_t)t->smp.ray[i] * 3, *g = t->grad3 + i * 3;
        esr_neus_section_fwd(t->f[i], d[0] * g[0] + d[1] * g[1] + d[2] * g[2], dt, 1.0f, &t->fp[i],
                             &t->fn[i]);
        t->alpha[i] = esr_neus_alpha_fwd(t->fp[i], t->fn[i], s);
    }
}

/* Compacts the samples whose composite weight is above the threshold (only they pay the colour
 * heads), in sample order, so off-ray samples come first. */
static int keep_samples(struct esr_trace *t, const struct esr_model *m, const float *dirs)
{
    size_t n = t->smp.count, k = 0, k_off = 0;
    for (size_t i = 0; i < n; i++)
        k += esr_composite_keep(t->weight[i], ESR_COMPOSITE_THRES);
    if (k > t->cap_kept)
        ESR_TRY(esr_trace_heads_grow(t, m, k + k / 4));
    k = 0;
    for (size_t i = 0; i < n; i++) {
        if (!esr_composite_keep(t->weight[i], ESR_COMPOSITE_THRES))
            continue;
        k_off += t->smp.ray[i] < t->n_off;
        t->kidx[k++] = (uint32_t)i;
    }
    t->n_kept = k;
    t->n_kept_off = k_off;
#pragma omp parallel for schedule(static)
    for (size_t j = 0; j < k; j++) {
        size_t i = t->kidx[j];
        const float *d = dirs + (size_t)t->smp.ray[i] * 3;
        for (int a = 0; a < 3; a++) {
            t->kpos3[j * 3 + a] = t->smp.pos[i * 3 + a];
            t->kdir3[j * 3 + a] = d[a];
        }
    }
    return ESR_OK;
}

static void composite_args(const struct esr_trace *t, struct esr_composite_args *a,
                           const float *values, int channels, const float *bg)
{
    a->n_rays = t->n_rays;
    a->ray_start = t->smp.ray_start;
    a->alpha = t->alpha;
    a->weight = t->weight;
    a->t_last = t->t_last;
    a->thres = ESR_COMPOSITE_THRES;
    a->channels = channels;
    a->values = values;
    a->bg = bg;
    a->bg_per_ray = 0;
}

static const float white[3] = {1.0f, 1.0f, 1.0f};

int esr_trace_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                  const float *origins, const float *dirs, int n, int n_off, uint64_t seed)
{
    if (n < 0 || n > t->max_rays || n_off < 0 || n_off > n)
        return ESR_FAIL("trace: %d rays (%d off) for a workspace of %d", n, n_off, t->max_rays);
    t->n_rays = n;
    t->n_off = n_off;
    t->dirs = dirs;
    t->step = stage_step(m);
    ESR_TRY(march(t, m, origins, dirs, n, seed));
    sample_alpha(t, m, sdf, dirs);
    esr_composite_weights(n, t->smp.ray_start, t->alpha, ESR_COMPOSITE_THRES, t->weight, t->t_last);
    ESR_TRY(keep_samples(t, m, dirs));
    ESR_TRY(esr_trace_heads_fwd(t, m, sdf));
    struct esr_composite_args a;
    composite_args(t, &a, t->val_tone3, 3, white);
    esr_composite_fwd(&a, t->rgb3);
    if (m->stage == ESR_STAGE_FINE) {
        composite_args(t, &a, t->val_lin3, 3, white);
        esr_composite_fwd(&a, t->lin_rgb3);
    } else {
        memcpy(t->lin_rgb3, t->rgb3, (size_t)n * 3 * sizeof(float));
    }
    return ESR_OK;
}

/* d alpha -> d density (alphamask) or d SDF value/gradient -> SDF grid. */
static void alpha_bwd(struct esr_trace *t, const struct esr_model *m, float *g_sdf, float *grads)
{
    size_t n = t->smp.count;
    if (m->stage == ESR_STAGE_ALPHAMASK) {
        memset(t->d_f, 0, n * sizeof(float));
        esr_density_alpha_batch_bwd(t->f, n, m->density_shift, m->cfg.alphamask.step_vox,
                                    t->d_alpha, t->d_f);
        esr_grid_sample_bwd(&m->density, t->smp.pos, n, t->d_f, grads + m->density_off);
        return;
    }
    const float dt = t->step, s = m->inv_s;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = t->dirs + (size_t)t->smp.ray[i] * 3, *g = t->grad3 + i * 3;
        float c = d[0] * g[0] + d[1] * g[1] + d[2] * g[2], dp, dn, dc;
        esr_neus_alpha_bwd(t->fp[i], t->fn[i], s, t->d_alpha[i], &dp, &dn, NULL);
        esr_neus_section_bwd(c, dt, 1.0f, dp, dn, &t->d_f[i], &dc);
        for (int a = 0; a < 3; a++)
            t->d_grad3[i * 3 + a] = dc * d[a];
    }
    esr_grid_sample_bwd(&m->sdf, t->smp.pos, n, t->d_f, g_sdf);
    esr_grid_sample_dpoint_bwd(&m->sdf, 0, t->smp.pos, n, t->d_grad3, g_sdf);
}

int esr_trace_bwd(struct esr_trace *t, const struct esr_model *m, const float *sdf, float *g_sdf,
                  float *grads, const float *d_rgb3, const float *d_lin3)
{
    size_t n = t->smp.count;
    memset(t->d_alpha, 0, n * sizeof(float));
    memset(t->d_val_tone3, 0, n * 3 * sizeof(float));
    struct esr_composite_args a;
    composite_args(t, &a, t->val_tone3, 3, white);
    esr_composite_bwd(&a, d_rgb3, t->d_alpha, t->d_val_tone3);
    if (m->stage == ESR_STAGE_FINE) {
        memset(t->d_val_lin3, 0, n * 3 * sizeof(float));
        if (d_lin3) {
            composite_args(t, &a, t->val_lin3, 3, white);
            esr_composite_bwd(&a, d_lin3, t->d_alpha, t->d_val_lin3);
        }
    }
    ESR_TRY(esr_trace_heads_bwd(t, m, sdf, g_sdf, grads));
    alpha_bwd(t, m, g_sdf, grads);
    return ESR_OK;
}

void esr_trace_extras(const struct esr_trace *t, const struct esr_model *m, const float *sdf,
                      float *depth, float *normal3, float *opacity)
{
    (void)sdf;
    struct esr_composite_args a;
    if (depth) {
        composite_args(t, &a, t->smp.t, 1, NULL);
        esr_composite_fwd(&a, depth);
        for (int r = 0; r < t->n_rays; r++)
            depth[r] /= fmaxf(1.0f - t->t_last[r], 1e-6f);
    }
    if (normal3 && m->stage != ESR_STAGE_ALPHAMASK) {
        float *nrm = t->d_val_lin3; /* free in inference */
        size_t n = t->smp.count;
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++) {
            const float *g = t->grad3 + i * 3;
            float len = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) + 1e-8f;
            for (int c = 0; c < 3; c++)
                nrm[i * 3 + c] = g[c] / len;
        }
        composite_args(t, &a, nrm, 3, NULL);
        esr_composite_fwd(&a, normal3);
    } else if (normal3) {
        memset(normal3, 0, (size_t)t->n_rays * 3 * sizeof(float));
    }
    if (opacity)
        for (int r = 0; r < t->n_rays; r++)
            opacity[r] = 1.0f - t->t_last[r];
}
