/* A small model for gradient and layer tests (header-only so any test program can use it). */
#ifndef ESR_TEST_MODEL_H
#define ESR_TEST_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "core/rng.h"
#include "model/model.h"

/* Fast-preset config shrunk so every gradient entry can be checked in seconds: 8^3 grids,
 * 2 feature channels, 8-wide MLPs, few encoding frequencies. */
static inline void test_small_config(struct esr_train_config *c, float lambda_tau)
{
    esr_config_defaults(c, ESR_PRESET_FAST);
    c->coarse.res = 8; /* coarse grids, and the fine stage's feature grids */
    c->coarse.feat_channels = 2;
    c->coarse.mlp_width = 8;
    c->fine.res = 8;
    c->fine.feat_channels = 2;
    c->fine.mlp_width = 8;
    c->fine.mlp_depth = 2;
    c->tone_width = 8;
    c->tone_pe = 2;
    c->pe_pos = 2;
    c->geo_scales = 2;
    c->lambda_tau = lambda_tau;
    c->lts.res = 8;
    c->pdra.res = 8;
    c->lts_points = 4;
    c->lts_dirs = 16;
    c->field_width = 8;
    c->field_depth = 1;
    c->env_lobes = 4;
    c->normal_ksize = 0; /* an 8^3 grid is too small for the normals' smoothing */
}

/* Values in [-amp, amp) for component c, so its inputs matter. */
static inline void test_randomise(struct esr_model *m, enum esr_component c, float amp, uint64_t seed)
{
    float *v = esr_model_values(m, c);
    for (size_t i = 0; i < m->part[c].count; i++) {
        struct esr_rng r = esr_rng_init(seed, i);
        v[i] += amp * (2.0f * esr_rng_float(&r) - 1.0f);
    }
}

#endif
