/* Training configuration: one table of options (name, type, bounds, default per preset, help),
 * from which defaults, validation, `--set key=value` parsing, JSON reading/writing and the help
 * text are all derived (redis-style table-driven config). Presets: "fast" (CPU default, sizes
 * tuned to train the lamp scene in minutes), "paper" (the authors' sizes from METHOD.md) and
 * "smoke" (fast with a few changes, config.c's smoke_changes: every stage runs a few iterations
 * on grids sized to the images, for checking an install and for the test suite; seconds on a
 * small dataset, nothing worth rendering). */
#ifndef ESR_MODEL_CONFIG_H
#define ESR_MODEL_CONFIG_H

#include <cjson/cJSON.h>
#include <stddef.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

enum esr_preset { ESR_PRESET_FAST, ESR_PRESET_PAPER, ESR_PRESET_SMOKE, ESR_PRESET_COUNT };

/* Per-stage options shared by the stages (unused ones are ignored by a stage). */
struct esr_stage_config {
    int res;            /* grid lattice points per axis (density / SDF); 0 = from the images
                           (esr_config_resolve_res), resolved before a run is written */
    int iters;          /* iterations of the stage */
    int feat_channels;  /* feature grid channels (coarse: colour; fine: per radiance branch) */
    int mlp_width;      /* hidden width of the colour / radiance MLPs */
    int mlp_depth;      /* hidden layers of those MLPs */
    float lr_grid;      /* density grid (alphamask) or SDF grid lr */
    float lr_feat;      /* feature grid lr */
    float lr_mlp;       /* MLP lr */
    float lr_final;     /* lr factor reached at the end of the stage */
    float s0;           /* NeuS inv-s at step 0 */
    float s_div;        /* inv-s grows by step / s_div */
    float tv_sdf;       /* SDF total-variation weight */
    float tv_sdf_grad;  /* smoothed-gradient total-variation weight on the SDF */
    float tv_feat;      /* feature-grid total-variation weight */
    float step_vox;     /* ray-marching step in voxels of this stage's grid */
    float geom_on;      /* weight of lights-on rays in the geometry (density / SDF) gradient */
};

/* The background of rays that leave the scene. AUTO is resolved by the trainer from the data
 * (learned when no training image has an alpha channel with any transparency: photos; white
 * otherwise: renders and masked captures, composited on white as the authors do); a model whose
 * options say AUTO (a checkpoint older than the option) has the white one. */
enum esr_background_mode { ESR_BACKGROUND_AUTO = -1, ESR_BACKGROUND_WHITE = 0, ESR_BACKGROUND_LEARNED = 1 };

struct esr_train_config {
    int preset;             /* enum esr_preset the defaults came from */
    int seed;
    int batch_rays;
    int save_every;         /* checkpoint every N iterations within a stage */
    int log_every;          /* progress/log line every N iterations */
    int threads;            /* OpenMP threads (0 = runtime default) */
    int background;         /* enum esr_background_mode: what rays leaving the scene see */
    float alpha_thres;      /* mask cache: alpha threshold on the density grid */
    int smooth_ksize;       /* SDF Gaussian smoothing kernel (0 = off) */
    float smooth_sigma;
    int normal_ksize;       /* shading/rendered normals: Gaussian kernel on the SDF (0 = raw) */
    float normal_sigma;
    int geo_scales;         /* fine: geometry-feature scales (first K of 0.5,1,1.5,2 voxels) */
    int pe_pos;             /* fine: PE frequencies of x */
    int pe_dir;             /* fine: PE frequencies of the view direction */
    int tone_width;         /* fine: tone-mapper hidden width */
    int tone_pe;            /* fine: PE frequencies of the tone-mapper input */
    float lambda_tau;       /* fine: weight of the gamma(linear) loss term */
    float sdf_init_alpha;   /* coarse: SDF starts as the signed distance to alpha > this */
    float fine_mask_band;   /* fine: mask keeps the band within this many voxels of the surface */
    int tv_every;           /* total-variation terms every N iterations (weight x N) */
    int mlp_engine;         /* enum esr_mlp_engine of the training MLPs */
    int lts_points;         /* lts: points per step of the light-transport loss */
    int lts_dirs;           /* lts: incident directions per point */
    int lts_estimator;      /* lts: incident radiance estimator (enum esr_lts_estimator) */
    int emission;           /* lts/pdra: 0 = no lights-on images: E is 0, no emo term */
    int lts_split;          /* lts: loss = product of two independent half-estimates' errors */
    int lts_lobe_dirs;      /* lts: of lts_dirs, per outgoing direction, from the BRDF's lobe */
    float lts_weight;       /* lts: weight of the light-transport MSE */
    float lts_brdf_emo;     /* lts/pdra: share of the lights-on error that trains the BRDF */
    float lts_emo_base;     /* lts/pdra: of that share, the part that trains the base colour */
    int field_width;        /* lts: emission / BRDF MLP width */
    int field_depth;        /* lts: emission / BRDF MLP hidden layers */
    int env_lobes;          /* lts: spherical Gaussians of the environment map */
    float env_level;        /* lts: the map's starting mean radiance (0: from the data) */
    int env_from_photos;    /* lts: that level from the photos' pixels (1) or the fine render (0) */
    float emitter_k;        /* emitter mask: composited E above this in any channel */
    float pdra_k0;          /* pdra: k at the start */
    float pdra_k_end;       /* pdra: k from 3/4 of the stage on (0: derived at its start) */
    float pdra_k_frac;      /* pdra: derived k_end = this x the emitters' level */
    float pdra_supp;        /* pdra: emission-suppression weight */
    float pdra_w_l;         /* pdra: weight of MSE(sg(L_emo), L^_emo) on E */
    float pdra_w_r;         /* pdra: weight of MSE(L_emo, sg(L^_emo)) (trains L_emo) */
    float pdra_w_es;        /* pdra: emission smoothness weight (train/pdra_reg.h) */
    float pdra_w_ns;        /* pdra: normal smoothness weight */
    float pdra_w_ent;       /* pdra: final-transmittance entropy weight */
    int pdra_sg;            /* pdra: stop-gradient pair on (0: the "w/o sg" ablation) */
    int pdra_progressive;   /* pdra: ray groups on (0: the "w/o progressive" ablation) */
    int pdra_lobe_dirs;     /* pdra: lts_lobe_dirs for the stage */
    int pdra_split;         /* pdra: lts_split for the stage */
    float pdra_lights_at;   /* pdra: share of the stage after which the light transport sees the
                               lights at their calibrated strength (0: never) */
    int lights_calib_points; /* surface points that calibrate the lights' strength */
    int lights_solve;        /* 1: the strengths solved from the lights-on pixels
                                (train/lights/solve.h); 0: the calibration's (ablation) */
    int lights_solve_rays;   /* lights-on training pixels that solve them */
    int lights_solve_spp;    /* area samples per light and pixel there */
    int lights_solve_seen;   /* 1: unclipped pixels that see a light are exact rows there; 0:
                                a light's own pixels bound it from below only */
    int lights_solve_dirs;   /* directions of its lights-off correction (0: none) */
    int lights_solve_drop;   /* 1: lights the solve does not see emitting are dropped */
    float lights_seen_area;  /* surface the views show round a lattice point for it to be seen, in
                                cell faces (train/lights/seen.h); 0: any hit */
    int lights_balance;      /* 1: the silhouette colour balance (train/lights/lights.h); 0: none */
    struct esr_stage_config alphamask, coarse, fine, lts, pdra;
};

/* Defaults of a preset. */
void esr_config_defaults(struct esr_train_config *c, enum esr_preset preset);
/* "fast" / "paper" / "smoke" -> preset; ESR_ERR naming the valid names otherwise. */
int esr_preset_from_name(const char *name, enum esr_preset *out);
const char *esr_preset_name(enum esr_preset p);

/* Applies one "key=value" override (e.g. "fine.iters=200"); ESR_ERR on an unknown key, a value
 * that does not parse or lies outside the option's bounds. */
int esr_config_set(struct esr_train_config *c, const char *assignment);
/* Applies a JSON config file: an object whose keys are option names (dotted, or nested objects
 * "fine": {"iters": 200}), plus an optional "preset" key applied first. Unknown keys or values
 * out of range are refused with a message naming the file and key. */
int esr_config_load_json(struct esr_train_config *c, const char *path);
/* The same from size bytes of JSON text in memory; name stands for the file in messages. */
int esr_config_parse_json(struct esr_train_config *c, const char *text, size_t size, const char *name);
/* Writes esr_config_to_json(c) to path, atomically. */
int esr_config_write_json(const struct esr_train_config *c, const char *path);
/* Every option as a flat JSON object ("fine.iters": 200, ...) plus "preset": the form checkpoints
 * store. Floats are written as the shortest decimal that reads back to the same float. NULL when
 * out of memory; the caller owns the object. */
cJSON *esr_config_to_json(const struct esr_train_config *c);
/* Reads a config object written by any version of esr: starts from the defaults of obj's "preset"
 * ("fast" if absent) and applies every key, so an option added since the object was written keeps
 * its preset default; *n_missing (n_missing may be NULL) counts the options obj lacks. Keys are
 * dotted or nested as in esr_config_load_json, and an unknown key or an out-of-range value fails
 * with a message naming `source` (e.g. "checkpoint run/fine.ckpt") and the key. c is unchanged on
 * failure. */
int esr_config_from_json(struct esr_train_config *c, const cJSON *obj, const char *source,
                         int *n_missing);
/* The grid resolutions of the stages whose res is 0 ("from the images"), from the training
 * images' size width x height and their pixel count `pixels` (lights-off training pixels, or
 * all when there are none): the fine stages' R = min(the images' longer side, sqrt(pixels / 8))
 * (a lattice point no finer than a pixel's footprint, the scene box filling about a view, and
 * about 8 pixels to each lattice point of a surface, which holds about R^2 of them), rounded
 * down to a multiple of 4 and clamped to [16, 256]; alphamask and coarse 5/8 of it (fast's
 * 80 : 128), at least 16. A 32 px dataset with 8 views: 32 and 20; 100 px with 50: 100 and 62.
 * Returns the number of stages resolved; says each in said [size] ("" when none). */
int esr_config_resolve_res(struct esr_train_config *c, int width, int height, size_t pixels,
                           char *said, size_t size);
/* Checks every option against its bounds (after manual edits). */
int esr_config_validate(const struct esr_train_config *c);
/* Prints the option table (name, type, bounds, fast/paper defaults, help) and the smoke
 * preset's changes to fast, for --help. */
void esr_config_print_help(FILE *out);

#ifdef __cplusplus
}
#endif
#endif
