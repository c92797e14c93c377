/* Geometry score of a trained model against a dataset's ground-truth surface (the gt/mesh.ply
 * that `esr synth` writes): the model's zero level set by marching cubes, compared by Chamfer
 * distance (eval/chamfer.h) in scene units. */
#ifndef ESR_EVAL_GEOMETRY_H
#define ESR_EVAL_GEOMETRY_H

#include <stddef.h>

#include "eval/chamfer.h"
#include "model/model.h"

/* Samples drawn on each surface: enough for the mean distances to settle to ~1e-4 of a unit
 * scene while staying a second or two of work. */
#define ESR_GEOMETRY_SAMPLES 200000

/* The dataset's ground-truth mesh path (DATA/gt/mesh.ply) into out; 0 when it does not exist
 * (real captures have none), 1 when it does. */
int esr_geometry_gt_path(const char *data_dir, char *out, size_t n);

/* Extracts m's surface (esr_model_mesh at the model's grid resolution) and scores it against the
 * mesh in gt_path. Fails on an unreadable ground truth or a model without a surface. */
int esr_geometry_score(const struct esr_model *m, const char *gt_path, struct esr_chamfer_result *out);

/* Writes {"gt_mesh", "samples", "accuracy", "completeness", "chamfer"} to path atomically. */
int esr_geometry_write_json(const char *path, const char *gt_path, const struct esr_chamfer_result *r);

#endif
