/* The lights a model found (pdra stage, train/lights/lights.h): the emitting surface split into
 * separate lights, each with an id, and each light's emission strength calibrated against the
 * light it casts on the rest of the scene.
 *
 * Storage: a label per lattice point of the SDF grid (0 = not an emitter, id + 1 otherwise) and
 * a small table per light. E(x) of a point on light K is reported as scale_K (per channel) x the
 * emission field's E(x): the field is trained on LDR images, where every emitter is saturated, so
 * it learns the emitters' shape and hue but not their strength; the scale restores the strength
 * (train/lights/lights.h says how). Saved in the checkpoint (model/checkpoint.c). */
#ifndef ESR_MODEL_LIGHTS_H
#define ESR_MODEL_LIGHTS_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ESR_MAX_LIGHTS 16

/* One light's edit (`esr edit`, seed eqs. 10-15): intensity multiplier (0 = off, 1 = as found)
 * and an optional recolour. */
struct esr_light_edit {
    float intensity;
    int recolour;       /* 1: hue and saturation replaced (V kept) */
    float hue, sat;     /* in [0, 1] */
};
/* The largest intensity an edit may ask: a million times the light as found keeps the edited
 * radiance, and its images, finite in float. */
#define ESR_LIGHT_EDIT_MAX_INTENSITY 1e6
/* What is wrong with edit ed, written into why [size] and returned; NULL when it can be applied:
 * intensity finite in [0, ESR_LIGHT_EDIT_MAX_INTENSITY], and with a recolour hue and saturation
 * finite in [0, 1] (a saturation above 1 gives negative light). */
const char *esr_light_edit_problem(const struct esr_light_edit *ed, char *why, size_t size);
/* ESR_OK when edit ed of light id can be applied, else ESR_ERR naming the light and the problem.
 * Every entry point that takes edits (edit/editor.h, edit/relight.h, edit/finetune.h) checks. */
int esr_light_edit_check(const struct esr_light_edit *ed, int id);
/* esr_light_edit_check over the n edits of lights 0..n-1. */
int esr_light_edits_check(const struct esr_light_edit *edits, int n);

struct esr_light {
    float centroid[3];    /* world position, mean of the light's surface points */
    float area;           /* surface area, world units^2 (each surface point's share of the
                             voxel faces its normal crosses, esr_light_point_area) */
    long points;          /* surface lattice points labelled with this light, its unseen part's
                             included */
    float field_rgb[3];   /* mean E of the emission field over the light's emitting points (E > k
                             on the outer surface; uncalibrated), which its unseen part emits */
    float scale[3];       /* per-channel strength calibration (1 = the field as trained) */
    float radiance[3];    /* emitted radiance found: scale x field_rgb (linear RGB) */
    float power;          /* emitted power, luminance x pi x area (Lambertian, one side; W-like
                             units of the dataset's radiance) */
    float calib_points;   /* non-emitting surface points (or, solved from the lights-on
                             pixels, pixels) whose lighting fixed the scale */
    /* what the photos say of the strength (train/lights/solve.h; 0 when not solved there): */
    float strength_err;   /* its relative standard error (mean over the channels) */
    uint32_t inseparable; /* bit j: the photos cannot tell this light's strength from light j's
                             (their estimates are nearly opposite: only their sum is known) */
    int bound_only;       /* 1: no unclipped pixel constrains it; its strength is the lower bound
                             the clipped ones give */
    int solved;           /* 1: its strength was solved there (every light is; 0: calibrated) */
};

struct esr_lights {
    int n;                /* 0: none found (or not computed) */
    struct esr_light light[ESR_MAX_LIGHTS];
    struct esr_grid grid; /* the lattice the labels live on (the SDF grid's) */
    uint8_t *label;       /* [nx*ny*nz] 0 or id + 1, ESR_LIGHT_UNSEEN added on the light's part no
                             camera sees (train/lights/lights.h); NULL when n == 0 */
    /* emitting regions large enough to be lights that esr_lights_find left out, past the
     * ESR_MAX_LIGHTS largest (not saved: said where they are found) */
    int n_left_out;
    /* what the last calibration decided about each light's undecided rim (ESR_LIGHT_UNDECIDED;
     * not saved: said where decided): its surface points (0: it had none), whether it emits,
     * and how clearly the light it casts said so (train/lights/fit.h, esr_calib_decide_rims) */
    struct esr_light_rim {
        long points;
        int emits;
        float t_on;
    } rim[ESR_MAX_LIGHTS];
    /* The colour balance found from the lights' own silhouettes (train/lights/lights.h,
     * esr_lights_balance): the base colour is this times the BRDF field's, the environment map
     * the field's over this, per channel (the images fix only their product). 0 0 0: none (1). */
    float balance[3];
    /* an edit in place (edit/finetune.h; not saved): emitted radiance is each light's calibrated
     * emission edited by edit[K]; edited 0: as found */
    int edited;
    struct esr_light_edit edit[ESR_MAX_LIGHTS];
};

/* A label's flag for a light's unseen part: surface next to the light that no training camera
 * sees (a lampshade's underside), or that only lights-off or clipped photos show and whose light
 * the photos ask for (train/lights/lights.h), which emits the light's mean field, not the field there. */
#define ESR_LIGHT_UNSEEN 0x80u
/* A label's flag, between finding the lights and calibrating them only (never saved), for a
 * light's undecided rim: outer surface next to it that only lights-off or clipped photos see,
 * which may emit or not (the calibration decides, train/lights/lights.h). */
#define ESR_LIGHT_UNDECIDED 0x40u
/* The light id + 1 of a label (0: no light). */
#define ESR_LIGHT_LABEL_ID(label) ((int)((label) & 0x3fu))

void esr_lights_free(struct esr_lights *L);

/* L's colour balance (1 1 1 when it has none, or no lights). */
void esr_lights_balance_of(const struct esr_lights *L, float b[3]);
/* 1 when L carries a colour balance other than 1 1 1. */
int esr_lights_balanced(const struct esr_lights *L);
/* Divides n environment radiances (rgb3 [n*3], in place) by L's colour balance. */
void esr_lights_balance_env(const struct esr_lights *L, float *rgb3, size_t n);
/* A light's radiance (scale x field_rgb) and power from its scale and area. */
void esr_light_update_radiance(struct esr_light *l);

/* A 64-bit hash (FNV-1a) of the lights (table, labels and colour balance; not an edit in
 * place): renders record it, so that lights found again (`esr lights --recompute`) make earlier
 * renders stale. */
uint64_t esr_lights_fingerprint(const struct esr_lights *L);

/* The edited emission of radiance e (linear RGB) under edit ed: times the intensity, then hue and
 * saturation replaced with V kept when ed->recolour (seed eqs. 10-15). Computed as
 * w * e, or w * V(e) on every channel with a recolour (w: esr_light_edit_weights), so that an
 * edit is linear in each light's found emission, or in its value V: a light's contribution at
 * found colour and at unit colour times V give any edit of it exactly (edit/relight.h's layers). */
void esr_light_edit_apply(const struct esr_light_edit *ed, const float e[3], float out[3]);
/* The per-channel weights of edit ed: intensity (no recolour), or intensity times the colour of
 * hue, saturation and value 1 (a recolour; it multiplies the emission's value V). */
void esr_light_edit_weights(const struct esr_light_edit *ed, float w[3]);
/* The value V of the HSV model: the largest channel of e. */
float esr_light_value(const float e[3]);

/* Removes light id (a reflection the user judges no light, say): its surface leaves the labels,
 * the lights above it move down one id, their table entries with them. The others' strengths
 * stay as they are (train/lights/lights.h's calibration fits them again without it). ESR_ERR for an
 * id outside [0, n). */
int esr_lights_drop(struct esr_lights *L, int id);

/* unseen[id] = the light's lattice points that carry ESR_LIGHT_UNSEEN (its part no camera sees),
 * for id < L->n. */
void esr_lights_unseen_points(const struct esr_lights *L, long unseen[ESR_MAX_LIGHTS]);

/* The label of a surface point: that of the nearest labelled corner of its lattice cell, or 0. */
uint8_t esr_lights_label_at(const struct esr_lights *L, const float pos[3]);
/* Light id of a surface point (the label of the nearest labelled corner of its lattice cell),
 * or -1. */
int esr_lights_id_at(const struct esr_lights *L, const float pos[3]);

/* The calibrated emission of n points: emit3 [n*3] multiplied in place by the scale of each
 * point's light (on the light's unseen part its mean field, field_rgb, replaces E there, as in
 * its light samples), then edited by its edit when one is in place (points on no light keep
 * E). */
void esr_lights_scale_emission(const struct esr_lights *L, const float *pos3, size_t n, float *emit3);

/* Sets emit3 [n*3] to 0 at the points on no light. */
void esr_lights_keep_lit(const struct esr_lights *L, const float *pos3, size_t n, float *emit3);

#ifdef __cplusplus
}
#endif
#endif
