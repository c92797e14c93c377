/* The option table and everything derived from it (see config.h). */
#include "model/config.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/suggest.h"
#include "io/file.h"
#include "io/json_file.h"

enum opt_type { OPT_INT, OPT_FLOAT };

/* The presets with a column of their own in the table: fast and paper. */
#define PRESET_COLUMNS 2

struct opt {
    const char *name;
    enum opt_type type;
    size_t offset;                 /* into struct esr_train_config */
    double lo, hi;                 /* inclusive bounds */
    double def[PRESET_COLUMNS];    /* fast, paper (smoke is fast changed: smoke_changes) */
    const char *help;
};

#define OFF(field) offsetof(struct esr_train_config, field)
/* A default as two named columns, so every option states its fast and its paper value itself: a
 * shared cell made tuning `fast` silently retune `paper` (coarse.lr_grid, tv_sdf_grad). */
#define DEF(fast, paper) {[ESR_PRESET_FAST] = (fast), [ESR_PRESET_PAPER] = (paper)}
/* One stage option in the five stages: the same bounds and help, one DEF per stage. Written as a
 * stage x preset grid so the macro's arity refuses a missing cell. */
#define STAGE_OPT(field, type, lo, hi, help, am, co, fi, lt, pd)                              \
    {"alphamask." #field, type, OFF(alphamask.field), lo, hi, am, help},                       \
    {"coarse." #field, type, OFF(coarse.field), lo, hi, co, help},                             \
    {"fine." #field, type, OFF(fine.field), lo, hi, fi, help},                                 \
    {"lts." #field, type, OFF(lts.field), lo, hi, lt, help},                                   \
    {"pdra." #field, type, OFF(pdra.field), lo, hi, pd, help}

static const struct opt opts[] = {
    {"seed", OPT_INT, OFF(seed), 0, 2147483647, DEF(1, 1), "random seed (rays, jitter, init)"},
    {"batch_rays", OPT_INT, OFF(batch_rays), 16, 65536, DEF(4096, 8192), "rays per iteration"},
    {"save_every", OPT_INT, OFF(save_every), 1, 1000000, DEF(500, 2000),
     "checkpoint every N iterations within a stage"},
    {"log_every", OPT_INT, OFF(log_every), 1, 1000000, DEF(50, 100), "log line every N iterations"},
    {"threads", OPT_INT, OFF(threads), 0, 1024, DEF(0, 0), "OpenMP threads (0 = default)"},
    {"background", OPT_INT, OFF(background), -1, 1, DEF(-1, -1),
     "rays leaving the scene: -1 from the data (learned for photos without alpha, else white), "
     "0 white, 1 learned (fields/background.h)"},
    {"alpha_thres", OPT_FLOAT, OFF(alpha_thres), 1e-7, 0.5, DEF(1e-3, 1e-3),
     "mask cache: density alpha threshold"},
    {"smooth_ksize", OPT_INT, OFF(smooth_ksize), 0, 9, DEF(5, 5),
     "SDF Gaussian smoothing kernel (0 = off, odd)"},
    {"smooth_sigma", OPT_FLOAT, OFF(smooth_sigma), 0.1, 5, DEF(0.8, 0.8), "SDF smoothing sigma"},
    /* The trilinear SDF's gradient carries voxel-scale noise the photometric loss never sees
     * (23.4 degrees mean error on the default scene's floors); normals from the SDF smoothed
     * over ~1 voxel: 12.2 degrees, same geometry. Render-time only: training is unchanged. */
    {"normal_ksize", OPT_INT, OFF(normal_ksize), 0, 9, DEF(7, 7),
     "normals (rendered, shading): Gaussian kernel on the SDF before its gradient (0/1 = raw)"},
    {"normal_sigma", OPT_FLOAT, OFF(normal_sigma), 0.1, 5, DEF(1.2, 1.2),
     "normals: that Gaussian's sigma in voxels"},
    {"geo_scales", OPT_INT, OFF(geo_scales), 1, 4, DEF(2, 4),
     "fine: geometry-feature scales (first K of 0.5,1,1.5,2 voxels)"},
    {"pe_pos", OPT_INT, OFF(pe_pos), 0, 10, DEF(5, 5), "fine: PE frequencies of the position"},
    {"pe_dir", OPT_INT, OFF(pe_dir), 0, 6, DEF(1, 1), "fine: PE frequencies of the view direction"},
    {"tone_width", OPT_INT, OFF(tone_width), 4, 256, DEF(32, 192), "fine: tone-mapper width"},
    {"tone_pe", OPT_INT, OFF(tone_pe), 0, 8, DEF(3, 5), "fine: tone-mapper PE frequencies"},
    {"lambda_tau", OPT_FLOAT, OFF(lambda_tau), 0, 100, DEF(1.0, 0.1),
     "fine: weight of the gamma(linear) loss"},
    {"sdf_init_alpha", OPT_FLOAT, OFF(sdf_init_alpha), 1e-6, 1, DEF(0.05, 0.05),
     "coarse: initial SDF = signed distance to the alphamask voxels with alpha above this"},
    {"fine_mask_band", OPT_FLOAT, OFF(fine_mask_band), 0, 1000, DEF(4, 0),
     "fine: mask cache narrowed to the band within this many voxels of the coarse surface "
     "(0 = off)"},
    {"mlp_engine", OPT_INT, OFF(mlp_engine), 0, 2, DEF(0, 0),
     "MLP training kernels: 0 esr's fused kernel (the fastest in `esr bench`; bitwise the same for any thread count), "
     "1 oneDNN, 2 OpenBLAS"},
    {"lts_points", OPT_INT, OFF(lts_points), 1, 100000, DEF(128, 100),
     "lts: surface points per step the light-transport loss checks"},
    {"lts_dirs", OPT_INT, OFF(lts_dirs), 1, 4096, DEF(32, 256),
     "lts: incident directions per point"},
    {"lts_estimator", OPT_INT, OFF(lts_estimator), 0, 1, DEF(0, 1),
     "lts: incident radiance estimator: 0 first hit of the SDF + radiance there, stratified "
     "cosine-weighted directions; 1 the authors' (faithful): radiance volume-rendered along "
     "each secondary ray, uniform directions"},
    /* 4: glossier BRDFs (lamp's mirror sphere roughness 0.75 -> 0.57) but no better lights or
     * relighting on our scenes (docs/design.md, Finding the lights: Estimators) */
    {"lts_lobe_dirs", OPT_INT, OFF(lts_lobe_dirs), 0, 64, DEF(0, 0),
     "lts stage: of the first-hit estimator's incident directions, this many per outgoing "
     "direction reflected about half vectors from the BRDF's specular lobe, the rest "
     "cosine-weighted, combined by the balance heuristic (core/brdf_sampling.h); used when "
     "lts_dirs is at least 4x this (0 = cosine only)"},
    {"lts_split", OPT_INT, OFF(lts_split), 0, 1, DEF(0, 0),
     "lts stage: 1 = the loss multiplies the errors of two independent half-estimates (the even "
     "and the odd incident directions) instead of squaring one error, so the estimate's variance, "
     "which pushes glossy surfaces rough, is not penalised; needs lts_estimator 0 and an even "
     "lts_lobe_dirs above 0 (e.g. 4)"},
    {"emission", OPT_INT, OFF(emission), 0, 1, DEF(1, 1),
     "lts/pdra: 0 = the scene has no lights-on images, so nothing tells emission from reflection: "
     "E is 0 and the light-transport loss has no lights-on term (esr train sets it, saying so, "
     "for such a dataset)"},
    {"lts_weight", OPT_FLOAT, OFF(lts_weight), 0, 1e6, DEF(0.01, 0.01),
     "lts: weight of the light-transport MSE (off + emo)"},
    {"lts_brdf_emo", OPT_FLOAT, OFF(lts_brdf_emo), 0, 1, DEF(1, 1),
     "lts/pdra: how much of the lights-on (emo) error trains the BRDF (1 = the seed's loss; 0 = the "
     "BRDF learns from the lights-off error only, so the clipped photos round a light, whose "
     "light the incident field cannot show, do not raise the base colour there; the emo error "
     "still trains E and the incident light)"},
    {"lts_emo_base", OPT_FLOAT, OFF(lts_emo_base), 0, 1, DEF(1, 1),
     "lts/pdra: of the lights-on error's share in the BRDF (lts_brdf_emo), the part that trains the "
     "base colour (1 = all of it, the seed's loss; 0 = the base colour learns from the lights-off "
     "error only while roughness and metallic still learn from the lights' highlights)"},
    {"field_width", OPT_INT, OFF(field_width), 8, 256, DEF(64, 128),
     "lts: emission and BRDF MLP hidden width"},
    {"field_depth", OPT_INT, OFF(field_depth), 1, 8, DEF(2, 4),
     "lts: emission and BRDF MLP hidden layers"},
    {"env_lobes", OPT_INT, OFF(env_lobes), 1, 128, DEF(48, 48),
     "lts: spherical Gaussians of the environment map"},
    {"env_level", OPT_FLOAT, OFF(env_level), 0, 1e6, DEF(0, 0),
     "lts: the environment map's starting mean radiance, grey (0 = from the data, per channel: the "
     "mean lights-off radiance of the surfaces the cameras see / 0.3, a scene that averages "
     "mid-grey under a 60%-visible sky)"},
    {"env_from_photos", OPT_INT, OFF(env_from_photos), 0, 1, DEF(0, 0),
     "lts: with env_level 0, the surfaces' mean lights-off radiance read from the photos (1: their "
     "pixels, sRGB made linear, on 65536 rays the fine model sees as opaque) or from the fine "
     "model's render (0: on 8192 rays, partly transparent ones divided by their opacity)"},
    {"emitter_k", OPT_FLOAT, OFF(emitter_k), 0, 1e6, DEF(0.2, 0.2),
     "emitter mask threshold on the composited emission (the pdra stage sets it to its final k)"},
    {"pdra.k0", OPT_FLOAT, OFF(pdra_k0), 0, 1e6, DEF(0.2, 0.2),
     "pdra: certainty threshold k at the first step"},
    {"pdra.k_end", OPT_FLOAT, OFF(pdra_k_end), 0, 1e6, DEF(0, 0),
     "pdra: k at 3/4 of the stage and after (0 = derived from the data at the stage's start: "
     "pdra.k_frac x the emitters' level, the 99.5th percentile of composited E)"},
    /* lamp emitter IoU: 0.5 -> 0.895, 0.6 -> 0.940 (with the per-step cap; without it 0.6
     * let k overtake the emitters: 0.04) */
    {"pdra.k_frac", OPT_FLOAT, OFF(pdra_k_frac), 0.01, 1, DEF(0.6, 0.6),
     "pdra: k_end as a fraction of the emitters' level when derived"},
    /* fast 1: lamp emitter IoU 0.93 (0.1: 0.87, floor glow left above k); paper: the authors'
     * default */
    {"pdra.supp", OPT_FLOAT, OFF(pdra_supp), 0, 1e6, DEF(1, 0.1),
     "pdra: emission-suppression weight on certain rays, w mean(E^2)"},
    {"pdra.w_l", OPT_FLOAT, OFF(pdra_w_l), 0, 1e6, DEF(50, 50),
     "pdra: weight of the LTS emo term that trains E towards sg(L_emo - reflection) "
     "(the authors' w_l, here on E only)"},
    {"pdra.w_r", OPT_FLOAT, OFF(pdra_w_r), 0, 1e6, DEF(1, 1),
     "pdra: weight of the LTS emo term that trains L_emo towards sg(estimate) (w_r)"},
    /* paper: the authors' default (METHOD.md) */
    {"pdra.w_es", OPT_FLOAT, OFF(pdra_w_es), 0, 1e6, DEF(0.01, 0.1),
     "pdra: emission smoothness, w mean |E(x) - E(x + 0.08-voxel jitter)| on the batch's samples"},
    {"pdra.w_ns", OPT_FLOAT, OFF(pdra_w_ns), 0, 1e6, DEF(0.001, 0.001),
     "pdra: normal smoothness, w mean |grad f(x) - grad f(x + 0.8-voxel jitter)| (the authors' "
     "0.001)"},
    {"pdra.w_ent", OPT_FLOAT, OFF(pdra_w_ent), 0, 1e6, DEF(0.001, 0.001),
     "pdra: entropy of each ray's final transmittance (hit or miss, not half; the authors' 0.001)"},
    {"pdra.sg", OPT_INT, OFF(pdra_sg), 0, 1, DEF(1, 1),
     "pdra: stop-gradients of the LTS emo pair (0 = the seed's ablation \"w/o sg\": one plain "
     "MSE, the reflection also trained on uncertain rays)"},
    {"pdra.progressive", OPT_INT, OFF(pdra_progressive), 0, 1, DEF(1, 1),
     "pdra: ray groups with the rising k (0 = the seed's ablation \"w/o progressive\": every "
     "ray uncertain, no suppression)"},
    /* with pdra.lights_at, which without them lets the lights' strength run up (the default
     * scene's lampshade 53% over; docs/design.md, "Lights in the transport") */
    {"pdra.lobe_dirs", OPT_INT, OFF(pdra_lobe_dirs), 0, 64, DEF(4, 0),
     "pdra: lts_lobe_dirs for the stage (and for the lights' calibration on its model); applied "
     "where the directions are at least 4x it (fine-tuning's 4 are not)"},
    {"pdra.split", OPT_INT, OFF(pdra_split), 0, 1, DEF(1, 0),
     "pdra: lts_split for the stage (needs an even pdra.lobe_dirs above 0); applied where "
     "pdra.lobe_dirs is, with lts_estimator 0 and an even lts_dirs, else pdra trains without it"},
    /* lamp direct relight test_nvi 27.43 -> 27.88 dB at 0.5, 28.07 at 0.25 (seed 2: 27.83 ->
     * 28.12; 28.05 at 0.1, its lights weaker); the default scene's lights 13.6% / 11.9% ->
     * 13.2% / 2.6% off at 0.5, 15.2% / 2.2% at 0.25 (seed 2: 9.1% / 2.1% -> 6.5% / 9.5%)
     * (docs/design.md, "Lights in the transport", "When") */
    {"pdra.lights_at", OPT_FLOAT, OFF(pdra_lights_at), 0, 1, DEF(0.25, 0),
     "pdra: share of the stage after which the lights are found and calibrated (without the "
     "lights-off correction) and the light-transport loss's secondary rays that end on a light "
     "see its calibrated emission instead of the radiance field there, which clipped photos keep "
     "near 1 (first-hit estimator; 0 = never, the seed's)"},
    {"lights_calib_points", OPT_INT, OFF(lights_calib_points), 1, 100000, DEF(2000, 2000),
     "pdra, `esr lights`: surface points away from the lights whose light calibrates the lights' "
     "strength"},
    {"lights_solve", OPT_INT, OFF(lights_solve), 0, 1, DEF(1, 1),
     "pdra's end, `esr lights`: 1 = each light's strength solved from the lights-on training "
     "pixels (photo = lights-off radiance + sum of strength x the light's direct transport; "
     "non-negative, robust, clipped pixels as lower bounds), 0 = the calibration's from the "
     "lights-off surface points (ablation)"},
    {"lights_solve_rays", OPT_INT, OFF(lights_solve_rays), 256, 4194304, DEF(65536, 65536),
     "lights-on training pixels the strengths are solved from (all when fewer; stratified)"},
    {"lights_solve_spp", OPT_INT, OFF(lights_solve_spp), 2, 1024, DEF(64, 64),
     "area samples per light and pixel in that solve (two independent halves)"},
    {"lights_solve_seen", OPT_INT, OFF(lights_solve_seen), 0, 1, DEF(0, 0),
     "in that solve, 1 = unclipped pixels that see a light count as exact rows (its reconstructed "
     "edge, a voxel wide, puts emitter where the photo shows none), 0 = a light's own pixels "
     "only bound it from below where clipped"},
    {"lights_solve_dirs", OPT_INT, OFF(lights_solve_dirs), 0, 256, DEF(32, 32),
     "in that solve, directions of each pixel's lights-off correction of its base colour (L_off / "
     "the model's estimate of it, over its median: base colour next to a light absorbs some of "
     "its clipped light); 0 = none (ablation)"},
    {"lights_solve_drop", OPT_INT, OFF(lights_solve_drop), 0, 1, DEF(1, 1),
     "1 = a light whose solved strength is within 3 standard errors of 0 (the photos do not show "
     "it emitting: a reflection of a light, a fleck) is dropped and the others solved again; 0 = "
     "kept (ablation)"},
    {"lights_seen_area", OPT_FLOAT, OFF(lights_seen_area), 0, 100, DEF(0, 0),
     "pdra's end, `esr lights`: the surface the training views must show within a lattice point "
     "and its 26 neighbours, foreshortened and summed over the views, in lattice cell faces, for "
     "it to count as seen (a light grows over the outer surface next to it that is not; "
     "train/lights/seen.h); 0 = any ray's hit, which the more rays of a larger image carry "
     "further (2: a 400 px capture's lights 1.77x instead of 2.04x too strong, but glossy's "
     "HDR MSE of the lights-on views doubles; docs/experiments/seen-surface.md)"},
    {"lights_balance", OPT_INT, OFF(lights_balance), 0, 1, DEF(1, 1),
     "1 = the lights' colour balanced by their silhouettes in the lights-on photos (base colour "
     "x b, environment / b), 0 = none (ablation)"},
    {"tv_every", OPT_INT, OFF(tv_every), 1, 1000, DEF(4, 1),
     "total-variation regularisers every N iterations (weight scaled by N)"},
    /* Stage options: one DEF(fast, paper) per stage, in the order alphamask, coarse, fine, lts, pdra. */
    STAGE_OPT(res, OPT_INT, 0, 512,
              "grid lattice points per axis (0 = from the training images' size and count, "
              "logged; at least 8 otherwise)",
              DEF(80, 100), DEF(80, 96), DEF(128, 160), DEF(128, 160), DEF(128, 160)),
    STAGE_OPT(iters, OPT_INT, 0, 1000000, "iterations",
              DEF(500, 10000), DEF(1500, 10000), DEF(2000, 20000), DEF(1500, 40000), DEF(1000, 80000)),
    STAGE_OPT(feat_channels, OPT_INT, 1, 64, "feature grid channels",
              DEF(6, 6), DEF(12, 12), DEF(6, 6), DEF(6, 6), DEF(6, 6)),
    STAGE_OPT(mlp_width, OPT_INT, 8, 256, "MLP hidden width",
              DEF(8, 8), DEF(64, 128), DEF(64, 192), DEF(64, 192), DEF(64, 192)),
    STAGE_OPT(mlp_depth, OPT_INT, 1, 8, "MLP hidden layers",
              DEF(1, 1), DEF(2, 3), DEF(3, 4), DEF(3, 4), DEF(3, 4)),
    /* paper coarse 5e-3: the value before the fast preset was tuned to 1e-2 (the authors' SDF lr
     * once their step decays have run) */
    STAGE_OPT(lr_grid, OPT_FLOAT, 0, 10, "density/SDF grid learning rate",
              DEF(0.1, 0.1), DEF(1e-2, 5e-3), DEF(2e-3, 2e-3), DEF(5e-4, 5e-4), DEF(5e-6, 5e-7)),
    STAGE_OPT(lr_feat, OPT_FLOAT, 0, 10, "feature grid learning rate",
              DEF(0.1, 0.1), DEF(0.1, 0.1), DEF(0.1, 0.1), DEF(0.05, 0.1), DEF(1e-2, 1e-2)),
    STAGE_OPT(lr_mlp, OPT_FLOAT, 0, 1, "MLP learning rate",
              DEF(1e-3, 1e-3), DEF(1e-3, 1e-3), DEF(1e-3, 1e-3), DEF(1e-3, 3e-3), DEF(3e-4, 3e-4)),
    STAGE_OPT(lr_final, OPT_FLOAT, 0, 1, "learning-rate factor reached at the last iteration",
              DEF(0.1, 0.1), DEF(0.1, 0.1), DEF(0.1, 0.1), DEF(0.1, 0.01), DEF(0.1, 0.01)),
    STAGE_OPT(s0, OPT_FLOAT, 0.1, 10000, "NeuS inv-s at step 0",
              DEF(1, 1), DEF(5, 5), DEF(100, 20), DEF(200, 220), DEF(200, 220)),
    STAGE_OPT(s_div, OPT_FLOAT, 0.01, 1e6, "inv-s grows by step / s_div",
              DEF(1, 1), DEF(10, 50), DEF(20, 100), DEF(1e6, 1e6), DEF(1e6, 1e6)),
    STAGE_OPT(tv_sdf, OPT_FLOAT, 0, 100, "grid total-variation weight",
              DEF(0, 0), DEF(1e-3, 1e-3), DEF(1e-3, 1e-3), DEF(1e-3, 1e-3), DEF(1e-3, 1e-3)),
    /* fast: coarse only (+1.2 dB on lamp; the fine band is narrowed by a distance estimate, so
     * the smoother SDF no longer widens it); paper: coarse and fine as METHOD.md says, at the
     * authors' weight */
    STAGE_OPT(tv_sdf_grad, OPT_FLOAT, 0, 100,
              "smoothed-gradient total-variation weight on the SDF (Voxurf; 0 = off)",
              DEF(0, 0), DEF(0.05, 0.05), DEF(0, 0.05), DEF(0, 0.05), DEF(0, 0.05)),
    STAGE_OPT(tv_feat, OPT_FLOAT, 0, 100, "feature-grid total-variation weight",
              DEF(0, 0), DEF(0, 0), DEF(0, 0), DEF(0, 0), DEF(0, 0)),
    STAGE_OPT(step_vox, OPT_FLOAT, 0.05, 4, "ray-marching step in voxels",
              DEF(0.5, 0.5), DEF(0.5, 0.5), DEF(0.5, 0.5), DEF(0.5, 0.5), DEF(0.5, 0.5)),
    /* fast: the geometry stages shape the surface from the lights-off photos only. A lit
     * emitter is clipped in the lights-on photos and its edge bleeds through the pixel filter, so
     * there it looks about half a pixel wider than it is; the off photos show the true outline
     * (lamp: bulb split IoU 0.836 -> 0.863, emitter IoU 0.948 -> 0.958; default scene: emitter
     * IoU 0.887 -> 0.924; lamp test_nv after fine 32.53 -> 31.55 dB, the on views no longer
     * reproducing that bleed, 34.19 -> 33.91 after pdra). lts and pdra weigh the on rays 0.3:
     * with their pull on the surface cut there too, lamp's lampshade lost its emission (emitter
     * IoU 0.34); at full weight the bleed widened the bulb again (split IoU 0.86). At 0.3
     * (2026-11-27, lts and pdra retrained from the same fine checkpoints; docs/design.md):
     * lamp bulb split 0.859 -> 0.888 (seed 2: 0.856 -> 0.884), the default scene's emitter IoU
     * 0.910 -> 0.943 and orb 22% -> 9% off. The weight is on the opacities; the geometry
     * features the emo branch reads keep their gradient.
     * paper: the authors train the geometry on every ray */
    STAGE_OPT(geom_on, OPT_FLOAT, 0, 1,
              "weight of the lights-on rays in the geometry (density/SDF) gradient (0 = the "
              "surface from the lights-off photos only)",
              DEF(0, 1), DEF(0, 1), DEF(0, 1), DEF(0.3, 1), DEF(0.3, 1)),
};
#define N_OPTS (sizeof opts / sizeof opts[0])

/* The smoke preset: fast with these changes. Every stage and every step of one (the mask, the
 * SDF's start, checkpoints within a stage, pdra's lights in the transport a quarter through, the
 * lights found, calibrated and colour-balanced at its end) runs, on grids sized to the images (res 0) with small networks and
 * batches, a few iterations each: all five stages of a 32 px, 8-view dataset in seconds, the
 * checkpoints a few MB. What it trains is not meant to be looked at. */
static const struct {
    const char *name;
    double value;
} smoke_changes[] = {
    {"batch_rays", 512}, {"log_every", 10}, {"save_every", 10}, {"tone_width", 8}, {"lts_points", 32},
    {"lts_dirs", 16}, {"field_width", 16}, {"field_depth", 1}, {"lights_calib_points", 250},
    {"lights_solve_rays", 2048}, {"lights_solve_spp", 4},
    {"alphamask.res", 0}, {"coarse.res", 0}, {"fine.res", 0}, {"lts.res", 0}, {"pdra.res", 0},
    {"alphamask.iters", 30}, {"coarse.iters", 30}, {"fine.iters", 20}, {"lts.iters", 10},
    {"pdra.iters", 12},
    {"coarse.mlp_width", 16}, {"fine.mlp_width", 16}, {"lts.mlp_width", 16}, {"pdra.mlp_width", 16},
    {"coarse.mlp_depth", 1}, {"fine.mlp_depth", 1}, {"lts.mlp_depth", 1}, {"pdra.mlp_depth", 1},
};
#define N_SMOKE_CHANGES (sizeof smoke_changes / sizeof smoke_changes[0])

static const char *preset_names[ESR_PRESET_COUNT] = {"fast", "paper", "smoke"};

const char *esr_preset_name(enum esr_preset p)
{
    return p >= 0 && p < ESR_PRESET_COUNT ? preset_names[p] : NULL;
}

int esr_preset_from_name(const char *name, enum esr_preset *out)
{
    for (int i = 0; i < ESR_PRESET_COUNT; i++)
        if (!strcmp(name, preset_names[i])) {
            *out = (enum esr_preset)i;
            return ESR_OK;
        }
    return ESR_FAIL("unknown preset '%s' (valid: fast, paper, smoke)", name);
}

static void opt_store(struct esr_train_config *c, const struct opt *o, double v)
{
    char *p = (char *)c + o->offset;
    if (o->type == OPT_INT) {
        int i = (int)v;
        memcpy(p, &i, sizeof i);
    } else {
        float f = (float)v;
        memcpy(p, &f, sizeof f);
    }
}

static double opt_load(const struct esr_train_config *c, const struct opt *o)
{
    const char *p = (const char *)c + o->offset;
    if (o->type == OPT_INT) {
        int i;
        memcpy(&i, p, sizeof i);
        return i;
    }
    float f;
    memcpy(&f, p, sizeof f);
    return f;
}

static const struct opt *opt_find(const char *name)
{
    for (size_t i = 0; i < N_OPTS; i++)
        if (!strcmp(opts[i].name, name))
            return &opts[i];
    return NULL;
}

void esr_config_defaults(struct esr_train_config *c, enum esr_preset preset)
{
    memset(c, 0, sizeof(*c));
    c->preset = preset;
    const int column = preset == ESR_PRESET_SMOKE ? ESR_PRESET_FAST : (int)preset;
    for (size_t i = 0; i < N_OPTS; i++)
        opt_store(c, &opts[i], opts[i].def[column]);
    for (size_t i = 0; preset == ESR_PRESET_SMOKE && i < N_SMOKE_CHANGES; i++)
        opt_store(c, opt_find(smoke_changes[i].name), smoke_changes[i].value);
}

/* Checks v against o's type and bounds; `where` prefixes the message. */
static int opt_check(const struct opt *o, double v, const char *where)
{
    if (!isfinite(v))
        return ESR_FAIL("%s: option '%s' must be a finite number", where, o->name);
    if (o->type == OPT_INT && v != floor(v))
        return ESR_FAIL("%s: option '%s' must be an integer (got %g)", where, o->name, v);
    /* a float option is checked as stored: 0.01 read back from its float is 0.0099999998, which
     * the bound 0.01 as a double refused ("0.01 is out of range [0.01, ...]") */
    const double lo = o->type == OPT_FLOAT ? (double)(float)o->lo : o->lo;
    const double hi = o->type == OPT_FLOAT ? (double)(float)o->hi : o->hi;
    const double as_stored = o->type != OPT_FLOAT ? v : fabs(v) > FLT_MAX ? v : (double)(float)v;
    if (as_stored < lo || as_stored > hi)
        return ESR_FAIL("%s: option '%s' = %g is out of range [%g, %g]", where, o->name, v, o->lo,
                        o->hi);
    if ((!strcmp(o->name, "smooth_ksize") || !strcmp(o->name, "normal_ksize")) && v != 0 &&
        ((int)v % 2) == 0)
        return ESR_FAIL("%s: option '%s' must be 0 or odd (got %g)", where, o->name, v);
    const size_t len = strlen(o->name);
    if (len > 4 && !strcmp(o->name + len - 4, ".res") && v > 0 && v < 8)
        return ESR_FAIL("%s: option '%s' must be 0 (from the images) or at least 8 (got %g)", where,
                        o->name, v);
    return ESR_OK;
}

/* An unknown key, with the nearest option's name when it looks like a typo of one. */
static int unknown_key(const char *where, const char *key)
{
    const char *names[N_OPTS];
    for (size_t i = 0; i < N_OPTS; i++)
        names[i] = opts[i].name;
    const char *near = esr_suggest(key, names, (int)N_OPTS);
    return ESR_FAIL("%s: unknown option '%s'%s%s%s (see `esr train --help`)", where, key,
                    near ? " (did you mean " : "", near ? near : "", near ? "?)" : "");
}

static int opt_apply(struct esr_train_config *c, const char *key, double v, const char *where)
{
    const struct opt *o = opt_find(key);
    if (!o)
        return unknown_key(where, key);
    ESR_TRY(opt_check(o, v, where));
    opt_store(c, o, v);
    return ESR_OK;
}

int esr_config_set(struct esr_train_config *c, const char *assignment)
{
    const char *eq = strchr(assignment, '=');
    char key[128];
    if (!eq || eq == assignment || (size_t)(eq - assignment) >= sizeof key)
        return ESR_FAIL("--set '%s': expected key=value", assignment);
    memcpy(key, assignment, (size_t)(eq - assignment));
    key[eq - assignment] = '\0';
    char *end;
    errno = 0;
    double v = strtod(eq + 1, &end);
    if (end == eq + 1 || *end != '\0' || errno)
        return ESR_FAIL("--set '%s': value '%s' is not a number", assignment, eq + 1);
    return opt_apply(c, key, v, "--set");
}

int esr_config_validate(const struct esr_train_config *c)
{
    for (size_t i = 0; i < N_OPTS; i++)
        ESR_TRY(opt_check(&opts[i], opt_load(c, &opts[i]), "config"));
    /* the split loss needs two halves that each hold half of every technique's directions; without
     * lobe directions the variance it stops penalising was what kept roughness up (lamp: 0
     * everywhere, design notes) */
    if (c->lts_split && (c->lts_estimator != 0 /* first hit */ || c->lts_lobe_dirs <= 0 ||
                         c->lts_lobe_dirs % 2 || c->lts_dirs % 2 || c->lts_dirs < 4 * c->lts_lobe_dirs))
        return ESR_FAIL("config: lts_split 1 needs lts_estimator 0, an even lts_lobe_dirs above 0 "
                        "and an even lts_dirs of at least 4x it (got estimator %d, lobe %d, dirs %d)",
                        c->lts_estimator, c->lts_lobe_dirs, c->lts_dirs);
    /* pdra's pair, on by default, applies only where it can (train/lts.c): refusing the rest
     * would refuse every run and checkpoint that sets another estimator or fewer directions */
    if (c->pdra_split && (c->pdra_lobe_dirs <= 0 || c->pdra_lobe_dirs % 2))
        return ESR_FAIL("config: pdra.split 1 needs an even pdra.lobe_dirs above 0 (got %d)",
                        c->pdra_lobe_dirs);
    return ESR_OK;
}

/* Applies the members of obj, prefixing nested object keys with "prefix." (one level). */
static int json_apply(struct esr_train_config *c, const cJSON *obj, const char *prefix,
                      const char *source)
{
    for (const cJSON *it = obj->child; it; it = it->next) {
        char key[160];
        snprintf(key, sizeof key, "%s%s%s", prefix, prefix[0] ? "." : "", it->string);
        if (!prefix[0] && !strcmp(it->string, "preset"))
            continue; /* applied first by json_apply_object */
        if (cJSON_IsObject(it) && !prefix[0]) {
            ESR_TRY(json_apply(c, it, it->string, source));
            continue;
        }
        if (!cJSON_IsNumber(it)) {
            if (!opt_find(key))
                return unknown_key(source, key);
            return ESR_FAIL("%s: option '%s' must be a number", source, key);
        }
        ESR_TRY(opt_apply(c, key, it->valuedouble, source));
    }
    return ESR_OK;
}

/* Whether obj sets option o, dotted ("fine.iters") or nested ("fine": {"iters"}). */
static int json_has_option(const cJSON *obj, const struct opt *o)
{
    if (cJSON_GetObjectItemCaseSensitive(obj, o->name))
        return 1;
    const char *dot = strchr(o->name, '.');
    char stage[32];
    if (!dot || (size_t)(dot - o->name) >= sizeof stage)
        return 0;
    memcpy(stage, o->name, (size_t)(dot - o->name));
    stage[dot - o->name] = '\0';
    const cJSON *sub = cJSON_GetObjectItemCaseSensitive(obj, stage);
    return cJSON_IsObject(sub) && cJSON_GetObjectItemCaseSensitive(sub, dot + 1);
}

/* The one reader behind esr_config_load_json and esr_config_from_json. A "preset" key resets c to
 * that preset's defaults; without one, c is reset to `fast` when reset_without_preset is set (a
 * checkpoint describes a whole config) and kept otherwise (a --config file edits the preset chosen
 * on the command line). c is left unchanged on failure. */
static int json_apply_object(struct esr_train_config *c, const cJSON *obj, const char *source,
                             int reset_without_preset, int *n_missing)
{
    if (!cJSON_IsObject(obj))
        return ESR_FAIL("%s: not a JSON object", source);
    struct esr_train_config next = *c;
    const cJSON *preset = cJSON_GetObjectItemCaseSensitive(obj, "preset");
    if (preset) {
        enum esr_preset p = ESR_PRESET_FAST; /* set by esr_preset_from_name on success */
        if (!cJSON_IsString(preset))
            return ESR_FAIL("%s: 'preset' must be a string (fast, paper or smoke)", source);
        ESR_TRY(esr_preset_from_name(preset->valuestring, &p));
        esr_config_defaults(&next, p);
    } else if (reset_without_preset) {
        esr_config_defaults(&next, ESR_PRESET_FAST);
    }
    ESR_TRY(json_apply(&next, obj, "", source));
    if (n_missing) {
        *n_missing = 0;
        for (size_t i = 0; i < N_OPTS; i++)
            *n_missing += !json_has_option(obj, &opts[i]);
    }
    *c = next;
    return ESR_OK;
}

int esr_config_from_json(struct esr_train_config *c, const cJSON *obj, const char *source,
                         int *n_missing)
{
    return json_apply_object(c, obj, source, 1, n_missing);
}

int esr_config_parse_json(struct esr_train_config *c, const char *text, size_t size, const char *name)
{
    char source[1200];
    snprintf(source, sizeof source, "config file %s", name);
    cJSON *root = esr_json_parse_whole(text, size, source);
    if (!root)
        return ESR_ERR;
    int rc = json_apply_object(c, root, source, 0, NULL);
    cJSON_Delete(root);
    return rc;
}

int esr_config_load_json(struct esr_train_config *c, const char *path)
{
    unsigned char *text;
    size_t size;
    ESR_TRY(esr_file_read_all(path, &text, &size));
    int rc = esr_config_parse_json(c, (const char *)text, size, path);
    free(text);
    return rc;
}

/* The shortest decimal that reads back to the same float, as a double: cJSON then prints 0.001,
 * not 0.0010000000474974513. Nine significant digits always read back to the same float. */
static double shortest_decimal(double v)
{
    for (int digits = 1; digits <= 9; digits++) {
        char text[32];
        snprintf(text, sizeof text, "%.*g", digits, v);
        double d = strtod(text, NULL);
        if ((float)d == (float)v)
            return d;
    }
    return v;
}

cJSON *esr_config_to_json(const struct esr_train_config *c)
{
    cJSON *root = cJSON_CreateObject();
    /* every value is written below, so a hand-built struct with no valid preset loses nothing */
    const char *preset = esr_preset_name((enum esr_preset)c->preset);
    if (!root || !cJSON_AddStringToObject(root, "preset", preset ? preset : "fast"))
        goto oom;
    for (size_t i = 0; i < N_OPTS; i++) {
        /* integers stay exact (9 float digits would round a large seed); cJSON prints them as
         * integers, never 5e+02 */
        double v = opt_load(c, &opts[i]);
        if (!cJSON_AddNumberToObject(root, opts[i].name,
                                     opts[i].type == OPT_INT ? v : shortest_decimal(v)))
            goto oom;
    }
    return root;
oom:
    cJSON_Delete(root);
    return NULL;
}

int esr_config_write_json(const struct esr_train_config *c, const char *path)
{
    return esr_json_write_atomic(path, esr_config_to_json(c));
}

/* An option's bound or default for the help table: an integer option's as an integer
 * ([0, 2147483647], not [0, 2.14748e+09]). */
static void help_number(const struct opt *o, double v, char *text, size_t n)
{
    if (o->type == OPT_INT)
        snprintf(text, n, "%.0f", v);
    else
        snprintf(text, n, "%g", v);
}

void esr_config_print_help(FILE *out)
{
    fprintf(out, "  %-24s %-5s %-18s %-9s %-9s %s\n", "option", "type", "range", "fast", "paper",
            "meaning");
    for (size_t i = 0; i < N_OPTS; i++) {
        const struct opt *o = &opts[i];
        char range[80], lo[32], hi[32], fast[32], paper[32];
        help_number(o, o->lo, lo, sizeof lo);
        help_number(o, o->hi, hi, sizeof hi);
        help_number(o, o->def[0], fast, sizeof fast);
        help_number(o, o->def[1], paper, sizeof paper);
        snprintf(range, sizeof range, "[%s, %s]", lo, hi);
        fprintf(out, "  %-24s %-5s %-18s %-9s %-9s %s\n", o->name,
                o->type == OPT_INT ? "int" : "float", range, fast, paper, o->help);
    }
    fprintf(out, "  preset smoke: fast with");
    for (size_t i = 0; i < N_SMOKE_CHANGES; i++) {
        char v[32];
        help_number(opt_find(smoke_changes[i].name), smoke_changes[i].value, v, sizeof v);
        fprintf(out, "%s%s %s %s", i ? "," : "", i && i % 6 == 0 ? "\n   " : "",
                smoke_changes[i].name, v);
    }
    fprintf(out, "\n");
}
