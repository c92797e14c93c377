/* Ray groups and emission suppression of the pdra stage (see pdra.h). */
#include "train/pdra.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/profile.h"
#include "core/order.h"
#include "volume/composite.h"

/* The emitters' level: this percentile of the batch's composited max-channel E. */
#define EMITTER_LEVEL_PERCENTILE 0.995

void esr_pdra_free(struct esr_pdra *pd)
{
    esr_material_fields_free(&pd->mf);
    esr_pdra_reg_free(&pd->reg);
    free(pd->e_ray3);
    free(pd->d_e_ray3);
    free(pd->d_rows3);
    free(pd->certain);
    free(pd->sorted);
    memset(pd, 0, sizeof(*pd));
}

int esr_pdra_init(struct esr_pdra *pd, const struct esr_model *m, int max_rays)
{
    memset(pd, 0, sizeof(*pd));
    pd->max_rays = max_rays;
    ESR_TRY(esr_material_fields_init(&pd->mf, m, (size_t)max_rays * 8,
                                     ESR_MATERIAL_TRAIN | ESR_MATERIAL_EMISSION_ONLY));
    int rc = esr_pdra_reg_init(&pd->reg, m, (size_t)max_rays * 8);
    if (rc != ESR_OK) {
        esr_material_fields_free(&pd->mf);
        return rc;
    }
    pd->e_ray3 = malloc((size_t)max_rays * 3 * sizeof(float));
    pd->d_e_ray3 = malloc((size_t)max_rays * 3 * sizeof(float));
    pd->certain = malloc((size_t)max_rays);
    pd->sorted = malloc((size_t)max_rays * sizeof(float));
    if (!pd->e_ray3 || !pd->d_e_ray3 || !pd->certain || !pd->sorted) {
        esr_pdra_free(pd);
        return ESR_FAIL("pdra: out of memory for %d rays", max_rays);
    }
    return ESR_OK;
}

float esr_pdra_k(const struct esr_train_config *cfg, long step, long iters)
{
    const double ramp = 0.75 * (double)(iters > 0 ? iters : 1);
    const double f = fmin(1.0, (double)step / ramp);
    return (float)(cfg->pdra_k0 + (cfg->pdra_k_end - cfg->pdra_k0) * f);
}

/* The emitters' level in this batch: the 99.5th percentile of the rays' max-channel E
 * (pd->sorted: scratch of max_rays floats). */
static float emitter_level(struct esr_pdra *pd, int n)
{
    for (int r = 0; r < n; r++)
        pd->sorted[r] = fmaxf(pd->e_ray3[r * 3], fmaxf(pd->e_ray3[r * 3 + 1], pd->e_ray3[r * 3 + 2]));
    esr_sort_floats(pd->sorted, (size_t)n);
    return pd->sorted[(size_t)(EMITTER_LEVEL_PERCENTILE * (n - 1))];
}

/* The groups at the current k, the suppression loss and its gradient ADDED into pd->d_rows3
 * (the kept rows' E, through the composite a: E only, not alpha). */
static void groups_and_suppression(struct esr_pdra *pd, struct esr_model *m,
                                   const struct esr_march *mc, const struct esr_composite_args *a,
                                   float *chosen_k_end)
{
    const int n = mc->n_rays;
    /* k_frac x the emitters' level in this batch, never below k0 */
    const float k_level = fmaxf(m->cfg.pdra_k0, m->cfg.pdra_k_frac * emitter_level(pd, n));
    if (m->cfg.pdra_k_end <= 0.0f) {
        m->cfg.pdra_k_end = k_level;
        *chosen_k_end = k_level;
    }
    /* the ramp, capped by the same fraction of the emitters' current level: emitters whose E
     * drifts down during the stage are never overtaken by k (and then suppressed for good) */
    const long iters = esr_stage_options(&m->cfg, (enum esr_stage)m->stage)->iters;
    pd->k = fminf(esr_pdra_k(&m->cfg, m->step, iters), k_level);
    m->cfg.emitter_k = pd->k; /* the mask the model renders uses the current k */
    int n_certain = 0, n_suppressed = 0;
    for (int r = 0; r < n; r++) {
        const float *e = pd->e_ray3 + r * 3;
        pd->certain[r] = fmaxf(e[0], fmaxf(e[1], e[2])) <= pd->k;
        n_certain += pd->certain[r];
        /* the penalty's mean runs over certain rays that reach a surface, so its strength does
         * not depend on how much background the batch holds */
        n_suppressed += pd->certain[r] && mc->kept_start[r + 1] > mc->kept_start[r];
    }
    pd->n_certain = n_certain;
    if (n_suppressed == 0 || m->cfg.pdra_supp <= 0.0f)
        return;
    const float scale = m->cfg.pdra_supp / (3.0f * (float)n_suppressed);
    double sum = 0.0;
    for (int r = 0; r < n; r++)
        for (int c = 0; c < 3; c++) {
            const float e = pd->certain[r] ? pd->e_ray3[r * 3 + c] : 0.0f;
            sum += (double)e * e;
            pd->d_e_ray3[r * 3 + c] = 2.0f * scale * e;
        }
    pd->supp_loss = (double)scale * sum;
    esr_composite_bwd(a, pd->d_e_ray3, NULL, pd->d_rows3);
}

static int pdra_step_run(struct esr_pdra *pd, struct esr_model *m, const float *sdf, float *g_sdf,
                         float *grads, const struct esr_march *mc, uint64_t seed, float *chosen_k_end);

int esr_pdra_step(struct esr_pdra *pd, struct esr_model *m, const float *sdf, float *g_sdf,
                  float *grads, const struct esr_march *mc, uint64_t seed, float *chosen_k_end)
{
    esr_prof_enter(ESR_PROF_PDRA);
    const int rc = pdra_step_run(pd, m, sdf, g_sdf, grads, mc, seed, chosen_k_end);
    esr_prof_exit(ESR_PROF_PDRA);
    return rc;
}

static int pdra_step_run(struct esr_pdra *pd, struct esr_model *m, const float *sdf, float *g_sdf,
                         float *grads, const struct esr_march *mc, uint64_t seed, float *chosen_k_end)
{
    const int n = mc->n_rays;
    *chosen_k_end = 0.0f;
    if (n > pd->max_rays)
        return ESR_FAIL("pdra: %d rays for a workspace of %d", n, pd->max_rays);
    const size_t nk = mc->n_kept;
    ESR_TRY(esr_material_fields_fwd(&pd->mf, m, sdf, mc->kpos3, nk));
    if (nk > pd->rows_cap) {
        free(pd->d_rows3);
        pd->rows_cap = nk + nk / 4;
        if (!(pd->d_rows3 = malloc(pd->rows_cap * 3 * sizeof(float)))) {
            pd->rows_cap = 0;
            return ESR_FAIL("pdra: out of memory for %zu kept rows", nk);
        }
    }
    struct esr_composite_args a;
    esr_march_composite_args(mc, pd->mf.emit3, 3, NULL, 0, &a);
    esr_composite_fwd(&a, pd->e_ray3);
    memset(pd->d_rows3, 0, nk * 3 * sizeof(float));
    memset(pd->certain, 0, (size_t)n);
    pd->n_certain = 0;
    pd->supp_loss = 0.0;
    if (m->cfg.pdra_progressive) /* else "w/o progressive": every ray uncertain */
        groups_and_suppression(pd, m, mc, &a, chosen_k_end);
    const struct esr_pdra_reg_batch rb = {mc, pd->mf.emit3, pd->d_rows3, seed};
    ESR_TRY(esr_pdra_reg_smooth(&pd->reg, m, sdf, g_sdf, grads, &rb));
    return esr_material_fields_bwd(&pd->mf, m, g_sdf, grads, pd->d_rows3, NULL);
}
