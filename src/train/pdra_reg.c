/* The pdra stage's regularisers (see pdra_reg.h). */
#include "train/pdra_reg.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/buffers.h"
#include "core/error.h"
#include "core/rng.h"
#include "fields/grid.h"

/* emission smoothness runs on every ES_STRIDE-th kept row (from a per-step offset) */
#define ES_STRIDE 4
/* the entropy's transmittance is clamped this far from 0 and 1 (H' is infinite there) */
#define ENT_EPS 1e-5f

void esr_pdra_reg_free(struct esr_pdra_reg *r)
{
    esr_material_fields_free(&r->mf);
    free(r->jit3);
    free(r->d_jit3);
    free(r->g0);
    free(r->g1);
    free(r->d_g);
    memset(r, 0, sizeof(*r));
}

static int reserve(struct esr_pdra_reg *r, size_t n)
{
    if (n <= r->cap)
        return ESR_OK;
    const size_t cap = n + n / 4;
    float **const b[] = {&r->jit3, &r->d_jit3, &r->g0, &r->g1, &r->d_g};
    r->cap = 0;
    ESR_TRY(esr_floats_realloc(b, sizeof b / sizeof b[0], cap * 3, "pdra regulariser rows"));
    r->cap = cap;
    return ESR_OK;
}

int esr_pdra_reg_init(struct esr_pdra_reg *r, const struct esr_model *m, size_t cap)
{
    memset(r, 0, sizeof(*r));
    int rc = esr_material_fields_init(&r->mf, m, cap, ESR_MATERIAL_TRAIN | ESR_MATERIAL_EMISSION_ONLY);
    if (rc == ESR_OK)
        rc = reserve(r, cap);
    if (rc != ESR_OK)
        esr_pdra_reg_free(r);
    return rc;
}

/* jit3 = pos3 + sigma N(0, 1) per coordinate (Box-Muller on stream i of seed). */
static void jitter(const float *pos3, size_t n, float sigma, uint64_t seed, float *jit3)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        struct esr_rng g = esr_rng_init(seed, i);
        for (int a = 0; a < 3; a++)
            jit3[i * 3 + a] = pos3[i * 3 + a] + sigma * esr_rng_normal(&g);
    }
}

static float sign(float x)
{
    return (float)((x > 0.0f) - (x < 0.0f));
}

int esr_pdra_reg_smooth(struct esr_pdra_reg *r, const struct esr_model *m, const float *sdf,
                        float *g_sdf, float *grads, const struct esr_pdra_reg_batch *b)
{
    const struct esr_march *mc = b->mc;
    const float *emit3 = b->emit3;
    float *d_emit3 = b->d_emit3;
    const uint64_t seed = b->seed;
    const size_t n = mc->n_kept;
    const struct esr_grid *g = esr_model_grid(m, ESR_COMP_SDF);
    const float vox = esr_grid_voxel_size(g, 0);
    r->es_loss = r->ns_loss = 0.0;
    if (n == 0)
        return ESR_OK;
    ESR_TRY(reserve(r, n));
    const float w_es = m->cfg.pdra_w_es, w_ns = m->cfg.pdra_w_ns;
    const float scale = 1.0f / (3.0f * (float)n);
    if (w_es > 0.0f) { /* on every ES_STRIDE-th kept row: the E MLP is the cost */
        const size_t first = (size_t)(seed % ES_STRIDE), m_rows = n > first ? (n - first + ES_STRIDE - 1) / ES_STRIDE : 0;
        for (size_t j = 0; j < m_rows; j++)
            memcpy(r->g0 + j * 3, mc->kpos3 + (first + j * ES_STRIDE) * 3, 3 * sizeof(float));
        jitter(r->g0, m_rows, ESR_PDRA_ES_SIGMA_VOX * vox, seed, r->jit3);
        ESR_TRY(esr_material_fields_fwd(&r->mf, m, sdf, r->jit3, m_rows));
        const float es_scale = 1.0f / (3.0f * (float)(m_rows ? m_rows : 1));
        double sum = 0.0;
        for (size_t j = 0; j < m_rows; j++)
            for (int c = 0; c < 3; c++) {
                const size_t k = (first + j * ES_STRIDE) * 3 + (size_t)c;
                const float d = emit3[k] - r->mf.emit3[j * 3 + c];
                sum += fabsf(d);
                d_emit3[k] += w_es * es_scale * sign(d);
                r->d_jit3[j * 3 + c] = -w_es * es_scale * sign(d);
            }
        r->es_loss = w_es * es_scale * sum;
        ESR_TRY(esr_material_fields_bwd(&r->mf, m, g_sdf, grads, r->d_jit3, NULL));
    }
    if (w_ns > 0.0f) {
        jitter(mc->kpos3, n, ESR_PDRA_NS_SIGMA_VOX * vox, seed ^ 0x9e3779b9ULL, r->jit3);
        esr_grid_sample_dpoint(g, sdf, 0, mc->kpos3, n, r->g0);
        esr_grid_sample_dpoint(g, sdf, 0, r->jit3, n, r->g1);
        double sum = 0.0;
        for (size_t i = 0; i < n * 3; i++) {
            const float d = r->g0[i] - r->g1[i];
            sum += fabsf(d);
            r->d_g[i] = w_ns * scale * sign(d);
        }
        r->ns_loss = w_ns * scale * sum;
        esr_grid_sample_dpoint_bwd(g, 0, mc->kpos3, n, r->d_g, g_sdf);
        for (size_t i = 0; i < n * 3; i++)
            r->d_g[i] = -r->d_g[i];
        esr_grid_sample_dpoint_bwd(g, 0, r->jit3, n, r->d_g, g_sdf);
    }
    return ESR_OK;
}

double esr_pdra_reg_entropy(float w_ent, const float *t_last, int n, float *d_t_last)
{
    double sum = 0.0;
    const float scale = w_ent / (float)(n > 0 ? n : 1);
    for (int i = 0; i < n; i++) {
        const float raw = t_last[i];
        const float t = fminf(fmaxf(raw, ENT_EPS), 1.0f - ENT_EPS);
        sum += -(double)t * log(t) - (1.0 - t) * log(1.0 - t);
        /* dH/dT = ln((1 - T) / T); zero where the clamp is active */
        d_t_last[i] = raw > ENT_EPS && raw < 1.0f - ENT_EPS ? scale * logf((1.0f - t) / t) : 0.0f;
    }
    return (double)scale * sum;
}
