/* Incident radiance of the LTS loss: the first-hit and the volume estimator (see lts_incident.h). */
#include "train/lts_incident.h"

#include <stdlib.h>
#include <string.h>

#include "core/buffers.h"
#include "core/error.h"
#include "core/profile.h"
#include "fields/grid.h"
#include "model/render_sdf.h"
#include "model/trace.h"
#include "volume/composite.h"
#include "volume/first_hit.h"

int esr_lts_reserve_rows(struct esr_lts *l, size_t rows)
{
    if (rows <= l->cap_rows)
        return ESR_OK;
    const size_t cap = rows + rows / 4;
    float **const f3[] = {&l->q_pos3, &l->q_dir3, &l->d_tone3, &l->d_lin3};
    l->cap_rows = 0;
    ESR_TRY(esr_floats_realloc(f3, sizeof f3 / sizeof f3[0], cap * 3, "lts point-field rows"));
    free(l->q_on);
    if (!(l->q_on = malloc(cap)))
        return ESR_FAIL("lts: out of memory for %zu point-field rows", cap);
    /* the tone-mapped outputs of the LTS rows get no gradient, ever */
    memset(l->d_tone3, 0, cap * 3 * sizeof(float));
    l->cap_rows = cap;
    return ESR_OK;
}

static int reserve_sec(struct esr_lts *l, size_t n)
{
    if (n <= l->cap_sec)
        return ESR_OK;
    const size_t cap = n + n / 4;
    float **const b[] = {&l->sec_off3, &l->sec_emo3, &l->d_sec_off3, &l->d_sec_emo3};
    l->cap_sec = 0;
    ESR_TRY(esr_floats_realloc(b, sizeof b / sizeof b[0], cap * 3, "lts secondary samples"));
    l->cap_sec = cap;
    return ESR_OK;
}

/* Two rows (off, on) at position pos, looking along dir, from row r on. */
static void put_row_pair(struct esr_lts *l, size_t r, const float *pos, const float *dir)
{
    for (int on = 0; on < 2; on++) {
        memcpy(l->q_pos3 + (r + (size_t)on) * 3, pos, 3 * sizeof(float));
        memcpy(l->q_dir3 + (r + (size_t)on) * 3, dir, 3 * sizeof(float));
        l->q_on[r + (size_t)on] = (uint8_t)on;
    }
}

/* First hit: sphere-trace to the surface as first hits see it (no surface where the renderer
 * skips space), one row pair per hit. */
static int first_hit_trace(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                           size_t P, size_t *rows)
{
    const size_t PM = P * (size_t)l->M;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    struct esr_first_hit_params hp;
    esr_first_hit_params_init(&hp, g);
    hp.inside = ESR_FIRST_HIT_INSIDE_SKIP; /* march out of any inside region first */
    struct esr_first_hit_rays hr = {l->orig3, l->wi3, NULL, NULL, PM};
    struct esr_first_hit_out ho = {l->hit_t, l->hit_flags, l->hit_pos3, NULL};
    esr_model_sdf_lift_skipped(m, sdf, l->skipped, l->hit_sdf);
    ESR_TRY(esr_first_hit(g, l->hit_sdf, &hp, &hr, &ho));
    size_t r = 4 * P;
    for (size_t i = 0; i < PM; i++) {
        l->hit_row[i] = -1;
        if (!(l->hit_flags[i] & ESR_FIRST_HIT_HIT))
            continue;
        l->hit_row[i] = (int32_t)r;
        put_row_pair(l, r, l->hit_pos3 + i * 3, l->wi3 + i * 3);
        r += 2;
    }
    *rows = r;
    return ESR_OK;
}

/* Volume: the primary rays' march along each secondary ray, one row pair per kept sample. */
static int volume_trace(struct esr_lts *l, const struct esr_model *m, const float *sdf, size_t P,
                        uint64_t seed, size_t *rows)
{
    struct esr_march_geometry geom;
    esr_trace_geometry(m, sdf, &geom);
    struct esr_march_rays rays;
    memset(&rays, 0, sizeof rays);
    rays.n = (int)(P * (size_t)l->M);
    rays.origins = l->orig3;
    rays.dirs = l->wi3;
    rays.seed = seed;
    rays.jitter = 1;
    ESR_TRY(esr_march_fwd(&l->sec, &geom, &rays));
    const size_t nk = l->sec.n_kept;
    ESR_TRY(reserve_sec(l, nk));
    ESR_TRY(esr_lts_reserve_rows(l, 4 * P + 2 * nk));
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nk; k++)
        put_row_pair(l, 4 * P + 2 * k, l->sec.kpos3 + k * 3, l->sec.kdir3 + k * 3);
    *rows = 4 * P + 2 * nk;
    return ESR_OK;
}

static int lts_incident_trace_run(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                                  size_t P, uint64_t seed, size_t *rows);

int esr_lts_incident_trace(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                           size_t P, uint64_t seed, size_t *rows)
{
    esr_prof_enter(ESR_PROF_LTS_SECONDARY);
    const int rc = lts_incident_trace_run(l, m, sdf, P, seed, rows);
    esr_prof_exit(ESR_PROF_LTS_SECONDARY);
    return rc;
}

static int lts_incident_trace_run(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                                  size_t P, uint64_t seed, size_t *rows)
{
    return l->estimator == ESR_LTS_VOLUME ? volume_trace(l, m, sdf, P, seed, rows)
                                          : first_hit_trace(l, m, sdf, P, rows);
}

void esr_lts_incident_gather(struct esr_lts *l, size_t P)
{
    const size_t PM = P * (size_t)l->M;
    const float *lin = l->pf.lin3;
    if (l->estimator == ESR_LTS_VOLUME) {
        const size_t nk = l->sec.n_kept;
        const float *rows = lin + 4 * P * 3;
#pragma omp parallel for schedule(static)
        for (size_t k = 0; k < nk; k++)
            for (int c = 0; c < 3; c++) {
                const float off = rows[(2 * k) * 3 + c], on = rows[(2 * k + 1) * 3 + c];
                l->sec_off3[k * 3 + c] = off;
                l->sec_emo3[k * 3 + c] = on - off; /* L_on = sg(L_off) + L_emo */
            }
        struct esr_composite_args a;
        esr_march_composite_args(&l->sec, l->sec_off3, 3, l->env3, 1, &a);
        esr_composite_fwd(&a, l->li_off3);
        esr_march_composite_args(&l->sec, l->sec_emo3, 3, NULL, 0, &a);
        esr_composite_fwd(&a, l->li_emo3);
        return;
    }
    for (size_t i = 0; i < PM; i++)
        for (int c = 0; c < 3; c++) {
            const int32_t r = l->hit_row[i];
            l->li_off3[i * 3 + c] = r >= 0 ? lin[(size_t)r * 3 + c] : l->env3[i * 3 + c];
            l->li_emo3[i * 3 + c] =
                r >= 0 ? lin[(size_t)(r + 1) * 3 + c] - lin[(size_t)r * 3 + c] : 0.0f;
        }
}

int esr_lts_incident_lights(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                            size_t P)
{
    const size_t PM = P * (size_t)l->M;
    size_t n = 0;
    for (size_t i = 0; i < PM; i++) {
        l->emo_fixed[i] =
            l->hit_row[i] >= 0 && esr_lights_id_at(&l->lights, l->hit_pos3 + i * 3) >= 0;
        if (l->emo_fixed[i])
            memcpy(l->light_pos3 + 3 * n++, l->hit_pos3 + i * 3, 3 * sizeof(float));
    }
    if (n == 0)
        return ESR_OK;
    ESR_TRY(esr_material_fields_fwd(&l->light_mf, m, sdf, l->light_pos3, n));
    float *emit3 = l->light_mf.emit3;
    esr_lights_scale_emission(&l->lights, l->light_pos3, n, emit3);
    for (size_t i = 0, k = 0; i < PM; i++)
        if (l->emo_fixed[i])
            memcpy(l->li_emo3 + i * 3, emit3 + 3 * k++, 3 * sizeof(float));
    return ESR_OK;
}

size_t esr_lts_incident_scatter(struct esr_lts *l, size_t P, float *g_sdf)
{
    const size_t PM = P * (size_t)l->M;
    size_t hits = 0;
    if (l->estimator == ESR_LTS_VOLUME) {
        struct esr_march *mc = &l->sec;
        const size_t nk = mc->n_kept;
        esr_march_zero_d_alpha(mc);
        memset(l->d_sec_off3, 0, nk * 3 * sizeof(float));
        memset(l->d_sec_emo3, 0, nk * 3 * sizeof(float));
        struct esr_composite_args a;
        esr_march_composite_args(mc, l->sec_off3, 3, l->env3, 1, &a);
        esr_composite_bwd(&a, l->d_li_off3, mc->d_alpha, l->d_sec_off3);
        esr_march_composite_args(mc, l->sec_emo3, 3, NULL, 0, &a);
        esr_composite_bwd(&a, l->d_li_emo3, mc->d_alpha, l->d_sec_emo3);
        float *rows = l->d_lin3 + 4 * P * 3;
#pragma omp parallel for schedule(static)
        for (size_t k = 0; k < nk; k++)
            for (int c = 0; c < 3; c++) { /* L_emo's gradient reaches the on row's emo branch */
                rows[(2 * k) * 3 + c] += l->d_sec_off3[k * 3 + c];
                rows[(2 * k + 1) * 3 + c] += l->d_sec_emo3[k * 3 + c];
            }
        for (size_t i = 0; i < PM; i++) {
            for (int c = 0; c < 3; c++)
                l->d_env3[i * 3 + c] = l->d_li_off3[i * 3 + c] * mc->t_last[i];
            hits += mc->t_last[i] < 0.5f; /* mostly blocked: a surface, as a first hit */
        }
        esr_march_bwd(mc, g_sdf);
        return hits;
    }
    for (size_t i = 0; i < PM; i++) {
        const int32_t r = l->hit_row[i];
        for (int c = 0; c < 3; c++) {
            if (r >= 0) { /* off row; emo -> the on row's emo branch */
                l->d_lin3[(size_t)r * 3 + c] += l->d_li_off3[i * 3 + c];
                if (!(l->lights.n > 0 && l->emo_fixed[i])) /* a light's emission: fixed */
                    l->d_lin3[(size_t)(r + 1) * 3 + c] += l->d_li_emo3[i * 3 + c];
                l->d_env3[i * 3 + c] = 0.0f;
            } else {
                l->d_env3[i * 3 + c] = l->d_li_off3[i * 3 + c];
            }
        }
        hits += r >= 0;
    }
    return hits;
}
