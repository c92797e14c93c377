/* Radiance fine-tuning's loss on the LTS points (see finetune_loss.h). */
#include "edit/finetune_loss.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/colour.h"
#include "core/error.h"
#include "core/vec3.h"
#include "model/material_fields.h"

/* The ratio of estimates: a floor (linear radiance) that keeps points no light reaches from
 * dividing noise by noise, plus this share of the step's mean direct light (as the ratio
 * relight's mean term, edit/relight.h), and a cap on how far one step's target may scale. Lamp
 * test_nvc, 6 frames of 2 edits, by the share: 0 28.54 dB, 0.05 28.94, 0.1 28.91, 0.15 28.80,
 * 0.3 28.53, 1 27.71. The errors' weight (esr_image_error_scale squared), by the radiance's
 * floor: linear MSE 29.92 dB, 0.05 30.40, 0.01 30.47, 0.003 30.47. */
#define EDIT_EPS 1e-3f
#define EDIT_FLOOR_SHARE 0.05f
#define EDIT_MAX_RATIO 16.0f

int esr_finetune_loss_init(struct esr_finetune_loss *fl, const struct esr_model *ref, int points,
                           int dirs)
{
    memset(fl, 0, sizeof(*fl));
    fl->ref = ref;
    fl->P = (size_t)points;
    fl->M = (size_t)dirs;
    fl->direct3 = malloc(fl->P * 6 * sizeof(float));
    fl->found3 = malloc(fl->P * 6 * sizeof(float));
    fl->on_light = malloc(fl->P * fl->M);
    if (fl->direct3 && fl->found3 && fl->on_light)
        return ESR_OK;
    esr_finetune_loss_free(fl);
    return ESR_FAIL("finetune: out of memory for the loss of %d points x %d directions", points,
                    dirs);
}

void esr_finetune_loss_free(struct esr_finetune_loss *fl)
{
    free(fl->direct3);
    free(fl->found3);
    free(fl->on_light);
    if (fl->has_pf_ref)
        esr_point_fields_free(&fl->pf_ref);
    memset(fl, 0, sizeof(*fl));
}

/* The reflection sum_j L_i R w of point p towards wo for the incident emo radiance of rows
 * `lin` (on row - off row at each hit), hits on a light left out (skip). */
static void reflected_emo(const struct esr_lts *l, const float *lin, const uint8_t *skip, size_t p,
                          const struct esr_material *mat, struct esr_vec3 n, struct esr_vec3 wo,
                          float out[3])
{
    const size_t M = (size_t)l->M;
    out[0] = out[1] = out[2] = 0.0f;
    for (size_t j = 0; j < M; j++) {
        const size_t i = p * M + j;
        const int32_t r = l->hit_row[i];
        if (r < 0 || skip[i])
            continue;
        float R[3];
        esr_brdf_eval(mat, n, wo, esr_v3_at(l->wi3, i), R);
        for (int c = 0; c < 3; c++)
            out[c] += (lin[(size_t)(r + 1) * 3 + c] - lin[(size_t)r * 3 + c]) * R[c] * l->wt[i];
    }
}

/* The ratio's floors for this step: EDIT_EPS + EDIT_FLOOR_SHARE x the mean of D' and of D over
 * the step's points and outgoing directions, per channel. */
static void edit_floors(struct esr_finetune_loss *fl, size_t P)
{
    double now[3] = {0, 0, 0}, was[3] = {0, 0, 0};
    for (size_t i = 0; i < P * 2; i++)
        for (int c = 0; c < 3; c++) {
            now[c] += fmaxf(fl->direct3[i * 3 + (size_t)c], 0.0f);
            was[c] += fmaxf(fl->found3[i * 3 + (size_t)c], 0.0f);
        }
    for (int c = 0; c < 3; c++) {
        fl->edit_floor[c] = EDIT_EPS + EDIT_FLOOR_SHARE * (float)(now[c] / (double)(P * 2));
        fl->found_floor[c] = EDIT_EPS + EDIT_FLOOR_SHARE * (float)(was[c] / (double)(P * 2));
    }
}

/* The loss at point p for both outgoing directions. */
static void point_loss(const struct esr_finetune_loss *fl, struct esr_lts *l,
                       const struct esr_lights *lights, size_t p, float scale, double *se_emo)
{
    if (esr_lights_id_at(lights, l->pos3 + p * 3) >= 0)
        return;
    const float *lin = l->pf.lin3, *ref = fl->pf_ref.lin3;
    const struct esr_material mat = esr_material_of_row(l->mf.brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
    const struct esr_vec3 n = esr_v3_at(l->nrm3, p);
    for (int o = 0; o < 2; o++) {
        const struct esr_vec3 wo = esr_v3_at(l->wo3, 2 * p + (size_t)o);
        if (esr_v3_dot(n, wo) <= 0.0f)
            continue;
        const size_t po = p * 2 + (size_t)o, row_off = p * 4 + (size_t)o * 2, row_on = row_off + 1;
        float refl[3], refl_ref[3];
        reflected_emo(l, lin, fl->on_light, p, &mat, n, wo, refl);
        reflected_emo(l, ref, fl->on_light, p, &mat, n, wo, refl_ref);
        for (int c = 0; c < 3; c++) {
            const float L = lin[row_on * 3 + c] - lin[row_off * 3 + c];
            const float L_ref = ref[row_on * 3 + c] - ref[row_off * 3 + c];
            const float now = fl->direct3[po * 3 + c] + refl[c];
            const float was = fl->found3[po * 3 + c] + refl_ref[c];
            const float ratio = fminf((fmaxf(now, 0.0f) + fl->edit_floor[c]) /
                                          (fmaxf(was, 0.0f) + fl->found_floor[c]),
                                      EDIT_MAX_RATIO);
            const float target = L_ref * ratio, e = L - target;
            const float slope = esr_image_error_scale(lin[row_off * 3 + c] + target);
            const float w = slope * slope;
            *se_emo += (double)(w * e * e);
            l->d_lin3[row_on * 3 + c] += 2.0f * scale * w * e;
        }
    }
}

int esr_finetune_loss_run(struct esr_finetune_loss *fl, struct esr_lts *l,
                          const struct esr_model *m, const float *sdf,
                          const struct esr_point_query *q, size_t P, double *se_emo)
{
    if (!fl->edit || !fl->ref)
        return ESR_FAIL("finetune: the loss needs an edit and the trained model");
    if (P > fl->P || (size_t)l->M != fl->M)
        return ESR_FAIL("finetune: %zu points x %d directions, the loss holds %zu x %zu", P, l->M,
                        fl->P, fl->M);
    if (!fl->has_pf_ref) {
        ESR_TRY(esr_point_fields_init(&fl->pf_ref, fl->ref, q->n, 0));
        fl->has_pf_ref = 1;
    }
    ESR_TRY(esr_point_fields_fwd(&fl->pf_ref, fl->ref, sdf, q));
    edit_floors(fl, P);
    const size_t PM = P * fl->M;
    /* no other loss to weigh this one against: weight 1 */
    const float scale = 1.0f / (float)(P * 2 * 3);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < PM; i++)
        fl->on_light[i] =
            l->hit_row[i] >= 0 && esr_lights_id_at(&m->lights, l->hit_pos3 + i * 3) >= 0;
    double se = 0.0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : se)
    for (size_t p = 0; p < P; p++)
        point_loss(fl, l, &m->lights, p, scale, &se);
    *se_emo += se;
    return ESR_OK;
}
