/* Incident radiance along the LTS secondary rays, one implementation per estimator (see lts.h):
 * trace the rays and append their point-field query rows, read L_i from the evaluated rows, and
 * send d loss/d L_i back to those rows, the environment map and the geometry. Used by
 * train/lts.c only. */
#ifndef ESR_TRAIN_LTS_INCIDENT_H
#define ESR_TRAIN_LTS_INCIDENT_H

#include <stddef.h>
#include <stdint.h>

#include "model/model.h"
#include "train/lts.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Grows l's query-row buffers to hold `rows` rows (the tone gradient stays all zero). */
int esr_lts_reserve_rows(struct esr_lts *l, size_t rows);

/* Traces the P*M secondary rays (l->orig3, l->wi3) through `sdf` and writes their query rows
 * from row 4P on; *rows = the total row count. */
int esr_lts_incident_trace(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                           size_t P, uint64_t seed, size_t *rows);
/* After the point fields' forward: l->li_off3 and l->li_emo3 (l->env3 must be filled). */
void esr_lts_incident_gather(struct esr_lts *l, size_t P);
/* After the gather, with lights in the transport (l->lights, esr_lts_set_lights): l->li_emo3 of
 * each direction whose first hit lies on a light becomes the light's calibrated emission there
 * (emo_fixed marks them: the scatter sends them no gradient). */
int esr_lts_incident_lights(struct esr_lts *l, const struct esr_model *m, const float *sdf,
                            size_t P);
/* Given l->d_li_off3 / d_li_emo3: ADDS into l->d_lin3's secondary rows and g_sdf, sets
 * l->d_env3. Returns the secondary rays that reached a surface. */
size_t esr_lts_incident_scatter(struct esr_lts *l, size_t P, float *g_sdf);

#ifdef __cplusplus
}
#endif
#endif
