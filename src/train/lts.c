/* The light-transport-segment loss (see lts.h). */
#include "train/lts.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/brdf.h"
#include "core/brdf_sampling.h"
#include "core/error.h"
#include "core/profile.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/vec3.h"
#include "fields/env_sg.h"
#include "fields/grid.h"
#include "model/render_sdf.h"
#include "train/lts_incident.h"

/* The normals' smoothed SDF follows the slowly trained SDF (lr 5e-4) every this many steps. */
#define NORMAL_REFRESH 50
/* Secondary rays start this many voxels off the surface point along the normal. */
#define SECONDARY_OFFSET_VOX 1.0f
void esr_lts_free(struct esr_lts *l)
{
    float *bufs[] = {l->R3, l->normal_sdf, l->pos3,     l->nrm3,     l->wo3,       l->wi3,
                     l->wt,         l->env3,     l->d_env3,   l->li_off3,   l->li_emo3,
                     l->d_li_off3,  l->d_li_emo3, l->orig3,   l->hit_t,     l->hit_pos3,
                     l->q_pos3,     l->q_dir3,   l->d_tone3,  l->d_lin3,    l->d_emit3,
                     l->d_brdf5,    l->hat3,     l->sec_off3, l->sec_emo3, l->d_sec_off3, l->d_sec_emo3,
                     l->hit_sdf};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++)
        free(bufs[i]);
    free(l->hit_flags);
    free(l->skipped);
    free(l->certain);
    free(l->pick);
    free(l->hit_row);
    free(l->emo_fixed);
    free(l->light_pos3);
    esr_material_fields_free(&l->light_mf); /* a no-op on a zeroed one: no lights handed over */
    esr_lights_free(&l->lights);
    free(l->q_on);
    esr_march_free(&l->sec);
    esr_point_fields_free(&l->pf);
    esr_material_fields_free(&l->mf);
    memset(l, 0, sizeof(*l));
}

void esr_lts_refresh_normals(struct esr_lts *l)
{
    free(l->normal_sdf);
    l->normal_sdf = NULL;
}

int esr_lts_init(struct esr_lts *l, const struct esr_model *m)
{
    return esr_lts_init_sized(l, m, m->cfg.lts_points, m->cfg.lts_dirs, m->cfg.lts_estimator);
}

int esr_lts_init_sized(struct esr_lts *l, const struct esr_model *m, int points, int dirs,
                       int estimator)
{
    memset(l, 0, sizeof(*l));
    l->P = points;
    l->M = dirs;
    l->estimator = estimator;
    /* a pdra model has its own pair (pdra.lobe_dirs, pdra.split: its transport sees the lights
     * at their calibrated strength, pdra.lights_at), applied where it can be: the split needs
     * lobe directions and even counts, so each half holds half of each technique's directions,
     * the same balance-heuristic estimate with half the samples (esr_config_validate checks
     * lts_split's pair, which applies as set) */
    const int pdra = m->stage == ESR_STAGE_PDRA;
    const int lobe = pdra ? m->cfg.pdra_lobe_dirs : m->cfg.lts_lobe_dirs;
    l->lobe = dirs >= 4 * lobe ? lobe : 0;
    l->split = pdra ? m->cfg.pdra_split && estimator == ESR_LTS_FIRST_HIT && l->lobe > 0 &&
                          l->lobe % 2 == 0 && dirs % 2 == 0
                    : m->cfg.lts_split;
    l->emo = m->cfg.emission ? 1.0f : 0.0f;
    const size_t P = (size_t)l->P, PM = P * (size_t)l->M;
    struct {
        float **p;
        size_t n;
    } fl[] = {{&l->pos3, P * 3},       {&l->nrm3, P * 3},       {&l->wo3, P * 6},
              {&l->wi3, PM * 3},       {&l->wt, PM},            {&l->env3, PM * 3},
              {&l->d_env3, PM * 3},    {&l->li_off3, PM * 3},   {&l->li_emo3, PM * 3},
              {&l->d_li_off3, PM * 3}, {&l->d_li_emo3, PM * 3}, {&l->orig3, PM * 3},
              {&l->R3, PM * 3},        {&l->hit_t, PM},         {&l->hit_pos3, PM * 3},
              {&l->d_emit3, P * 3},    {&l->d_brdf5, P * ESR_BRDF_CHANNELS},
              {&l->hat3, P * 12}};
    int ok = 1;
    for (size_t i = 0; i < sizeof fl / sizeof fl[0]; i++)
        ok &= (*fl[i].p = malloc(fl[i].n * sizeof(float))) != NULL;
    ok &= (l->hit_flags = malloc(PM)) != NULL;
    ok &= (l->hit_row = malloc(PM * sizeof(int32_t))) != NULL;
    ok &= (l->certain = malloc(P)) != NULL;
    int rc = ok ? ESR_OK : ESR_FAIL("lts: out of memory for %zu points x %d directions", P, l->M);
    /* rows: the points', and two per secondary ray to start with (one pair per hit) */
    if (rc == ESR_OK)
        rc = esr_lts_reserve_rows(l, 4 * P + 2 * PM);
    if (rc == ESR_OK && l->estimator == ESR_LTS_VOLUME)
        rc = esr_march_init(&l->sec, (int)PM, 1);
    if (rc == ESR_OK && l->estimator == ESR_LTS_FIRST_HIT) {
        const size_t N = esr_grid_voxels(esr_model_grid(m, ESR_COMP_SDF));
        l->skipped = malloc(N);
        l->hit_sdf = malloc(N * sizeof(float));
        rc = l->skipped && l->hit_sdf ? esr_model_sdf_skipped(m, l->skipped) /* the mask is fixed */
                                      : ESR_FAIL("lts: out of memory for the SDF as first hits see it");
    }
    if (rc == ESR_OK)
        rc = esr_point_fields_init(&l->pf, m, 4 * P + 2 * PM, 1);
    if (rc == ESR_OK)
        rc = esr_material_fields_init(&l->mf, m, P, ESR_MATERIAL_TRAIN);
    if (rc != ESR_OK)
        esr_lts_free(l);
    return rc;
}

int esr_lts_set_lights(struct esr_lts *l, const struct esr_model *m, struct esr_lights *lights)
{
    if (l->estimator != ESR_LTS_FIRST_HIT) {
        esr_lights_free(lights);
        return ESR_FAIL("lts: lights in the transport need the first-hit estimator "
                        "(lts_estimator 0)");
    }
    const size_t PM = (size_t)l->P * (size_t)l->M;
    esr_material_fields_free(&l->light_mf);
    esr_lights_free(&l->lights);
    if (lights->n == 0)
        return ESR_OK;
    if (!l->emo_fixed)
        l->emo_fixed = malloc(PM);
    if (!l->light_pos3)
        l->light_pos3 = malloc(PM * 3 * sizeof(float));
    int rc = l->emo_fixed && l->light_pos3 ? ESR_OK
                                           : ESR_FAIL("lts: out of memory for the lights' hits");
    if (rc == ESR_OK)
        rc = esr_material_fields_init(&l->light_mf, m, PM, ESR_MATERIAL_EMISSION_ONLY);
    if (rc != ESR_OK) {
        esr_lights_free(lights);
        return rc;
    }
    l->lights = *lights;
    memset(lights, 0, sizeof *lights);
    return ESR_OK;
}

static void v3_put(float *a, size_t i, struct esr_vec3 v)
{
    a[i * 3] = v.x;
    a[i * 3 + 1] = v.y;
    a[i * 3 + 2] = v.z;
}

/* Points (stratified over the kept list), their normals, BRDF (the material fields' forward),
 * outgoing and incident directions and the secondary rays' origins. Returns the number of
 * points. */
static int setup_points(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                        const struct esr_march *mc, const uint8_t *ray_certain, uint64_t seed,
                        size_t *n_points)
{
    const size_t P = mc->n_kept < (size_t)l->P ? mc->n_kept : (size_t)l->P, M = (size_t)l->M;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float off = SECONDARY_OFFSET_VOX * esr_grid_voxel_size(g, 0);
    /* kept rows listed uncertain first; with ray groups, half the points come from each group
     * (the few uncertain rays would otherwise get almost no points: pdra's stratified batches) */
    size_t n_unc = 0; /* without groups: one group, the kept rows in order */
    if (ray_certain) {
        for (size_t k = 0; k < mc->n_kept; k++)
            if (!ray_certain[mc->kray[k]])
                l->pick[n_unc++] = (uint32_t)k;
        size_t j = n_unc;
        for (size_t k = 0; k < mc->n_kept; k++)
            if (ray_certain[mc->kray[k]])
                l->pick[j++] = (uint32_t)k;
    }
    const size_t n_cer = mc->n_kept - n_unc;
    const size_t P_unc = n_unc == 0 ? 0 : n_cer == 0 ? P : P / 2;
    for (size_t p = 0; p < P; p++) {
        struct esr_rng r = esr_rng_init(seed, p);
        /* stratified within the point's group: [0, n_unc) or [n_unc, n_kept) of the list */
        const int in_unc = p < P_unc;
        const size_t base = in_unc ? 0 : n_unc, span = in_unc ? n_unc : n_cer;
        const size_t slot = in_unc ? p : p - P_unc, slots = in_unc ? P_unc : P - P_unc;
        size_t i = base + (size_t)(((double)slot + esr_rng_float(&r)) * (double)span / (double)slots);
        if (i >= base + span)
            i = base + span - 1;
        const size_t k = ray_certain ? l->pick[i] : i;
        memcpy(l->pos3 + p * 3, mc->kpos3 + k * 3, 3 * sizeof(float));
        l->certain[p] = ray_certain ? ray_certain[mc->kray[k]] : 0;
        memcpy(l->wo3 + p * 6, mc->kdir3 + k * 3, 3 * sizeof(float)); /* ray dir; negated below */
    }
    esr_grid_sample_dpoint(g, l->normal_sdf, 0, l->pos3, P, l->nrm3);
    ESR_TRY(esr_material_fields_fwd(&l->mf, m, sdf, l->pos3, P)); /* the lobe needs the roughness */
#pragma omp parallel for schedule(static)
    for (size_t p = 0; p < P; p++) {
        struct esr_rng r = esr_rng_init(seed ^ 0x5bd1e995ULL, p);
        struct esr_vec3 d = esr_v3_at(l->wo3, 2 * p), n = esr_v3_at(l->nrm3, p);
        struct esr_vec3 wo = esr_v3_scale(d, -1.0f);
        n = esr_v3_length(n) > 1e-12f ? esr_v3_normalize(n) : wo;
        v3_put(l->nrm3, p, n);
        struct esr_vec3 t, b;
        esr_v3_basis(n, &t, &b);
        float u1 = esr_rng_float(&r), u2 = esr_rng_float(&r);
        v3_put(l->wo3, 2 * p, wo);
        v3_put(l->wo3, 2 * p + 1, esr_v3_from_local(esr_sample_hemisphere_uniform(u1, u2), t, b, n));
        struct esr_vec3 o = esr_v3_add(esr_v3_at(l->pos3, p), esr_v3_scale(n, off));
        if (l->estimator == ESR_LTS_VOLUME) { /* the authors': independent, uniform */
            for (size_t j = 0; j < M; j++) {
                u1 = esr_rng_float(&r);
                u2 = esr_rng_float(&r);
                const struct esr_vec3 loc = esr_sample_hemisphere_uniform(u1, u2);
                v3_put(l->wi3, p * M + j, esr_v3_from_local(loc, t, b, n));
                l->wt[p * M + j] = 1.0f / ((float)M * fmaxf(esr_pdf_hemisphere_uniform(loc), 1e-6f));
            }
        } else { /* cosine-weighted and from the BRDF's lobe about both outgoing directions */
            struct esr_brdf_dirs bd = {n, t, b, {wo, esr_v3_at(l->wo3, 2 * p + 1)}, 2,
                                       esr_material_of_row(l->mf.brdf5 + p * ESR_BRDF_CHANNELS, 1.0f).roughness,
                                       (int)M, l->lobe, l->split};
            bd.n_cos = (int)M - (esr_brdf_dirs_count(&bd) - (int)M); /* a dead lobe's share to cosine */
            struct esr_vec3 wi[ESR_LTS_MAX_DIRS];
            esr_brdf_dirs_sample(&bd, &r, wi, l->wt + p * M);
            for (size_t j = 0; j < M; j++)
                v3_put(l->wi3, p * M + j, wi[j]);
        }
        for (size_t j = 0; j < M; j++)
            v3_put(l->orig3, p * M + j, o);
    }
    *n_points = P;
    return ESR_OK;
}

/* Query rows of the points: per point 2 outgoing x (off, on). */
static void build_point_rows(struct esr_lts *l, size_t P)
{
    size_t r = 0;
    for (size_t p = 0; p < P; p++)
        for (int o = 0; o < 2; o++)
            for (int on = 0; on < 2; on++, r++) {
                v3_put(l->q_pos3, r, esr_v3_at(l->pos3, p));
                v3_put(l->q_dir3, r, esr_v3_scale(esr_v3_at(l->wo3, 2 * p + (size_t)o), -1.0f));
                l->q_on[r] = (uint8_t)on;
            }
}

/* How a call weighs its points' errors (the same for every point). */
struct point_weights {
    float scale; /* the loss weight over the terms averaged: points x 2 outgoing x 3 channels */
    float w_l;   /* the emo pair's weight on E's side (1: the plain MSE) */
    float w_r;   /* the emo pair's weight on L_emo's side (1: the plain MSE) */
    int sg;      /* pdra's stop-gradient pair in force: an uncertain point's emo error trains E
                    and L_emo, not the reflection */
    float brdf_emo; /* the share of the emo error that reaches the BRDF (option lts_brdf_emo) */
    float emo_base; /* of that share, the part that reaches the base colour (option lts_emo_base;
                       roughness and metallic get all of it) */
};

/* Estimates, loss and the gradients of everything they read, for point p; *prod gets the split
 * loss's products (l->split). */
static void point_loss(struct esr_lts *l, size_t p, const struct point_weights *pw,
                       double *se_off, double *se_emo, double *prod)
{
    const float scale = pw->scale, w_l = pw->w_l, w_r = pw->w_r, brdf_emo = pw->brdf_emo;
    const int sg = pw->sg;
    /* the emo error's BRDF gradient kept apart when the base colour takes another share of it */
    const int apart = pw->emo_base != 1.0f;
    const float emo_in_sum = apart ? 0.0f : brdf_emo;
    const size_t M = (size_t)l->M;
    const float *lin = l->pf.lin3, *E = l->mf.emit3 + p * 3;
    const struct esr_material mat = esr_material_of_row(l->mf.brdf5 + p * ESR_BRDF_CHANNELS, 1.0f);
    const struct esr_vec3 n = esr_v3_at(l->nrm3, p);
    struct esr_material d_mat, d_mat_emo;
    memset(&d_mat, 0, sizeof d_mat);
    memset(&d_mat_emo, 0, sizeof d_mat_emo);
    /* pdra's stop-gradient: an uncertain point's L^_emo = E + sg(reflection), so its emo error
     * trains E (and L_emo), not the BRDF or the incident L_emo */
    const float refl_emo = sg && !l->certain[p] ? 0.0f : 1.0f;
    for (int o = 0; o < 2; o++) {
        const struct esr_vec3 wo = esr_v3_at(l->wo3, 2 * p + (size_t)o);
        float *hat_out = l->hat3 + (p * 2 + (size_t)o) * 6;
        if (esr_v3_dot(n, wo) <= 0.0f) { /* back-facing camera direction: nothing to compare */
            for (int c = 0; c < 6; c++)
                hat_out[c] = NAN;
            continue;
        }
        const size_t row_off = p * 4 + (size_t)o * 2, row_on = row_off + 1;
        const float e_on = l->certain[p] ? 0.0f : 1.0f; /* certain: reflection alone */
        float hat_off[3] = {0, 0, 0}, hat_emo[3] = {e_on * E[0], e_on * E[1], e_on * E[2]};
        /* the split's reflected sums of the even and the odd directions */
        float half_off[2][3] = {{0, 0, 0}, {0, 0, 0}}, half_emo[2][3] = {{0, 0, 0}, {0, 0, 0}};
        for (size_t j = 0; j < M; j++) {
            const size_t i = p * M + j;
            float *R = l->R3 + i * 3; /* kept for the backward below */
            esr_brdf_eval(&mat, n, wo, esr_v3_at(l->wi3, i), R);
            for (int c = 0; c < 3; c++) {
                const float t_off = l->li_off3[i * 3 + c] * R[c] * l->wt[i];
                const float t_emo = l->li_emo3[i * 3 + c] * R[c] * l->wt[i];
                hat_off[c] += t_off;
                hat_emo[c] += t_emo;
                half_off[j & 1][c] += t_off;
                half_emo[j & 1][c] += t_emo;
            }
        }
        /* d/d(direction term) per half: with the split, the other half's error */
        float d_hat_off[2][3], d_hat_emo[2][3];
        for (int c = 0; c < 3; c++) {
            hat_out[c] = hat_off[c];
            hat_out[3 + c] = hat_emo[c];
            const float L_off = lin[row_off * 3 + c];
            const float L_emo = lin[row_on * 3 + c] - L_off; /* L_on = sg(L_off) + L_emo */
            /* without lights-on images (l->emo 0) the emo error is dropped: L_emo never saw data */
            const float e_off = L_off - hat_off[c], e_emo = l->emo * (L_emo - hat_emo[c]);
            *se_off += (double)e_off * e_off;
            *se_emo += (double)e_emo * e_emo;
            l->d_lin3[row_off * 3 + c] += 2.0f * scale * e_off;
            /* the emo pair: w_r trains L_emo towards sg(L^_emo), w_l trains E towards
             * sg(L_emo - reflection); both 1 = the plain MSE. The reflection side (BRDF,
             * incident radiance) keeps weight 1: it also carries the off estimate, which a
             * heavier pull through the shared BRDF wrecks (lamp: off MSE 0.003 -> 0.5) */
            l->d_lin3[row_on * 3 + c] += 2.0f * w_r * scale * e_emo; /* the emo branch only */
            l->d_emit3[p * 3 + c] += e_on * w_l * (-2.0f * scale * e_emo);
            for (int h = 0; h < 2; h++) {
                float eo = e_off, ee = e_emo;
                if (l->split) { /* half h's estimate is 2 x its sum: the other half's error */
                    eo = L_off - 2.0f * half_off[1 - h][c];
                    ee = l->emo * (L_emo - e_on * E[c] - 2.0f * half_emo[1 - h][c]);
                }
                d_hat_off[h][c] = -2.0f * scale * eo;
                d_hat_emo[h][c] = -2.0f * scale * ee;
            }
            if (l->split)
                *prod += (double)(L_off - 2.0f * half_off[0][c]) * (L_off - 2.0f * half_off[1][c]) +
                         (double)l->emo * (L_emo - e_on * E[c] - 2.0f * half_emo[0][c]) *
                             (L_emo - e_on * E[c] - 2.0f * half_emo[1][c]);
        }
        for (size_t j = 0; j < M; j++) {
            const size_t i = p * M + j;
            const float *R = l->R3 + i * 3;
            float d_R[3];
            for (int c = 0; c < 3; c++) {
                const float w = l->wt[i];
                const float d_off = d_hat_off[j & 1][c], d_emo = refl_emo * d_hat_emo[j & 1][c];
                d_R[c] = (d_off * l->li_off3[i * 3 + c] + emo_in_sum * d_emo * l->li_emo3[i * 3 + c]) * w;
                l->d_li_off3[i * 3 + c] += d_off * R[c] * w;
                l->d_li_emo3[i * 3 + c] += d_emo * R[c] * w;
            }
            esr_brdf_eval_bwd(&mat, n, wo, esr_v3_at(l->wi3, i), d_R, &d_mat);
            if (apart) {
                float d_R_emo[3];
                for (int c = 0; c < 3; c++)
                    d_R_emo[c] = brdf_emo * refl_emo * d_hat_emo[j & 1][c] * l->li_emo3[i * 3 + c] * l->wt[i];
                esr_brdf_eval_bwd(&mat, n, wo, esr_v3_at(l->wi3, i), d_R_emo, &d_mat_emo);
            }
        }
    }
    float *db = l->d_brdf5 + p * ESR_BRDF_CHANNELS;
    if (apart) {
        for (int c = 0; c < 3; c++)
            d_mat.base[c] += pw->emo_base * d_mat_emo.base[c];
        d_mat.roughness += d_mat_emo.roughness;
        d_mat.metallic += d_mat_emo.metallic;
    }
    for (int c = 0; c < 3; c++)
        db[c] = d_mat.base[c];
    db[3] = d_mat.roughness;
    db[4] = d_mat.metallic;
}

static int run_lts(struct esr_lts *l, const struct esr_model *m, const float *sdf, float *g_sdf,
                   float *grads, const struct esr_lts_batch *b, struct esr_lts_stats *out);

int esr_lts_run(struct esr_lts *l, const struct esr_model *m, const float *sdf, float *g_sdf,
                float *grads, const struct esr_lts_batch *b, struct esr_lts_stats *out)
{
    esr_prof_enter(ESR_PROF_LTS_LOSS);
    const int rc = run_lts(l, m, sdf, g_sdf, grads, b, out);
    esr_prof_exit(ESR_PROF_LTS_LOSS);
    return rc;
}

static int run_lts(struct esr_lts *l, const struct esr_model *m, const float *sdf, float *g_sdf,
                   float *grads, const struct esr_lts_batch *b, struct esr_lts_stats *out)
{
    const struct esr_march *mc = b->mc;
    const uint8_t *ray_certain = b->ray_certain;
    const uint64_t seed = b->seed;
    memset(out, 0, sizeof(*out));
    if (mc->n_kept == 0)
        return ESR_OK;
    if (!l->normal_sdf || (!l->hook && m->step % NORMAL_REFRESH == 0)) {
        esr_lts_refresh_normals(l);
        ESR_TRY(esr_model_normal_sdf(m, &l->normal_sdf));
        if (!l->normal_sdf) { /* smoothing off: the raw SDF's own gradient */
            size_t ns = esr_grid_count(esr_model_grid(m, ESR_COMP_SDF));
            if (!(l->normal_sdf = malloc(ns * sizeof(float))))
                return ESR_FAIL("lts: out of memory for the normal SDF");
            memcpy(l->normal_sdf, sdf, ns * sizeof(float));
        }
    }
    if (ray_certain && mc->n_kept > l->pick_cap) {
        free(l->pick);
        l->pick_cap = mc->n_kept + mc->n_kept / 4;
        if (!(l->pick = malloc(l->pick_cap * sizeof(uint32_t)))) {
            l->pick_cap = 0;
            return ESR_FAIL("lts: out of memory for %zu kept rows", mc->n_kept);
        }
    }
    size_t P;
    ESR_TRY(setup_points(l, m, sdf, mc, ray_certain, seed, &P));
    const size_t M = (size_t)l->M, PM = P * M;
    size_t rows;
    ESR_TRY(esr_lts_incident_trace(l, m, sdf, P, seed ^ 0x2545f4914f6cdd1dULL, &rows));
    build_point_rows(l, P);
    struct esr_point_query q = {rows, l->q_pos3, l->q_dir3, l->q_on};
    ESR_TRY(esr_point_fields_fwd(&l->pf, m, sdf, &q));
    const int lobes = m->cfg.env_lobes;
    const float *env = esr_model_values(m, ESR_COMP_ENV);
    esr_env_sg_fwd(env, lobes, l->wi3, PM, l->env3);
    esr_lights_balance_env(&m->lights, l->env3, PM);
    esr_lts_incident_gather(l, P);
    if (l->lights.n > 0)
        ESR_TRY(esr_lts_incident_lights(l, m, sdf, P));
    memset(l->d_lin3, 0, rows * 3 * sizeof(float));
    memset(l->d_li_off3, 0, PM * 3 * sizeof(float));
    memset(l->d_li_emo3, 0, PM * 3 * sizeof(float));
    memset(l->d_emit3, 0, P * 3 * sizeof(float));
    /* mean over points x 2 outgoing x 3 channels, per term */
    /* a hook (fine-tuning) has no other loss to weigh this one against */
    const float w = l->hook ? 1.0f : m->cfg.lts_weight, scale = w / (float)(P * 2 * 3);
    const int pair = ray_certain && m->cfg.pdra_sg; /* "w/o sg": one plain MSE */
    const float w_l = pair ? m->cfg.pdra_w_l : 1.0f, w_r = pair ? m->cfg.pdra_w_r : 1.0f;
    const struct point_weights pw = {scale, w_l, w_r, pair, m->cfg.lts_brdf_emo, m->cfg.lts_emo_base};
    double se_off = 0.0, se_emo = 0.0, prod = 0.0;
    if (l->hook) {
        ESR_TRY(l->hook->run(l->hook->user, l, m, sdf, &q, P, &se_emo));
    } else {
        /* each point writes only its own rows and directions */
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : se_off, se_emo, prod)
        for (size_t p = 0; p < P; p++)
            point_loss(l, p, &pw, &se_off, &se_emo, &prod);
    }
    size_t hits = 0;
    if (grads) { /* NULL: forward only (the calibration reads the estimates, not a gradient) */
        hits = esr_lts_incident_scatter(l, P, g_sdf);
        ESR_TRY(esr_point_fields_bwd(&l->pf, m, g_sdf, grads, l->d_tone3, l->d_lin3));
        if (!l->hook) {
            ESR_TRY(esr_material_fields_bwd(&l->mf, m, g_sdf, grads, l->d_emit3, l->d_brdf5));
            esr_lights_balance_env(&m->lights, l->d_env3, PM); /* through map / balance */
            esr_env_sg_bwd(env, lobes, l->wi3, PM, l->d_env3, grads + m->part[ESR_COMP_ENV].off);
        }
    }
    const double n = (double)(P * 2 * 3);
    out->mse_off = se_off / n;
    out->mse_emo = se_emo / n;
    out->loss = (double)w * (l->split && !l->hook ? prod / n : out->mse_off + out->mse_emo);
    out->points = P;
    out->secondary = PM;
    out->hits = hits;
    return ESR_OK;
}
