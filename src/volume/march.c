/* Trace layer 1: marching, alpha, weights and the kept list (see march.h). */
#include "volume/march.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "fields/density.h"
#include "volume/composite.h"
#include "volume/neus.h"


static void free_samples(struct esr_march *mc)
{
    float **bufs[] = {&mc->f,     &mc->grad3,  &mc->fp,      &mc->fn,  &mc->alpha,
                      &mc->weight, &mc->d_alpha, &mc->d_f, &mc->d_grad3};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++) {
        free(*bufs[i]);
        *bufs[i] = NULL;
    }
    free(mc->kept_row);
    mc->kept_row = NULL;
    esr_samples_free(&mc->smp);
    mc->cap_samples = 0;
}

/* (Re)allocates the per-sample buffers for `cap` samples. */
static int grow_samples(struct esr_march *mc, size_t cap)
{
    free_samples(mc);
    ESR_TRY(esr_samples_alloc(&mc->smp, cap, mc->max_rays));
    float **one[] = {&mc->f, &mc->fp, &mc->fn, &mc->alpha, &mc->weight, &mc->d_alpha, &mc->d_f};
    float **three[] = {&mc->grad3, &mc->d_grad3};
    int ok = (mc->kept_row = malloc(cap * sizeof(uint32_t))) != NULL;
    for (size_t i = 0; i < sizeof one / sizeof one[0]; i++)
        ok &= (*one[i] = malloc(cap * sizeof(float))) != NULL;
    for (size_t i = 0; i < sizeof three / sizeof three[0]; i++)
        ok &= (*three[i] = malloc(cap * 3 * sizeof(float))) != NULL;
    if (!ok) {
        free_samples(mc);
        return ESR_FAIL("march: out of memory for %zu ray samples", cap);
    }
    mc->cap_samples = cap;
    return ESR_OK;
}

static void free_kept(struct esr_march *mc)
{
    free(mc->kidx);
    free(mc->kray);
    free(mc->kpos3);
    free(mc->kdir3);
    mc->kidx = NULL;
    mc->kray = NULL;
    mc->kpos3 = mc->kdir3 = NULL;
    mc->cap_kept = 0;
}

static int grow_kept(struct esr_march *mc, size_t cap)
{
    free_kept(mc);
    mc->kidx = malloc(cap * sizeof(uint32_t));
    mc->kray = malloc(cap * sizeof(int32_t));
    mc->kpos3 = malloc(cap * 3 * sizeof(float));
    mc->kdir3 = malloc(cap * 3 * sizeof(float));
    if (!mc->kidx || !mc->kray || !mc->kpos3 || !mc->kdir3) {
        free_kept(mc);
        return ESR_FAIL("march: out of memory for %zu kept samples", cap);
    }
    mc->cap_kept = cap;
    return ESR_OK;
}

int esr_march_init(struct esr_march *mc, int max_rays, int train)
{
    memset(mc, 0, sizeof(*mc));
    if (max_rays < 1)
        return ESR_FAIL("march: max_rays %d must be >= 1", max_rays);
    mc->train = train;
    mc->max_rays = max_rays;
    mc->t_last = malloc((size_t)max_rays * sizeof(float));
    mc->kept_start = malloc(((size_t)max_rays + 1) * sizeof(size_t));
    int rc = mc->t_last && mc->kept_start ? ESR_OK
                                          : ESR_FAIL("march: out of memory for %d rays", max_rays);
    if (rc == ESR_OK)
        rc = grow_samples(mc, (size_t)max_rays * 64);
    if (rc == ESR_OK)
        rc = grow_kept(mc, (size_t)max_rays * 8);
    if (rc != ESR_OK)
        esr_march_free(mc);
    return rc;
}

void esr_march_free(struct esr_march *mc)
{
    free_samples(mc);
    free_kept(mc);
    free(mc->t_last);
    free(mc->kept_start);
    memset(mc, 0, sizeof(*mc));
}

/* Samples of every ray, growing the buffers when a batch needs more. */
static int sample(struct esr_march *mc, const struct esr_march_geometry *g,
                  const struct esr_march_rays *r)
{
    struct esr_sample_params sp;
    memset(&sp, 0, sizeof sp);
    for (int a = 0; a < 3; a++) {
        sp.bmin[a] = g->bmin[a];
        sp.bmax[a] = g->bmax[a];
    }
    sp.near = 0.0f;
    sp.far = 1e30f;
    sp.step = g->step;
    sp.jitter = r->jitter;
    sp.seed = r->seed;
    /* no cap: a ray is never cut off (a fixed 2048 cut rays at res 512 and step_vox under
     * 0.43, letting the background through the rest); the buffers grow to what a batch needs */
    sp.max_per_ray = 0;
    sp.mask = g->mask;
    sp.t_min = r->t_min;
    sp.t_max = r->t_max;
    sp.streams = r->streams;
    if (esr_sample_rays(&sp, r->origins, r->dirs, r->n, &mc->smp) == ESR_OK)
        return ESR_OK;
    if (mc->smp.count <= mc->cap_samples)
        return ESR_ERR;
    esr_error_clear();
    ESR_TRY(grow_samples(mc, mc->smp.count + mc->smp.count / 4));
    return esr_sample_rays(&sp, r->origins, r->dirs, r->n, &mc->smp);
}

/* alpha of every sample: DVGO density, or NeuS from the SDF value and point gradient (one fused
 * grid pass) through the mid-point section estimate. */
static void sample_alpha(struct esr_march *mc, const struct esr_march_geometry *g)
{
    const size_t n = mc->smp.count;
    if (g->alpha == ESR_MARCH_DENSITY) {
        esr_grid_sample_fwd(g->grid, g->values, mc->smp.pos, n, mc->f);
        esr_density_alpha_batch_fwd(mc->f, n, g->density_shift, g->density_step_vox, mc->alpha);
        return;
    }
    esr_grid_sample_value_dpoint(g->grid, g->values, mc->smp.pos, n, mc->f, mc->grad3);
    const float dt = g->step, s = g->inv_s;
    const float *dirs = mc->dirs;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = dirs + (size_t)mc->smp.ray[i] * 3, *gr = mc->grad3 + i * 3;
        esr_neus_section_fwd(mc->f[i], d[0] * gr[0] + d[1] * gr[1] + d[2] * gr[2], dt, 1.0f,
                             &mc->fp[i], &mc->fn[i]);
        mc->alpha[i] = esr_neus_alpha_fwd(mc->fp[i], mc->fn[i], s);
    }
}

/* The kept list: per-ray counts, a prefix sum, then each ray writes its own rows, so the list is
 * in sample order (grouped by ray) for any thread count. */
static int keep_samples(struct esr_march *mc)
{
    const int nr = mc->n_rays;
    const size_t *rs = mc->smp.ray_start;
    size_t *ks = mc->kept_start;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < nr; r++) {
        size_t k = 0;
        for (size_t i = rs[r]; i < rs[r + 1]; i++)
            k += esr_composite_keep(mc->weight[i], ESR_COMPOSITE_THRES);
        ks[r + 1] = k;
    }
    ks[0] = 0;
    for (int r = 0; r < nr; r++)
        ks[r + 1] += ks[r];
    const size_t nk = ks[nr];
    if (nk > mc->cap_kept)
        ESR_TRY(grow_kept(mc, nk + nk / 4));
    mc->n_kept = nk;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < nr; r++) {
        size_t k = ks[r];
        const float *d = mc->dirs + (size_t)r * 3;
        for (size_t i = rs[r]; i < rs[r + 1]; i++) {
            if (!esr_composite_keep(mc->weight[i], ESR_COMPOSITE_THRES))
                continue;
            mc->kept_row[i] = (uint32_t)k;
            mc->kidx[k] = (uint32_t)i;
            mc->kray[k] = r;
            for (int a = 0; a < 3; a++) {
                mc->kpos3[k * 3 + a] = mc->smp.pos[i * 3 + a];
                mc->kdir3[k * 3 + a] = d[a];
            }
            k++;
        }
    }
    return ESR_OK;
}

static int march_fwd_run(struct esr_march *mc, const struct esr_march_geometry *geom,
                         const struct esr_march_rays *rays);

int esr_march_fwd(struct esr_march *mc, const struct esr_march_geometry *geom,
                  const struct esr_march_rays *rays)
{
    esr_prof_enter(ESR_PROF_MARCH);
    const int rc = march_fwd_run(mc, geom, rays);
    esr_prof_exit(ESR_PROF_MARCH);
    return rc;
}

static int march_fwd_run(struct esr_march *mc, const struct esr_march_geometry *geom,
                         const struct esr_march_rays *rays)
{
    if (rays->n < 0 || rays->n > mc->max_rays)
        return ESR_FAIL("march: %d rays for a workspace of %d", rays->n, mc->max_rays);
    if (!(geom->step > 0.0f) || geom->grid->channels != 1)
        return ESR_FAIL("march: bad geometry (step %g, %d grid channels)", (double)geom->step,
                        geom->grid->channels);
    mc->n_rays = rays->n;
    mc->dirs = rays->dirs;
    mc->geom = *geom;
    ESR_TRY(sample(mc, geom, rays));
    sample_alpha(mc, geom);
    esr_composite_weights(rays->n, mc->smp.ray_start, mc->alpha, ESR_COMPOSITE_THRES, mc->weight,
                          mc->t_last);
    return keep_samples(mc);
}

void esr_march_zero_d_alpha(struct esr_march *mc)
{
    memset(mc->d_alpha, 0, mc->smp.count * sizeof(float));
}

static void march_bwd_run(struct esr_march *mc, float *g_values);

void esr_march_bwd(struct esr_march *mc, float *g_values)
{
    esr_prof_enter(ESR_PROF_MARCH);
    march_bwd_run(mc, g_values);
    esr_prof_exit(ESR_PROF_MARCH);
}

static void march_bwd_run(struct esr_march *mc, float *g_values)
{
    const struct esr_march_geometry *g = &mc->geom;
    const size_t n = mc->smp.count;
    if (g->alpha == ESR_MARCH_DENSITY) {
        memset(mc->d_f, 0, n * sizeof(float));
        esr_density_alpha_batch_bwd(mc->f, n, g->density_shift, g->density_step_vox, mc->d_alpha,
                                    mc->d_f);
        esr_grid_sample_bwd(g->grid, mc->smp.pos, n, mc->d_f, g_values);
        return;
    }
    const float dt = g->step, s = g->inv_s;
    const float *dirs = mc->dirs;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        const float *d = dirs + (size_t)mc->smp.ray[i] * 3, *gr = mc->grad3 + i * 3;
        float c = d[0] * gr[0] + d[1] * gr[1] + d[2] * gr[2], dp, dn, dc;
        esr_neus_alpha_bwd(mc->fp[i], mc->fn[i], s, mc->d_alpha[i], &dp, &dn, NULL);
        esr_neus_section_bwd(c, dt, 1.0f, dp, dn, &mc->d_f[i], &dc);
        for (int a = 0; a < 3; a++)
            mc->d_grad3[i * 3 + a] = dc * d[a];
    }
    esr_grid_sample_value_dpoint_bwd(g->grid, mc->smp.pos, n, mc->d_f, mc->d_grad3, g_values);
}

float esr_march_strongest_kept(const struct esr_march *mc, int r, size_t *row)
{
    float wmax = 0.0f;
    for (size_t k = mc->kept_start[r]; k < mc->kept_start[r + 1]; k++)
        if (mc->weight[mc->kidx[k]] > wmax) {
            wmax = mc->weight[mc->kidx[k]];
            *row = k;
        }
    return wmax;
}

void esr_march_composite_args(const struct esr_march *mc, const float *kept_values, int channels,
                              const float *bg, int bg_per_ray, struct esr_composite_args *a)
{
    a->n_rays = mc->n_rays;
    a->ray_start = mc->smp.ray_start;
    a->alpha = mc->alpha;
    a->weight = mc->weight;
    a->t_last = mc->t_last;
    a->thres = ESR_COMPOSITE_THRES;
    a->channels = channels;
    a->values = kept_values;
    a->bg = bg;
    a->bg_per_ray = bg_per_ray;
    a->value_row = mc->kept_row;
}
