/* One training step's loss and gradient (see step.h). */
#include "train/step.h"

#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "fields/sdf.h"
#include "model/render_sdf.h"

void esr_train_step_free(struct esr_train_step *st)
{
    esr_trace_free(&st->tr);
    if (st->has_lts)
        esr_lts_free(&st->lts);
    if (st->has_pdra)
        esr_pdra_free(&st->pdra);
    float *bufs[] = {st->orig3, st->dir3,       st->tgt3,    st->d_rgb3,      st->d_lin3,
                     st->sdf_view, st->g_sdf_view, st->scratch, st->grad_tv_work, st->d_t_last};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    free(st->lights_on);
    memset(st, 0, sizeof(*st));
}

int esr_train_step_init(struct esr_train_step *st, const struct esr_model *m, int max_rays)
{
    memset(st, 0, sizeof(*st));
    st->max_rays = max_rays;
    ESR_TRY(esr_trace_init(&st->tr, m, max_rays, 1));
    float **per_ray[] = {&st->orig3, &st->dir3, &st->tgt3, &st->d_rgb3, &st->d_lin3};
    int ok = 1;
    for (size_t i = 0; i < sizeof per_ray / sizeof per_ray[0]; i++)
        ok &= (*per_ray[i] = malloc((size_t)max_rays * 3 * sizeof(float))) != NULL;
    ok &= (st->lights_on = malloc((size_t)max_rays)) != NULL;
    ok &= (st->d_t_last = malloc((size_t)max_rays * sizeof(float))) != NULL;
    const enum esr_stage s = (enum esr_stage)m->stage;
    if (ok && esr_stage_info(s)->smoothed_sdf && m->cfg.smooth_ksize > 1) {
        size_t ns = esr_grid_count(esr_model_grid(m, ESR_COMP_SDF));
        ok &= (st->sdf_view = malloc(ns * sizeof(float))) != NULL;
        ok &= (st->g_sdf_view = malloc(ns * sizeof(float))) != NULL;
        ok &= (st->scratch = malloc(ns * sizeof(float))) != NULL;
    }
    if (ok && esr_model_has(m, ESR_COMP_SDF) && esr_stage_options(&m->cfg, s)->tv_sdf_grad > 0.0f)
        ok &= (st->grad_tv_work = malloc(esr_sdf_grad_tv_work(esr_model_grid(m, ESR_COMP_SDF)) *
                                         sizeof(float))) != NULL;
    if (!ok) {
        esr_train_step_free(st);
        return ESR_FAIL("train: out of memory for a batch of %d rays", max_rays);
    }
    if (esr_stage_info(s)->lts_loss) {
        int rc = esr_lts_init(&st->lts, m);
        if (rc != ESR_OK) {
            esr_train_step_free(st);
            return rc;
        }
        st->has_lts = 1;
    }
    if (esr_stage_info(s)->ray_groups) {
        int rc = esr_pdra_init(&st->pdra, m, max_rays);
        if (rc != ESR_OK) {
            esr_train_step_free(st);
            return rc;
        }
        st->has_pdra = 1;
    }
    return ESR_OK;
}

int esr_train_step_run(struct esr_train_step *st, struct esr_model *m, int n, uint64_t seed,
                       struct esr_render_loss_result *out)
{
    if (n < 1 || n > st->max_rays)
        return ESR_FAIL("train step: %d rays for a workspace of %d", n, st->max_rays);
    const struct esr_stage_info *si = esr_stage_info((enum esr_stage)m->stage);
    const float *sdf = NULL;
    float *g_sdf = NULL, *g_raw = NULL;
    if (esr_model_has(m, ESR_COMP_SDF)) {
        float *raw = esr_model_values(m, ESR_COMP_SDF);
        g_raw = m->params.g + m->part[ESR_COMP_SDF].off;
        sdf = raw;
        g_sdf = g_raw;
        if (st->sdf_view) {
            esr_prof_enter(ESR_PROF_REG);
            const int rc = esr_model_view_sdf(m, raw, st->sdf_view, st->scratch);
            esr_prof_exit(ESR_PROF_REG);
            ESR_TRY(rc);
            sdf = st->sdf_view;
            g_sdf = st->g_sdf_view;
            memset(g_sdf, 0, esr_grid_count(esr_model_grid(m, ESR_COMP_SDF)) * sizeof(float));
        }
    }
    esr_nn_params_zero_grad(&m->params, 0, m->params.count);
    ESR_TRY(esr_trace_fwd(&st->tr, m, sdf, st->orig3, st->dir3, st->lights_on, n, seed));
    float *d_lin = si->linear_loss ? st->d_lin3 : NULL;
    esr_render_loss_batch(st->tr.rgb3, st->tr.lin_rgb3, st->tgt3, (size_t)n,
                          si->linear_loss ? m->cfg.lambda_tau : 0.0f, st->d_rgb3, d_lin, out);
    st->ent_loss = 0.0;
    if (st->has_pdra && m->cfg.pdra_w_ent > 0.0f) { /* pdra's entropy on T_last */
        st->ent_loss = esr_pdra_reg_entropy(m->cfg.pdra_w_ent, st->tr.march.t_last, n, st->d_t_last);
        st->tr.d_t_last = st->d_t_last;
        out->loss += st->ent_loss;
    }
    ESR_TRY(esr_trace_bwd(&st->tr, m, g_sdf, m->params.g, st->d_rgb3, d_lin));
    const uint8_t *certain = NULL;
    if (st->has_pdra) {
        ESR_TRY(esr_pdra_step(&st->pdra, m, sdf, g_sdf, m->params.g, &st->tr.march,
                              seed ^ 0x5eed0f5a11ULL, &st->pdra_chosen_k_end));
        out->loss += st->pdra.supp_loss + st->pdra.reg.es_loss + st->pdra.reg.ns_loss;
        certain = st->pdra.certain;
    }
    if (st->has_lts) {
        const struct esr_lts_batch lb = {&st->tr.march, certain, seed ^ 0x17a3c0ffeeULL};
        ESR_TRY(esr_lts_run(&st->lts, m, sdf, g_sdf, m->params.g, &lb, &st->lts_stats));
        out->loss += st->lts_stats.loss;
    }
    if (st->sdf_view) {
        esr_prof_enter(ESR_PROF_REG);
        const int rc = esr_grid_smooth_bwd(esr_model_grid(m, ESR_COMP_SDF), st->g_sdf_view, g_raw,
                                           st->scratch, m->cfg.smooth_ksize, m->cfg.smooth_sigma);
        esr_prof_exit(ESR_PROF_REG);
        ESR_TRY(rc);
    }
    return ESR_OK;
}
