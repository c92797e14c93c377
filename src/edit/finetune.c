/* Radiance fine-tuning for edits (see finetune.h). */
#include "edit/finetune.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/grid.h"
#include "nn/adam.h"
#include "nn/schedule.h"
#include "train/lights/direct.h"
#include "model/trace.h"

/* the start's power ratio is kept within these (an edit that turns every light off) */
#define START_RATIO_MIN 1e-3
#define START_RATIO_MAX 1e3

/* the two components fine-tuning trains */
static const enum esr_component TUNED[2] = {ESR_COMP_EMO_FEAT, ESR_COMP_EMO_MLP};

void esr_finetune_default_opts(struct esr_finetune_opts *o)
{
    o->iters = 300;
    o->rays = 512;
    o->points = 1024;
    o->dirs = 4;
    o->light_spp = 32;
    o->lr_feat = 0.06f;
    o->lr_mlp = 3e-3f;
    o->lr_final = 0.1f;
}

/* The lights' direct light at the step's points, edited and as found (the same samples), each
 * summed over lights. */
static int edited_and_found_direct(struct esr_finetune *f, const struct esr_lts *l, size_t P,
                                   float *direct3, float *found3)
{
    const struct esr_direct_points dp = {P, l->pos3, l->nrm3, l->mf.brdf5, l->wo3, 2};
    const struct esr_direct_lights dl = {&f->shadows, f->samples, f->m->lights.n, f->loss.edit,
                                         f->o.light_spp};
    ESR_TRY(esr_lights_direct(&dl, &dp, f->seed ^ (uint64_t)(f->step + 1) * 0x9e3779b97f4a7c15ULL,
                              f->direct, f->found));
    const double *src[2] = {f->direct, f->found};
    float *dst[2] = {direct3, found3};
    for (int v = 0; v < 2; v++)
        for (size_t i = 0; i < P * 2; i++)
            for (int c = 0; c < 3; c++) {
                double sum = 0.0;
                for (int k = 0; k < f->m->lights.n; k++)
                    sum += src[v][(i * ESR_MAX_LIGHTS + (size_t)k) * 3 + (size_t)c];
                dst[v][i * 3 + (size_t)c] = (float)sum;
            }
    return ESR_OK;
}

/* The LTS's loss while an edit is tuned: the direct light at its points, then the loss. */
static int finetune_lts_loss(void *user, struct esr_lts *l, const struct esr_model *m,
                             const float *sdf, const struct esr_point_query *q, size_t P,
                             double *se_emo)
{
    struct esr_finetune *f = user;
    ESR_TRY(edited_and_found_direct(f, l, P, f->loss.direct3, f->loss.found3));
    return esr_finetune_loss_run(&f->loss, l, m, sdf, q, P, se_emo);
}

void esr_finetune_start(struct esr_model *m, const struct esr_light_edit *edits, float rho[3])
{
    double found[3] = {0, 0, 0}, edited[3] = {0, 0, 0};
    for (int k = 0; k < m->lights.n; k++) {
        const struct esr_light *lt = &m->lights.light[k];
        float e[3];
        esr_light_edit_apply(&edits[k], lt->radiance, e);
        for (int c = 0; c < 3; c++) {
            found[c] += (double)lt->radiance[c] * lt->area;
            edited[c] += (double)e[c] * lt->area;
        }
    }
    const struct esr_mlp *mlp = esr_model_mlp(m, ESR_COMP_EMO_MLP);
    float *bias = m->params.w + mlp->b_off[mlp->n_layers - 1];
    for (int c = 0; c < 3; c++) {
        double r = found[c] > 0.0 ? edited[c] / found[c] : 1.0;
        r = r < START_RATIO_MIN ? START_RATIO_MIN : r > START_RATIO_MAX ? START_RATIO_MAX : r;
        bias[c] += (float)log(r);
        if (rho)
            rho[c] = (float)r;
    }
}

void esr_finetune_free(struct esr_finetune *f)
{
    esr_ray_set_free(&f->rays);
    free(f->trained_w);
    free(f->trained_moments);
    esr_march_free(&f->march);
    esr_lts_free(&f->lts);
    esr_finetune_loss_free(&f->loss);
    for (int k = 0; k < ESR_MAX_LIGHTS; k++)
        esr_light_samples_free(&f->samples[k]);
    esr_light_shadows_free(&f->shadows);
    free(f->direct);
    free(f->found);
    free(f->g_sdf);
    free(f->orig3);
    free(f->dir3);
    free(f->rgb3);
    free(f->on);
    memset(f, 0, sizeof(*f));
}

/* The tuned components' Adam moments into saved (save 1) or back from it (save 0). */
static void moments_copy(struct esr_model *m, float *saved, int save)
{
    size_t at = 0;
    for (int i = 0; i < 2; i++) {
        const struct esr_part *p = &m->part[TUNED[i]];
        float *model[2] = {m->adam.m + p->off, m->adam.v + p->off};
        for (int k = 0; k < 2; k++, at += p->count)
            memcpy(save ? saved + at : model[k], save ? model[k] : saved + at,
                   p->count * sizeof(float));
    }
}

int esr_finetune_init(struct esr_finetune *f, struct esr_model *m, const struct esr_dataset *ds,
                      const struct esr_finetune_opts *o)
{
    memset(f, 0, sizeof(*f));
    f->o = *o;
    if (m->stage != ESR_STAGE_PDRA || m->lights.n == 0)
        return ESR_FAIL("finetune: the model has no lights (a finished pdra stage finds them)");
    if (esr_stage_info(ESR_STAGE_PDRA)->smoothed_sdf)
        return ESR_FAIL("finetune: expects the pdra stage to render its raw SDF");
    if (o->iters < 1 || o->rays < 1 || o->points < 1 || o->dirs < 1 || o->light_spp < 1)
        return ESR_FAIL("finetune: iterations, rays, points, directions and light samples must "
                        "be positive");
    int rc = esr_ray_set_build(&f->rays, ds, ESR_PHASE_TRAIN);
    if (rc == ESR_OK && !(f->trained_w = malloc(m->params.count * sizeof(float))))
        rc = ESR_FAIL("finetune: out of memory for a copy of %zu weights", m->params.count);
    if (rc == ESR_OK) {
        memcpy(f->trained_w, m->params.w, m->params.count * sizeof(float));
        f->trained = *m; /* shares m's description, read only */
        f->trained.params.w = f->trained_w;
    }
    size_t tuned = 0;
    for (int i = 0; i < 2; i++)
        tuned += m->part[TUNED[i]].count;
    if (rc == ESR_OK && !(f->trained_moments = malloc(2 * tuned * sizeof(float))))
        rc = ESR_FAIL("finetune: out of memory for a copy of %zu Adam moments", 2 * tuned);
    if (rc == ESR_OK)
        moments_copy(m, f->trained_moments, 1);
    for (int k = 0; rc == ESR_OK && k < m->lights.n; k++)
        rc = esr_light_samples_get(m, k, &f->samples[k]);
    if (rc == ESR_OK)
        rc = esr_light_shadows_init(&f->shadows, m);
    const size_t nd = (size_t)o->points * 2 * ESR_MAX_LIGHTS * 3;
    if (rc == ESR_OK && (!(f->direct = malloc(nd * sizeof(double))) ||
                         !(f->found = malloc(nd * sizeof(double)))))
        rc = ESR_FAIL("finetune: out of memory for the direct light of %d points", o->points);
    f->m = m;
    const size_t R = (size_t)o->rays;
    if (rc == ESR_OK) {
        f->orig3 = malloc(R * 3 * sizeof(float));
        f->dir3 = malloc(R * 3 * sizeof(float));
        f->rgb3 = malloc(R * 3 * sizeof(float));
        f->on = malloc(R);
        f->g_sdf = calloc(esr_grid_count(esr_model_grid(m, ESR_COMP_SDF)), sizeof(float));
        if (!f->orig3 || !f->dir3 || !f->rgb3 || !f->on || !f->g_sdf)
            rc = ESR_FAIL("finetune: out of memory for a batch of %zu rays", R);
    }
    if (rc == ESR_OK)
        rc = esr_march_init(&f->march, o->rays, 1);
    if (rc == ESR_OK) /* the LTS workspace at our sizes, first hit */
        rc = esr_lts_init_sized(&f->lts, m, o->points, o->dirs, ESR_LTS_FIRST_HIT);
    if (rc == ESR_OK)
        rc = esr_finetune_loss_init(&f->loss, &f->trained, o->points, o->dirs);
    if (rc == ESR_OK) {
        f->hook = (struct esr_lts_loss_hook){finetune_lts_loss, f};
        f->lts.hook = &f->hook;
    }
    if (rc != ESR_OK)
        esr_finetune_free(f);
    return rc;
}

void esr_finetune_restore(struct esr_finetune *f, struct esr_model *m)
{
    if (!f->applied)
        return;
    for (int i = 0; i < 2; i++) {
        const struct esr_part *p = &m->part[TUNED[i]];
        memcpy(m->params.w + p->off, f->trained_w + p->off, p->count * sizeof(float));
    }
    moments_copy(m, f->trained_moments, 0);
    m->lights.edited = 0;
    f->applied = 0;
}

int esr_finetune_apply(struct esr_finetune *f, struct esr_model *m,
                       const struct esr_light_edit *edits, uint64_t seed,
                       struct esr_finetune_stats *st)
{
    memset(st, 0, sizeof(*st));
    ESR_TRY(esr_light_edits_check(edits, m->lights.n));
    esr_finetune_restore(f, m);
    const double t0 = omp_get_wtime();
    const float *sdf = esr_model_values(m, ESR_COMP_SDF);
    struct esr_march_geometry geom;
    esr_trace_geometry(m, sdf, &geom);
    for (int i = 0; i < 2; i++) { /* fresh moments: this edit's steps only */
        const struct esr_part *p = &m->part[TUNED[i]];
        memset(m->adam.m + p->off, 0, p->count * sizeof(float));
        memset(m->adam.v + p->off, 0, p->count * sizeof(float));
    }
    f->loss.edit = edits;
    f->seed = seed;
    f->applied = 1; /* from here on the weights move: restore puts them back */
    esr_finetune_start(m, edits, NULL);
    const int iters = f->o.iters, tail = iters / 10 > 0 ? iters / 10 : 1;
    int rc = ESR_OK;
    for (int it = 0; it < iters && rc == ESR_OK; it++) {
        f->step = it;
        esr_ray_set_draw(&f->rays, seed, it, f->o.rays, f->orig3, f->dir3, f->rgb3, f->on);
        struct esr_march_rays rays = {.n = f->o.rays, .origins = f->orig3, .dirs = f->dir3,
                                      .seed = seed ^ (uint64_t)it * 0x9e3779b97f4a7c15ULL,
                                      .jitter = 1};
        rc = esr_march_fwd(&f->march, &geom, &rays);
        for (int i = 0; rc == ESR_OK && i < 2; i++) /* only these are read below */
            esr_nn_params_zero_grad(&m->params, m->part[TUNED[i]].off, m->part[TUNED[i]].count);
        struct esr_lts_stats ls;
        const struct esr_lts_batch lb = {&f->march, NULL, seed ^ 0x17a3c0ffeeULL ^ (uint64_t)it};
        if (rc == ESR_OK)
            rc = esr_lts_run(&f->lts, m, sdf, f->g_sdf, m->params.g, &lb, &ls);
        if (rc == ESR_OK && !isfinite(ls.mse_emo))
            rc = ESR_FAIL("finetune: the LTS loss became %g at step %d", ls.mse_emo, it);
        if (rc != ESR_OK)
            break;
        if (it < tail)
            st->mse_first += ls.mse_emo / tail;
        if (it >= iters - tail)
            st->mse_last += ls.mse_emo / tail;
        const float decay = esr_lr_cosine_factor(it, iters, 0, f->o.lr_final);
        for (int i = 0; i < 2; i++) {
            const int grid = esr_component_info(TUNED[i])->kind == ESR_KIND_GRID;
            const struct esr_adam_hp hp = {(grid ? f->o.lr_feat : f->o.lr_mlp) * decay, 0.9f,
                                           grid ? 0.99f : 0.999f, 1e-8f, grid};
            esr_adam_step(&hp, it + 1, &m->adam, m->params.w, m->params.g, m->part[TUNED[i]].off,
                          m->part[TUNED[i]].count);
        }
        st->iters = it + 1;
    }
    f->loss.edit = NULL;
    if (rc != ESR_OK) {
        esr_finetune_restore(f, m);
        return rc;
    }
    memcpy(m->lights.edit, edits, (size_t)m->lights.n * sizeof *edits);
    m->lights.edited = 1;
    st->seconds = omp_get_wtime() - t0;
    return ESR_OK;
}
