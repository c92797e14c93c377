/* Direct light from the found lights at surface points, by area sampling: for each point x,
 * each outgoing direction wo and each light K,
 *     D_K(x, wo) = sum over K's surface of E_K(y) R(x, wo, wi) |n_y . wi| / d^2 dA
 * estimated with spp area samples y (stratified over K's labelled surface points, each standing
 * for its area) and a shadow ray to each (first hit of the SDF before y: occluded). Sampling the
 * lights by area, not by direction, keeps D nearly noise-free even for a small bright light,
 * which a few hemisphere directions hit only by chance. Used by the calibration of the lights'
 * strength (train/lights/lights.h), by radiance fine-tuning (edit/finetune.h), which needs the edited
 * lights' light exactly, and per pixel by direct and ratio relighting (edit/relight.h). */
#ifndef ESR_TRAIN_LIGHT_DIRECT_H
#define ESR_TRAIN_LIGHT_DIRECT_H

#include <stddef.h>
#include <stdint.h>

#include "core/brdf.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "model/model.h"
#include "train/lights/surface.h"
#include "volume/first_hit.h"

#ifdef __cplusplus
extern "C" {
#endif

/* outgoing directions per point at most (the LTS points' two: the camera's and one more) */
#define ESR_DIRECT_MAX_WO 2

struct esr_direct_points {
    size_t n;
    const float *pos3, *nrm3; /* [n*3] surface points and their unit normals */
    const float *brdf5;       /* [n*ESR_BRDF_CHANNELS] their BRDF rows (material fields) */
    const float *wo3;         /* [n*n_wo*3] unit outgoing directions, away from the surface */
    int n_wo;                 /* 1..ESR_DIRECT_MAX_WO */
};

/* A model's SDF as shadow rays march it (volume/first_hit.h: the grid's global bound G takes a
 * pass over the grid), prepared once for every call while the SDF stays the same: a fine-tune
 * (geometry frozen) or a calibration. Holds its own copy of the SDF as first hits see it
 * (model/render_sdf.h, esr_model_first_hit_sdf: no surface where the renderer skips space). */
struct esr_light_shadows {
    struct esr_first_hit_grid grid;
    struct esr_first_hit_params params;
    float *sdf;
    float voxel; /* the SDF grid's voxel edge along x: shadow rays start 1 voxel off the
                    surface and stop 1.5 short of the light's sample */
};
int esr_light_shadows_init(struct esr_light_shadows *s, const struct esr_model *m);
/* Frees what init allocated; a zeroed struct frees nothing. */
void esr_light_shadows_free(struct esr_light_shadows *s);

/* One surface point x (unit normal n, material mat) and light ls: spp area samples, stratified
 * over the light's points (stored in lattice order, so the strata are patches of its surface),
 * each with a shadow ray from x + 1 voxel n to 1.5 voxels short of the sample (wi and d are
 * measured from x itself; a sample within 2.5 voxels of x is left out). ADDS
 * scale e R(wo_w, wi) |n_y . wi| A N / (spp d^2) per sample and channel (N: the light's point
 * count, A the sample's area) into edited[w] for each of the n_wo
 * outgoing directions wo (e: the sample's emission edited by *edit, or as found when edit is
 * NULL) and, when found is not NULL, the same with the emission as found into found[w], and
 * when value is not NULL, the same with the found emission's value V (model/lights.h,
 * esr_light_value) on every channel into value[w] (what a recolour multiplies). A
 * back-facing wo gets nothing; a sample no wo sees is not traced. Draws from rng; returns the
 * shadow rays traced. The kernel of esr_lights_direct and of direct relighting
 * (edit/relight.h). The sums are float (esr_lights_direct adds each light's into its double
 * output). */
struct esr_direct_point_query {
    const struct esr_light_shadows *sh;
    const struct esr_light_samples *ls; /* the light */
    const struct esr_light_edit *edit;  /* its edit, or NULL: as found */
    int spp;
    const struct esr_material *mat;     /* at x */
    struct esr_vec3 x, n;               /* the point and its unit normal */
    const struct esr_vec3 *wo;          /* n_wo unit outgoing directions */
    int n_wo;
    float scale;                        /* what each sample's light is multiplied by */
};
size_t esr_light_direct_point(const struct esr_direct_point_query *q, struct esr_rng *rng,
                              float (*edited)[3], float (*found)[3], float (*value)[3]);

/* The lights whose direct light esr_lights_direct sums, and how it samples them. */
struct esr_direct_lights {
    const struct esr_light_shadows *sh; /* the SDF the shadow rays march */
    const struct esr_light_samples *ls; /* [n] each light's surface samples */
    int n;                              /* lights, 0..ESR_MAX_LIGHTS */
    const struct esr_light_edit *edits; /* [n] each sample's emission edited by its light's edit,
                                           or NULL: as the samples carry it */
    int spp;                            /* area samples per point and light */
};

/* out[((p * n_wo + o) * ESR_MAX_LIGHTS + K) * 3 + c] = D_K (per channel) for the lights of *L;
 * out_found (or NULL), the same for the emission as found, from the same samples and shadow
 * rays (what fine-tuning compares). Zero for a back-facing wo. Deterministic in seed. Fails
 * (writing nothing) unless pts->n_wo is 1..ESR_DIRECT_MAX_WO and L->n 0..ESR_MAX_LIGHTS. */
int esr_lights_direct(const struct esr_direct_lights *L, const struct esr_direct_points *pts,
                      uint64_t seed, double *out, double *out_found);

#ifdef __cplusplus
}
#endif
#endif
