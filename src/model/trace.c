/* Primary rays: march -> point fields -> composite, and back (see trace.h). */
#include "model/trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "fields/background.h"
#include "fields/grid.h"
#include "volume/composite.h"

static const float white[3] = {1.0f, 1.0f, 1.0f};

/* The background the composites blend in behind each ray: the learned one per ray when the model
 * has it (filled by the forward; the tone-mapped composite takes its colour, the linear one that
 * colour decoded to linear, so the loss's gamma(linear) term sees the same colour), else white. */
static void background_args(const struct esr_trace *t, int linear, const float **bg, int *per_ray)
{
    *bg = t->has_bg ? (linear ? t->bg_lin3 : t->bg3) : white;
    *per_ray = t->has_bg;
}

static void free_rows(struct esr_trace *t)
{
    free(t->row_on);
    free(t->d_tone_rows);
    free(t->d_lin_rows);
    t->row_on = NULL;
    t->d_tone_rows = t->d_lin_rows = NULL;
    t->cap_rows = 0;
}

static int grow_rows(struct esr_trace *t, size_t cap)
{
    free_rows(t);
    t->row_on = malloc(cap);
    t->d_tone_rows = malloc(cap * 3 * sizeof(float));
    t->d_lin_rows = malloc(cap * 3 * sizeof(float));
    if (!t->row_on || !t->d_tone_rows || !t->d_lin_rows) {
        free_rows(t);
        return ESR_FAIL("trace: out of memory for %zu kept samples", cap);
    }
    t->cap_rows = cap;
    return ESR_OK;
}

int esr_trace_init(struct esr_trace *t, const struct esr_model *m, int max_rays, int train)
{
    memset(t, 0, sizeof(*t));
    t->train = train;
    t->max_rays = max_rays;
    ESR_TRY(esr_march_init(&t->march, max_rays, train));
    t->rgb3 = malloc((size_t)max_rays * 3 * sizeof(float));
    t->lin_rgb3 = malloc((size_t)max_rays * 3 * sizeof(float));
    t->bg3 = malloc((size_t)max_rays * 3 * sizeof(float));
    t->bg_lin3 = malloc((size_t)max_rays * 3 * sizeof(float));
    t->d_bg3 = malloc((size_t)max_rays * 3 * sizeof(float));
    int rc = t->rgb3 && t->lin_rgb3 && t->bg3 && t->bg_lin3 && t->d_bg3 ? ESR_OK
                                                          : ESR_FAIL("trace: out of memory for %d rays", max_rays);
    if (rc == ESR_OK)
        rc = grow_rows(t, (size_t)max_rays * 8);
    if (rc == ESR_OK)
        rc = esr_point_fields_init(&t->fields, m, (size_t)max_rays * 8, train);
    if (rc != ESR_OK)
        esr_trace_free(t);
    return rc;
}

void esr_trace_free(struct esr_trace *t)
{
    esr_march_free(&t->march);
    esr_point_fields_free(&t->fields);
    free_rows(t);
    free(t->rgb3);
    free(t->lin_rgb3);
    free(t->bg3);
    free(t->bg_lin3);
    free(t->d_bg3);
    memset(t, 0, sizeof(*t));
}

void esr_trace_geometry(const struct esr_model *m, const float *sdf, struct esr_march_geometry *g)
{
    const enum esr_stage s = (enum esr_stage)m->stage;
    memset(g, 0, sizeof(*g));
    const float step_vox = esr_stage_options(&m->cfg, s)->step_vox;
    if (esr_stage_info(s)->alpha == ESR_ALPHA_DENSITY) {
        g->alpha = ESR_MARCH_DENSITY;
        g->grid = esr_model_grid(m, ESR_COMP_DENSITY);
        g->values = esr_model_values(m, ESR_COMP_DENSITY);
        g->density_shift = m->density_shift;
        g->density_step_vox = step_vox;
    } else {
        g->alpha = ESR_MARCH_NEUS;
        g->grid = esr_model_grid(m, ESR_COMP_SDF);
        g->values = sdf;
        g->inv_s = m->inv_s;
    }
    g->step = step_vox * esr_grid_voxel_size(g->grid, 0);
    g->mask = m->has_mask ? &m->mask : NULL;
    for (int a = 0; a < 3; a++) {
        g->bmin[a] = m->scene_min[a];
        g->bmax[a] = m->scene_max[a];
    }
}

int esr_trace_fwd(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                  const float *origins, const float *dirs, const uint8_t *lights_on, int n,
                  uint64_t seed)
{
    struct esr_march_geometry geom;
    esr_trace_geometry(m, sdf, &geom);
    struct esr_march_rays rays;
    memset(&rays, 0, sizeof rays);
    rays.n = n;
    rays.origins = origins;
    rays.dirs = dirs;
    rays.seed = seed;
    rays.jitter = t->train;
    ESR_TRY(esr_march_fwd(&t->march, &geom, &rays));
    t->dirs = dirs;
    return esr_trace_shade(t, m, sdf, lights_on);
}

int esr_trace_shade(struct esr_trace *t, const struct esr_model *m, const float *sdf,
                    const uint8_t *lights_on)
{
    const struct esr_march *mc = &t->march;
    const size_t nk = mc->n_kept;
    const int n = mc->n_rays;
    const float *dirs = t->dirs;
    t->lights_on = lights_on;
    if (nk > t->cap_rows)
        ESR_TRY(grow_rows(t, nk + nk / 4));
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        t->row_on[k] = lights_on[mc->kray[k]] ? 1 : 0;
    struct esr_point_query q = {nk, mc->kpos3, mc->kdir3, t->row_on};
    ESR_TRY(esr_point_fields_fwd(&t->fields, m, sdf, &q));
    t->has_bg = esr_model_has(m, ESR_COMP_BACKGROUND);
    if (t->has_bg) {
        esr_background_fwd_linear(esr_model_values(m, ESR_COMP_BACKGROUND), dirs, lights_on, n, t->bg3,
                                  t->bg_lin3);
    }
    const float *bg;
    int bg_per_ray;
    background_args(t, 0, &bg, &bg_per_ray);
    struct esr_composite_args a;
    esr_march_composite_args(mc, t->fields.tone3, 3, bg, bg_per_ray, &a);
    esr_composite_fwd(&a, t->rgb3);
    if (t->fields.lin3) {
        background_args(t, 1, &bg, &bg_per_ray);
        esr_march_composite_args(mc, t->fields.lin3, 3, bg, bg_per_ray, &a);
        esr_composite_fwd(&a, t->lin_rgb3);
    } else {
        memcpy(t->lin_rgb3, t->rgb3, (size_t)n * 3 * sizeof(float));
    }
    return ESR_OK;
}

/* The background's gradient: the composites add t_last bg and t_last lin(bg), so
 * d bg = t_last (d rgb + lin'(bg) d lin). */
static void background_bwd(struct esr_trace *t, const struct esr_model *m, float *grads,
                           const float *d_rgb3, const float *d_lin3)
{
    const struct esr_march *mc = &t->march;
    float *d_bg3 = t->d_bg3;
    for (int r = 0; r < mc->n_rays; r++)
        for (int c = 0; c < 3; c++)
            d_bg3[r * 3 + c] = mc->t_last[r] * (d_rgb3[r * 3 + c] +
                                                (d_lin3 ? d_lin3[r * 3 + c] * esr_linear_from_srgb_grad(t->bg3[r * 3 + c]) : 0.0f));
    esr_background_bwd(esr_model_values(m, ESR_COMP_BACKGROUND), t->dirs, t->lights_on, mc->n_rays,
                       d_bg3, grads + m->part[ESR_COMP_BACKGROUND].off);
}

/* The stage's geom_on weight on the lights-on rays' share of d alpha (the composites' gradient,
 * background's included), before it reaches the density or SDF grid. */
static void scale_lights_on_geometry(struct esr_trace *t, const struct esr_model *m)
{
    const float w = esr_stage_options(&m->cfg, (enum esr_stage)m->stage)->geom_on;
    struct esr_march *mc = &t->march;
    if (w == 1.0f || !t->lights_on)
        return;
#pragma omp parallel for schedule(static)
    for (int r = 0; r < mc->n_rays; r++)
        if (t->lights_on[r])
            for (size_t s = mc->smp.ray_start[r]; s < mc->smp.ray_start[r + 1]; s++)
                mc->d_alpha[s] *= w;
}

int esr_trace_bwd(struct esr_trace *t, const struct esr_model *m, float *g_sdf, float *grads,
                  const float *d_rgb3, const float *d_lin3)
{
    struct esr_march *mc = &t->march;
    const size_t nk = mc->n_kept;
    esr_march_zero_d_alpha(mc);
    memset(t->d_tone_rows, 0, nk * 3 * sizeof(float));
    const float *bg;
    int bg_per_ray;
    background_args(t, 0, &bg, &bg_per_ray);
    if (t->has_bg)
        background_bwd(t, m, grads, d_rgb3, t->fields.lin3 ? d_lin3 : NULL);
    struct esr_composite_args a;
    esr_march_composite_args(mc, t->fields.tone3, 3, bg, bg_per_ray, &a);
    esr_composite_bwd(&a, d_rgb3, mc->d_alpha, t->d_tone_rows);
    const float *d_lin_rows = NULL;
    if (t->fields.lin3 && d_lin3) {
        memset(t->d_lin_rows, 0, nk * 3 * sizeof(float));
        background_args(t, 1, &bg, &bg_per_ray);
        esr_march_composite_args(mc, t->fields.lin3, 3, bg, bg_per_ray, &a);
        esr_composite_bwd(&a, d_lin3, mc->d_alpha, t->d_lin_rows);
        d_lin_rows = t->d_lin_rows;
    }
    if (t->d_t_last) {
        esr_composite_t_last_bwd(mc->n_rays, mc->smp.ray_start, mc->alpha, ESR_COMPOSITE_THRES,
                                 t->d_t_last, mc->d_alpha);
        t->d_t_last = NULL;
    }
    scale_lights_on_geometry(t, m);
    ESR_TRY(esr_point_fields_bwd(&t->fields, m, g_sdf, grads, t->d_tone_rows, d_lin_rows));
    float *g_geom = mc->geom.alpha == ESR_MARCH_DENSITY ? grads + m->part[ESR_COMP_DENSITY].off
                                                        : g_sdf;
    esr_march_bwd(mc, g_geom);
    return ESR_OK;
}

void esr_trace_extras(struct esr_trace *t, const float *normal_sdf, float *depth, float *normal3,
                      float *opacity)
{
    const struct esr_march *mc = &t->march;
    struct esr_composite_args a;
    if (depth) {
        esr_march_composite_args(mc, mc->smp.t, 1, NULL, 0, &a);
        a.value_row = NULL; /* t is stored per sample */
        esr_composite_fwd(&a, depth);
        for (int r = 0; r < mc->n_rays; r++)
            depth[r] /= fmaxf(1.0f - mc->t_last[r], 1e-6f);
    }
    if (normal3 && mc->geom.alpha == ESR_MARCH_NEUS) {
        float *nrm = t->d_tone_rows; /* free outside a training backward */
        const size_t nk = mc->n_kept;
        if (normal_sdf)
            esr_grid_sample_dpoint(mc->geom.grid, normal_sdf, 0, mc->kpos3, nk, nrm);
#pragma omp parallel for schedule(static)
        for (size_t k = 0; k < nk; k++) {
            const float *g = normal_sdf ? nrm + k * 3 : mc->grad3 + (size_t)mc->kidx[k] * 3;
            float len = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) + 1e-8f;
            for (int c = 0; c < 3; c++)
                nrm[k * 3 + c] = g[c] / len;
        }
        esr_march_composite_args(mc, nrm, 3, NULL, 0, &a);
        esr_composite_fwd(&a, normal3);
    } else if (normal3) {
        memset(normal3, 0, (size_t)mc->n_rays * 3 * sizeof(float));
    }
    if (opacity)
        for (int r = 0; r < mc->n_rays; r++)
            opacity[r] = 1.0f - mc->t_last[r];
}
