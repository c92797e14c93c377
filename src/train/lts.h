/* The light-transport-segment (LTS) loss of the lts stage (METHOD.md stage 4, seed eq. 4): at
 * points on the surface the radiance fields must agree with a re-rendering of themselves,
 *     L^_off(x, wo) = sum_j (L_i^off(x, w_j)) R(x, wo, w_j) / (M pdf_j)
 *     L^_emo(x, wo) = E(x) + sum_j L_i^emo(x, w_j) R(x, wo, w_j) / (M pdf_j)
 *     loss = lts_weight * (MSE(L_off, L^_off) + MSE(L_emo, L^_emo))
 * (in pdra the emo MSE's gradient is weighted: w_r on L_emo, w_l on E, the stop-gradient pair
 * of METHOD.md stage 5 in squared form; the loss value is the plain MSE)
 * for the camera direction and one random outgoing direction per point. Both sides are trained
 * (radiance at the point and at the secondary hits, E, BRDF, environment).
 *
 * Points: lts_points kept samples of the primary batch (stratified over the kept list; with pdra's
 * ray groups half from the uncertain rays' samples and half from the certain ones'), normals
 * from the smoothed normal SDF (esr_model_normal_sdf, refreshed every NORMAL_REFRESH steps,
 * detached). Secondary rays start one voxel off the surface along the normal. Incident
 * radiance (lts_estimator, train/lts_incident.h):
 *   ESR_LTS_FIRST_HIT (fast, the default): lts_dirs stratified cosine-weighted directions; each
 *     ray sphere-traces the SDF (volume/first_hit.h) to its first hit y, where L_i = the
 *     radiance fields at y seen along the ray (L_off, and L_emo = L_on - sg(L_off)); a miss sees
 *     the environment map (off) and nothing (emo). No gradient reaches the geometry.
 *   ESR_LTS_VOLUME (the authors', faithful): lts_dirs uniform directions; L_i is volume-rendered
 *     along each ray with the primary rays' march (NeuS alpha, mask cache, step, kept samples),
 *     L_i^off = sum w L_off + T_last env(w), L_i^emo = sum w L_emo; the gradient reaches the
 *     samples' radiance, the environment and the SDF through the alphas. */
#ifndef ESR_TRAIN_LTS_H
#define ESR_TRAIN_LTS_H

#include <stddef.h>
#include <stdint.h>

#include "model/material_fields.h"
#include "model/model.h"
#include "model/point_fields.h"
#include "volume/march.h"

#ifdef __cplusplus
extern "C" {
#endif

enum esr_lts_estimator { ESR_LTS_FIRST_HIT = 0, ESR_LTS_VOLUME = 1 };

struct esr_lts_stats {
    double loss;            /* weighted loss added */
    double mse_off, mse_emo; /* with a hook, the hook's (fine-tuning's: weighted) */
    size_t points, secondary, hits; /* hits: secondary rays that reached a surface (first hit)
                                        or whose final transmittance is below 1/2 (volume) */
};

/* lts_dirs' upper bound (model/config.c) */
#define ESR_LTS_MAX_DIRS 4096

/* A loss that replaces the LTS loss on the same points (radiance fine-tuning, whose state and
 * loss live in edit/finetune_loss.h): called each step after the points' and the hits' rows q
 * are rendered into l->pf (and the points' materials into l->mf), it adds its gradient into
 * l->d_lin3 and its squared error into *se_emo (the stats' mse_emo). With a hook the normals
 * are computed once (the geometry is frozen), and only the rows' radiance gets a gradient (not
 * the materials, E or the environment). */
struct esr_lts;
struct esr_lts_loss_hook {
    int (*run)(void *user, struct esr_lts *l, const struct esr_model *m, const float *sdf,
               const struct esr_point_query *q, size_t P, double *se_emo);
    void *user;
};

struct esr_lts {
    int P, M;                  /* points, incident directions per point */
    int estimator;             /* enum esr_lts_estimator */
    int lobe;                  /* first hit: directions per outgoing direction from the BRDF's lobe */
    float emo;                 /* 1, or 0 without lights-on images (option emission): the emo
                                  term's error is dropped */
    int split;                 /* option lts_split in force: the loss is (L - A)(L - B), A and B
                                  the estimates from the even and the odd directions alone
                                  (independent, each unbiased), whose expectation is the squared
                                  bias of the estimate without its variance; the gradient is the
                                  same as the MSE's for L and E, and for direction j's terms the
                                  other half's error in place of the whole estimate's */
    long calls;
    float *normal_sdf;         /* smoothed SDF the normals come from (refreshed) */
    /* per point [P]: position, normal, two outgoing directions (away from the surface) */
    float *pos3, *nrm3, *wo3;
    /* per (point, direction) [P*M]: direction, sampling weight (core/brdf_sampling.h; 1/(M pdf)
     * for one proposal), hit row or -1, environment radiance, incident radiance off/emo and their
     * gradients */
    float *wi3, *wt, *env3, *d_env3, *li_off3, *li_emo3, *d_li_off3, *d_li_emo3;
    float *orig3, *hit_t, *hit_pos3;
    float *R3;                 /* [P*M*3] BRDF x cosine of the current outgoing direction */
    float *hat3;               /* [P*2*2*3] the estimates L^_off, L^_emo per point and outgoing
                                  direction (NaN for a back-facing one): (p, o, off/emo, rgb) */
    uint8_t *hit_flags;
    int32_t *hit_row;
    /* first hit: the lattice points of the SDF the renderer skips (once) and, each call, the SDF
     * as first hits see it, no surface there (model/render_sdf.h) */
    uint8_t *skipped;
    float *hit_sdf;
    /* The lights the transport sees (pdra.lights_at, esr_lts_set_lights; n 0: none, the seed's
     * transport): a first hit on one of them sees its calibrated emission instead of the
     * radiance field there, without gradient (emo_fixed [P*M]); light_pos3 [P*M*3] and light_mf
     * query E at those hits. */
    struct esr_lights lights;
    uint8_t *emo_fixed;
    float *light_pos3;
    struct esr_material_fields light_mf;
    /* point-field query rows [cap_rows]: 4 per point (2 outgoing x off/on), then 2 (off, on)
     * per hit (first hit) or per kept secondary sample (volume) */
    size_t cap_rows;
    float *q_pos3, *q_dir3, *d_tone3, *d_lin3;
    uint8_t *q_on;
    /* volume estimator: the secondary rays' march and per kept sample [cap_sec * 3] the off and
     * emo radiance and their gradients */
    struct esr_march sec;
    size_t cap_sec;
    float *sec_off3, *sec_emo3, *d_sec_off3, *d_sec_emo3;
    float *d_emit3, *d_brdf5;
    uint8_t *certain;          /* [P] the point's ray is certain (pdra): L^_emo without E */
    uint32_t *pick;            /* [pick_cap] kept rows, uncertain first (pdra) */
    size_t pick_cap;
    struct esr_point_fields pf;
    struct esr_material_fields mf;
    /* A loss in place of the LTS loss (NULL in training): radiance fine-tuning's
     * (edit/finetune_loss.h). */
    const struct esr_lts_loss_hook *hook;
};

int esr_lts_init(struct esr_lts *l, const struct esr_model *m);
/* esr_lts_init with its own points per call, directions per point and estimator instead of m's
 * options (the lights' calibration, a fine-tune); the rest (lobe directions, split) as m's. */
int esr_lts_init_sized(struct esr_lts *l, const struct esr_model *m, int points, int dirs,
                       int estimator);
void esr_lts_free(struct esr_lts *l);
/* Hands l's light transport the lights in *lights (taken over, *lights zeroed; found and
 * calibrated from the model being trained): from the next call, a secondary ray whose first hit
 * lies on a light sees the light's calibrated emission there, scale x E (its unseen part: scale
 * x its mean field), not the radiance field's L_emo, with no gradient to either. The photos
 * show a light clipped near 1, so the field's L_emo on it stays near 1 whatever the light
 * casts, and without this the BRDF round a light absorbs the difference (docs/design.md,
 * "Lights in the transport"). First-hit estimator only. */
int esr_lts_set_lights(struct esr_lts *l, const struct esr_model *m, struct esr_lights *lights);
/* The next step recomputes the normals from the model's SDF, as a run resumed from a checkpoint
 * saved now would (its workspace starts without them): the trainer calls it after each
 * checkpoint inside a stage, so a resumed stage trains exactly as one never stopped. */
void esr_lts_refresh_normals(struct esr_lts *l);

/* The batch an LTS call takes its points from. */
struct esr_lts_batch {
    const struct esr_march *mc;  /* the primary batch's last forward: the points are taken from
                                    its kept list */
    const uint8_t *ray_certain;  /* per ray of the batch, or NULL (none): the pdra stage's certain
                                    rays, whose points re-render L_emo from reflection alone and
                                    give E no gradient */
    uint64_t seed;               /* the call's draws (points, directions, secondary rays) */
};

/* The LTS loss on points of batch b, its gradient ADDED into grads (flat base) and g_sdf (the
 * SDF the fields read). `sdf` is that SDF. grads NULL: the forward only (the estimates and the
 * stats, hits 0; g_sdf is not touched). */
int esr_lts_run(struct esr_lts *l, const struct esr_model *m, const float *sdf, float *g_sdf,
                float *grads, const struct esr_lts_batch *b, struct esr_lts_stats *out);

#ifdef __cplusplus
}
#endif
#endif
