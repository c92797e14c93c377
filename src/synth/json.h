/* The JSON files of a synthetic dataset: transforms_<phase>.json and scene.json. */
#ifndef ESR_SYNTH_JSON_H
#define ESR_SYNTH_JSON_H

#include "synth/photo.h"
#include "synth/plan.h"

/* Writes <dir>/transforms/transforms_<phase>.json for the plan's frames of phase, each file_path
 * ending in ext ("" or ".jpg"), and with exposure (one per frame, or NULL) each frame's
 * "exposure" as its JPEG's EXIF records it (what `esr import colmap` writes for photos). */
struct esr_exif_exposure;
int esr_synth_json_transforms(const char *dir, const struct esr_synth_scene *s, const struct esr_synth_plan *plan,
                              enum esr_phase_id phase, const char *ext, const struct esr_exif_exposure *exposure);

/* Render settings recorded in scene.json. */
struct esr_synth_settings {
    int res, spp, n_train, n_test;
    unsigned long long seed;
};

/* Writes <dir>/scene.json: lights, world, bounding boxes, cameras, settings, ground-truth files. */
int esr_synth_json_scene(const char *dir, const struct esr_synth_scene *s, const struct esr_synth_plan *plan,
                         const struct esr_synth_settings *set);

/* Writes <dir>/gt/photos.json: the curve and, per train frame (by file_path), the truth of
 * photo.h: "exposure_stops" (log2 of the exposure factor) and "wb_gain" (three gains). */
int esr_synth_json_photos(const char *dir, const struct esr_synth_plan *plan, const struct esr_photo_options *opt,
                          const struct esr_photo_truth *truth);

#endif
