/* The lights' surface (train/lights/lights.h), what finding, calibrating and lighting them share: the
 * SDF lattice points next to the zero level set projected onto it, the area each stands for, the
 * emission field there, and one light's surface samples for direct lighting. */
#ifndef ESR_TRAIN_LIGHT_SURFACE_H
#define ESR_TRAIN_LIGHT_SURFACE_H

#include <stddef.h>
#include <stdint.h>

#include "fields/grid.h"
#include "model/model.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Lattice points of m's SDF with a sign change to an axis neighbour, outside the space the
 * renderer skips (the mask cache; model/render_sdf.h says why): their indices, surface
 * positions (projected along the SDF gradient by at most a voxel) and unit normals, allocated
 * (*n_out of each; free them). */
int esr_light_surface_points(const struct esr_model *m, uint32_t **idx_out, float **pos_out,
                             float **nrm_out, size_t *n_out);
/* The area a surface point with unit normal nrm stands for, on a lattice of spacing h. */
float esr_light_point_area(float h, const float *nrm);
/* The emission field E at n points (emit3 [n*3]), in chunks. */
int esr_light_emission_at(const struct esr_model *m, const float *pos3, size_t n, float *emit3);

/* Surface samples of one light for direct lighting (edit/relight.h): the light's labelled
 * surface points, unit normals, calibrated emitted radiance (scale x E) and the area each stands
 * for (as in the light's area). */
struct esr_light_samples {
    size_t n;
    float *pos3, *nrm3, *emit3, *area;
    double total_area;
    float max_emit;       /* largest channel of any sample's emission (0: the light is dark) */
};

int esr_light_samples_get(const struct esr_model *m, int id, struct esr_light_samples *out);
/* The same over part of the light: all of it, its settled part, or its undecided rim
 * (ESR_LIGHT_UNDECIDED, between finding and calibrating). */
enum esr_light_part { ESR_LIGHT_PART_ALL, ESR_LIGHT_PART_SETTLED, ESR_LIGHT_PART_UNDECIDED };
int esr_light_samples_part(const struct esr_model *m, int id, enum esr_light_part part,
                           struct esr_light_samples *out);
void esr_light_samples_free(struct esr_light_samples *s);

#ifdef __cplusplus
}
#endif
#endif
