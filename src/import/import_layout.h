/* What every importer (`esr import colmap`, `esr import dtu`) writes in the ESR layout
 * (../shared/scenes/FORMAT.md) inside its staging folder (io/staging.h): the folders, a training
 * frame's JSON entry and transforms/transforms_train.json. */
#ifndef ESR_IO_IMPORT_LAYOUT_H
#define ESR_IO_IMPORT_LAYOUT_H

#include <cjson/cJSON.h>

#include "import/colmap_scene.h"
#include "io/dataset.h"

/* A path inside a staging folder (at most ESR_PATH_MAX long): a file name or two more. */
#define ESR_STAGED_PATH (ESR_PATH_MAX + ESR_NAME_MAX + 64)

/* staging/train and staging/transforms. */
int esr_import_layout_dirs(const char *staging);

/* staging/train/<name>.png, 8-bit; img is freed in every case. */
int esr_import_write_image(const char *staging, const char *name, struct esr_image *img);

/* A photo's pixels as an importer writes them: grey expanded and any alpha composited on white
 * (as the dataset loader does), then, when mask_path is not empty, the foreground mask as alpha:
 * 1 where its first channel exceeds 127 of 255, else 0 (DTU's and COLMAP's masks are binary; a
 * fringe of partial alpha comes from resampling, not from the mask). Fails naming both files when
 * the mask is unreadable or not the photo's size. photo is freed in every case. */
int esr_import_photo_pixels(struct esr_image *photo, const char *photo_path, const char *mask_path,
                            struct esr_image *out);

/* A training frame: file_path "train/<name>", the camera-to-world matrix (esr's convention and
 * world, 4x4 with the row 0 0 0 1), one light, "off" (intensity 0) or "on" (1), original colour,
 * no mask. The importer adds its own keys naming the source photo. NULL on out of memory. */
cJSON *esr_import_frame_json(const char *name, const double c2w[3][4], int lights_on);

/* staging/transforms/transforms_train.json: camera_angle_x and the frames (an array of
 * esr_import_frame_json objects; ownership taken). */
int esr_import_write_transforms(const char *staging, double camera_angle_x, cJSON *frames);

/* Widens [*dist_min, *dist_max] to the camera centre's distance from esr's origin. */
void esr_import_camera_distance(const double c2w[3][4], double *dist_min, double *dist_max);

/* import.json's common part: {"source": source, "mapping": mapping, "centre", "rotation",
 * "scale"} of the placement f; the importer adds what it read. NULL on out of memory. */
cJSON *esr_import_record(const char *source, const char *mapping, const struct esr_scene_frame *f);
/* staging/import.json (ownership of root taken). */
int esr_import_write_record(const char *staging, cJSON *root);

#endif
