/* Model assembly per stage (see model.h). */
#include "model/model.h"

#include <math.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "fields/density.h"
#include "fields/sdf.h"
#include "model/sdf_init.h"

static const char *stage_names[ESR_STAGE_COUNT] = {"alphamask", "coarse", "fine"};

const char *esr_stage_name(enum esr_stage s)
{
    return s >= 0 && s < ESR_STAGE_COUNT ? stage_names[s] : NULL;
}

int esr_stage_from_name(const char *name, enum esr_stage *out)
{
    for (int i = 0; i < ESR_STAGE_COUNT; i++)
        if (!strcmp(name, stage_names[i])) {
            *out = (enum esr_stage)i;
            return ESR_OK;
        }
    return ESR_FAIL("unknown stage '%s' (valid: alphamask, coarse, fine)", name);
}

/* A cubic grid of `res` points per axis over the scene box, with its values taken from p. */
static int take_grid(struct esr_model *m, struct esr_grid *g, size_t *off, int channels, int res)
{
    ESR_TRY(esr_grid_init(g, channels, res, res, res, m->scene_min, m->scene_max));
    return esr_nn_params_take(&m->params, esr_grid_count(g), off);
}

static int take_mlp(struct esr_model *m, struct esr_mlp *mlp, int n_in, int width, int depth,
                    int n_out, enum esr_nn_act out_act)
{
    struct esr_mlp_desc d;
    d.n_in = n_in;
    d.width = width;
    d.n_hidden = depth;
    d.n_out = n_out;
    d.hidden_act = ESR_NN_ACT_RELU;
    d.out_act = out_act;
    return esr_mlp_init(mlp, &d, &m->params);
}

/* Small uniform noise so feature channels are not all identical at the start. */
static void init_noise(float *v, size_t n, uint64_t seed, float amp)
{
    for (size_t i = 0; i < n; i++) {
        struct esr_rng r = esr_rng_init(seed, i);
        v[i] = amp * (2.0f * esr_rng_float(&r) - 1.0f);
    }
}

static int layout_alphamask(struct esr_model *m)
{
    const struct esr_stage_config *s = &m->cfg.alphamask;
    ESR_TRY(take_grid(m, &m->density, &m->density_off, 1, s->res));
    /* off RGB + on RGB logits (DVGO's direct colour grid, sigmoid) */
    ESR_TRY(take_grid(m, &m->feat, &m->feat_off, 6, s->res));
    /* alpha_init 1e-3, i.e. ~5e-4 per half-voxel step: above the 1e-4 pruning threshold (a
     * pruned sample gets no gradient at all; DVGO uses 1e-6 with a 1e-7 threshold) and below the
     * mask-cache threshold, so space no ray has seen stays out of the mask */
    m->density_shift = esr_density_shift(1e-3f);
    return ESR_OK;
}

static int layout_coarse(struct esr_model *m)
{
    const struct esr_stage_config *s = &m->cfg.coarse;
    ESR_TRY(take_grid(m, &m->sdf, &m->sdf_off, 1, s->res));
    ESR_TRY(take_grid(m, &m->feat, &m->feat_off, s->feat_channels, s->res));
    m->pe_dir.n_dims = 3;
    m->pe_dir.n_freqs = m->cfg.pe_dir;
    int n_in = s->feat_channels + esr_pe_out_dims(&m->pe_dir) + 1;
    return take_mlp(m, &m->colour, n_in, s->mlp_width, s->mlp_depth, 3, ESR_NN_ACT_SIGMOID);
}

static int layout_fine(struct esr_model *m)
{
    const struct esr_stage_config *s = &m->cfg.fine;
    ESR_TRY(take_grid(m, &m->sdf, &m->sdf_off, 1, s->res));
    /* Feature grids at the coarse resolution: their Adam and TV passes touch every entry each
     * step, and the MLPs' PE(x) input carries the fine detail. */
    int fres = m->cfg.coarse.res;
    ESR_TRY(take_grid(m, &m->feat_off_g, &m->feat_off_off, s->feat_channels, fres));
    ESR_TRY(take_grid(m, &m->feat_emo_g, &m->feat_emo_off, s->feat_channels, fres));
    esr_geo_feature_default(&m->geo);
    m->geo.n_scales = m->cfg.geo_scales;
    m->pe_pos.n_dims = 3;
    m->pe_pos.n_freqs = m->cfg.pe_pos;
    m->pe_dir.n_dims = 3;
    m->pe_dir.n_freqs = m->cfg.pe_dir;
    m->pe_tone.n_dims = 3;
    m->pe_tone.n_freqs = m->cfg.tone_pe;
    int n_in = s->feat_channels + esr_pe_out_dims(&m->pe_pos) + esr_geo_feature_dim(&m->geo) +
               esr_pe_out_dims(&m->pe_dir);
    ESR_TRY(take_mlp(m, &m->rad_off, n_in, s->mlp_width, s->mlp_depth, 3, ESR_NN_ACT_SOFTPLUS));
    ESR_TRY(take_mlp(m, &m->rad_emo, n_in, s->mlp_width, s->mlp_depth, 3, ESR_NN_ACT_SOFTPLUS));
    return take_mlp(m, &m->tone, esr_pe_out_dims(&m->pe_tone), m->cfg.tone_width, 1, 3,
                    ESR_NN_ACT_SIGMOID);
}

/* Initial values of the stage's parameters. */
static int init_values(struct esr_model *m, const struct esr_model *prev)
{
    float *w = m->params.w;
    uint64_t seed = (uint64_t)m->cfg.seed * 1000 + (uint64_t)m->stage;
    switch (m->stage) {
    case ESR_STAGE_ALPHAMASK:
        return ESR_OK; /* density 0 (alpha_init via the shift), colour logits 0 */
    case ESR_STAGE_COARSE: {
        int used = 0;
        if (prev && prev->stage == ESR_STAGE_ALPHAMASK)
            ESR_TRY(esr_sdf_init_from_density(m, prev, m->cfg.sdf_init_alpha, &used));
        if (!used)
            ESR_TRY(esr_sdf_init_sphere(&m->sdf, w + m->sdf_off, 1.0f));
        init_noise(w + m->feat_off, esr_grid_count(&m->feat), seed, 1e-2f);
        esr_mlp_init_weights(&m->colour, w, seed + 1, 0.0f);
        return ESR_OK;
    }
    default:
        if (prev && prev->stage >= ESR_STAGE_COARSE)
            ESR_TRY(esr_grid_resample(&prev->sdf, prev->params.w + prev->sdf_off, &m->sdf,
                                      w + m->sdf_off));
        else
            ESR_TRY(esr_sdf_init_sphere(&m->sdf, w + m->sdf_off, 1.0f));
        init_noise(w + m->feat_off_off, esr_grid_count(&m->feat_off_g), seed, 1e-2f);
        init_noise(w + m->feat_emo_off, esr_grid_count(&m->feat_emo_g), seed + 7, 1e-2f);
        esr_mlp_init_weights(&m->rad_off, w, seed + 1, 0.0f);
        /* emission starts near zero: softplus(-5) ~ 0.007, so off-rays are not tinted */
        esr_mlp_init_weights(&m->rad_emo, w, seed + 2, -5.0f);
        esr_mlp_init_weights(&m->tone, w, seed + 3, 0.0f);
        return ESR_OK;
    }
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
    int rc = esr_nn_params_init(&m->params, 0);
    if (rc == ESR_OK)
        rc = stage == ESR_STAGE_ALPHAMASK ? layout_alphamask(m)
             : stage == ESR_STAGE_COARSE  ? layout_coarse(m)
                                          : layout_fine(m);
    if (rc == ESR_OK)
        rc = esr_adam_init(&m->adam, m->params.count);
    if (rc == ESR_OK)
        rc = init_values(m, prev);
    /* the mask lattice is the alphamask grid's; until it is trained every voxel is "occupied" */
    if (rc == ESR_OK && prev && prev->has_mask) {
        struct esr_grid lat;
        rc = esr_grid_init(&lat, 1, prev->mask.nx, prev->mask.ny, prev->mask.nz, prev->mask.bmin,
                           prev->mask.bmax);
        if (rc == ESR_OK)
            rc = esr_mask_alloc(&m->mask, &lat);
        if (rc == ESR_OK) {
            memcpy(m->mask.occ, prev->mask.occ, esr_grid_voxels(&lat));
            m->has_mask = 1;
        }
    }
    if (rc == ESR_OK && m->has_mask && stage == ESR_STAGE_FINE && prev &&
        prev->stage == ESR_STAGE_COARSE && cfg->fine_mask_band > 0.0f)
        rc = esr_mask_narrow_to_sdf(m, prev, cfg->fine_mask_band * esr_grid_voxel_size(&prev->sdf, 0));
    m->inv_s = esr_model_inv_s_at(m, 0);
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
    memset(m, 0, sizeof(*m));
}

float esr_model_inv_s_at(const struct esr_model *m, long step)
{
    if (m->stage == ESR_STAGE_ALPHAMASK)
        return 0.0f; /* density stage: no NeuS */
    const struct esr_stage_config *sc = m->stage == ESR_STAGE_FINE ? &m->cfg.fine : &m->cfg.coarse;
    return sc->s0 + (float)step / sc->s_div;
}

int esr_model_sdf_grid(const struct esr_model *m, const struct esr_grid **grid, const float **data)
{
    if (m->stage < ESR_STAGE_COARSE)
        return ESR_FAIL("model: the %s stage has no SDF grid (train the coarse stage first)",
                        esr_stage_name((enum esr_stage)m->stage));
    *grid = &m->sdf;
    *data = m->params.w + m->sdf_off;
    return ESR_OK;
}
