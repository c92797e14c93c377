/* Model assembly per stage from the component and stage tables (see model.h). */
#include "model/model.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "core/hash.h"
#include "core/limits.h"
#include "core/rng.h"
#include "fields/density.h"
#include "fields/env_sg.h"
#include "fields/sdf.h"
#include "model/sdf_init.h"

/* Small uniform noise so feature channels are not all identical at the start. */
static void init_noise(float *v, size_t n, uint64_t seed, float amp)
{
    for (size_t i = 0; i < n; i++) {
        struct esr_rng r = esr_rng_init(seed, i);
        v[i] = amp * (2.0f * esr_rng_float(&r) - 1.0f);
    }
}

/* The SDF of a fresh stage: the signed distance to the previous stage's occupied voxels
 * (alphamask), the previous SDF resampled, or a unit sphere. */
static int init_sdf(struct esr_model *m, const struct esr_model *prev)
{
    float *sdf = esr_model_values(m, ESR_COMP_SDF);
    if (prev && esr_model_has(prev, ESR_COMP_SDF))
        return esr_grid_resample(esr_model_grid(prev, ESR_COMP_SDF),
                                 esr_model_values(prev, ESR_COMP_SDF),
                                 esr_model_grid(m, ESR_COMP_SDF), sdf);
    int used = 0;
    if (prev && esr_model_has(prev, ESR_COMP_DENSITY))
        ESR_TRY(esr_sdf_init_from_density(m, prev, m->cfg.sdf_init_alpha, &used));
    return used ? ESR_OK : esr_sdf_init_sphere(esr_model_grid(m, ESR_COMP_SDF), sdf, 1.0f);
}

/* 1 when prev has component c with the same shape as m's (then m starts from its values). */
static int same_shape(const struct esr_model *m, const struct esr_model *prev, enum esr_component c)
{
    if (!prev || !esr_model_has(prev, c) || prev->part[c].count != m->part[c].count)
        return 0;
    const struct esr_part *a = &m->part[c], *b = &prev->part[c];
    switch (esr_component_info(c)->kind) {
    case ESR_KIND_GRID:
        return a->grid.nx == b->grid.nx && a->grid.ny == b->grid.ny && a->grid.nz == b->grid.nz &&
               a->grid.channels == b->grid.channels;
    case ESR_KIND_MLP:
        return a->mlp.desc.n_in == b->mlp.desc.n_in && a->mlp.desc.width == b->mlp.desc.width &&
               a->mlp.desc.n_hidden == b->mlp.desc.n_hidden && a->mlp.desc.n_out == b->mlp.desc.n_out;
    case ESR_KIND_VECTOR:
        break;
    }
    return 1;
}

/* Initial values of every component of the stage: what the previous stage trained when it has
 * the component in the same shape (the lts stage continues the fine stage's SDF and radiance),
 * else the component table's init kind with its seed offset. */
static int init_values(struct esr_model *m, const struct esr_model *prev)
{
    const uint64_t seed = (uint64_t)m->cfg.seed * 1000 + (uint64_t)m->stage;
    for (int c = 0; c < ESR_COMP_COUNT; c++) {
        if (!esr_model_has(m, (enum esr_component)c))
            continue;
        if (same_shape(m, prev, (enum esr_component)c)) {
            memcpy(esr_model_values(m, (enum esr_component)c),
                   esr_model_values(prev, (enum esr_component)c), m->part[c].count * sizeof(float));
            continue;
        }
        const struct esr_component_info *ci = esr_component_info((enum esr_component)c);
        const uint64_t cs = seed + (uint64_t)ci->seed_offset;
        switch (ci->init) {
        case ESR_INIT_ZERO:
            break; /* the parameter buffer starts zeroed */
        case ESR_INIT_SDF:
            ESR_TRY(init_sdf(m, prev));
            break;
        case ESR_INIT_NOISE:
            init_noise(esr_model_values(m, (enum esr_component)c), m->part[c].count, cs, 1e-2f);
            break;
        case ESR_INIT_KAIMING:
            esr_mlp_init_weights(&m->part[c].mlp, m->params.w, cs, ci->last_bias);
            break;
        case ESR_INIT_ENV_SG:
            esr_env_sg_init(esr_model_values(m, (enum esr_component)c), m->cfg.env_lobes, cs);
            break;
        }
    }
    return ESR_OK;
}

/* Encodings and geometry feature (read by the MLP layouts), then every component of the stage in
 * table order. */
static int layout(struct esr_model *m)
{
    esr_geo_feature_default(&m->geo);
    m->geo.n_scales = m->cfg.geo_scales;
    m->pe_pos.n_dims = m->pe_dir.n_dims = m->pe_tone.n_dims = 3;
    m->pe_pos.n_freqs = m->cfg.pe_pos;
    m->pe_dir.n_freqs = m->cfg.pe_dir;
    m->pe_tone.n_freqs = m->cfg.tone_pe;
    /* alpha_init 1e-3, i.e. ~5e-4 per half-voxel step: above the 1e-4 pruning threshold (a
     * pruned sample gets no gradient at all; DVGO uses 1e-6 with a 1e-7 threshold) and below the
     * mask-cache threshold, so space no ray has seen stays out of the mask */
    m->density_shift = esr_density_shift(1e-3f);
    for (int c = 0; c < ESR_COMP_COUNT; c++)
        if (esr_stage_has((enum esr_stage)m->stage, (enum esr_component)c))
            ESR_TRY(esr_component_info((enum esr_component)c)->layout(m, (enum esr_component)c));
    return ESR_OK;
}

/* Takes over prev's mask cache (its lattice is the alphamask grid's); narrowed to a band around
 * prev's surface when the stage asks for it. */
static int inherit_mask(struct esr_model *m, const struct esr_model *prev)
{
    struct esr_grid lat;
    ESR_TRY(esr_grid_init(&lat, 1, prev->mask.nx, prev->mask.ny, prev->mask.nz, prev->mask.bmin,
                          prev->mask.bmax));
    ESR_TRY(esr_mask_alloc(&m->mask, &lat));
    memcpy(m->mask.occ, prev->mask.occ, esr_grid_voxels(&lat));
    m->has_mask = 1;
    if (esr_stage_info((enum esr_stage)m->stage)->narrows_mask && esr_model_has(prev, ESR_COMP_SDF) &&
        m->cfg.fine_mask_band > 0.0f)
        return esr_mask_narrow_to_sdf(
            m, prev, m->cfg.fine_mask_band * esr_grid_voxel_size(esr_model_grid(prev, ESR_COMP_SDF), 0));
    return ESR_OK;
}

/* Bytes of m's mask cache (one per cell; 0 without one). */
static size_t mask_bytes(const struct esr_model *m)
{
    return m->has_mask ? (size_t)m->mask.nx * m->mask.ny * m->mask.nz : 0;
}

/* A layout pass that only counts parameters: 16 bytes each (values, gradients, both Adam
 * moments), and the mask cache taken over from prev. */
int esr_model_memory_need(const struct esr_train_config *cfg, enum esr_stage stage,
                          const struct esr_model *prev, const float scene_min[3],
                          const float scene_max[3], size_t *bytes, size_t *n_params)
{
    struct esr_model dry;
    memset(&dry, 0, sizeof dry);
    dry.cfg = *cfg;
    dry.stage = stage;
    memcpy(dry.scene_min, scene_min, sizeof dry.scene_min);
    memcpy(dry.scene_max, scene_max, sizeof dry.scene_max);
    dry.params.count_only = 1;
    ESR_TRY(layout(&dry));
    *bytes = dry.params.count * 4 * sizeof(float) + (prev ? mask_bytes(prev) : 0);
    if (n_params)
        *n_params = dry.params.count;
    return ESR_OK;
}

size_t esr_model_memory_held(const struct esr_model *m)
{
    return m->params.count * 4 * sizeof(float) + mask_bytes(m);
}

uint64_t esr_model_fingerprint(const struct esr_model *m)
{
    const uint64_t lights = esr_lights_fingerprint(&m->lights);
    uint64_t h = esr_hash_bytes(ESR_HASH_INIT, &m->stage, sizeof m->stage);
    h = esr_hash_bytes(h, &m->step, sizeof m->step);
    h = esr_hash_floats(h, m->params.w, m->params.count);
    h = esr_hash_floats(h, &m->density_shift, 1);
    if (m->has_mask && m->mask.occ)
        h = esr_hash_bytes(h, m->mask.occ, (size_t)m->mask.nx * m->mask.ny * m->mask.nz);
    return esr_hash_bytes(h, &lights, sizeof lights);
}

/* Refuses a model that would not fit in memory before any of it is allocated: a wrong option or
 * a corrupt checkpoint then fails with a message instead of being killed by the system. */
static int check_memory(const struct esr_model *m, const struct esr_model *prev)
{
    size_t need, n_params;
    ESR_TRY(esr_model_memory_need(&m->cfg, (enum esr_stage)m->stage, prev, m->scene_min, m->scene_max,
                                  &need, &n_params));
    char what[160];
    snprintf(what, sizeof what, "the %s stage's model with these options (%zu parameters)",
             esr_stage_name((enum esr_stage)m->stage), n_params);
    return esr_limits_check_memory(0, need, what);
}

int esr_model_init(struct esr_model *m, const struct esr_train_config *cfg, enum esr_stage stage,
                   const struct esr_model *prev, const float scene_min[3], const float scene_max[3])
{
    memset(m, 0, sizeof(*m));
    if (stage < 0 || stage >= ESR_STAGE_COUNT)
        return ESR_FAIL("model: invalid stage %d", (int)stage);
    ESR_TRY(esr_config_validate(cfg));
    m->cfg = *cfg;
    m->stage = stage;
    for (int a = 0; a < 3; a++) {
        m->scene_min[a] = scene_min[a];
        m->scene_max[a] = scene_max[a];
    }
    int rc = check_memory(m, prev);
    if (rc == ESR_OK)
        rc = esr_nn_params_init(&m->params, 0);
    if (rc == ESR_OK)
        rc = layout(m);
    if (rc == ESR_OK)
        rc = esr_adam_init(&m->adam, m->params.count);
    if (rc == ESR_OK)
        rc = init_values(m, prev);
    if (rc == ESR_OK && prev && prev->has_mask)
        rc = inherit_mask(m, prev);
    m->inv_s = esr_stage_inv_s(&m->cfg, stage, 0);
    m->lr_scale = 1.0f;
    if (rc != ESR_OK)
        esr_model_free(m);
    return rc;
}

void esr_model_free(struct esr_model *m)
{
    esr_nn_params_free(&m->params);
    esr_adam_free(&m->adam);
    if (m->has_mask)
        esr_mask_free(&m->mask);
    esr_lights_free(&m->lights);
    memset(m, 0, sizeof(*m));
}

int esr_model_sdf_grid(const struct esr_model *m, const struct esr_grid **grid, const float **data)
{
    if (!esr_model_has(m, ESR_COMP_SDF))
        return ESR_FAIL("model: the %s stage has no SDF grid (train the coarse stage first)",
                        esr_stage_name((enum esr_stage)m->stage));
    *grid = esr_model_grid(m, ESR_COMP_SDF);
    *data = esr_model_values(m, ESR_COMP_SDF);
    return ESR_OK;
}
