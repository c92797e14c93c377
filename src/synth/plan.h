/* What a synthetic dataset contains before anything is rendered: the cameras and, per phase,
 * every frame's name, camera and light state (FORMAT.md's schedule of edits). */
#ifndef ESR_SYNTH_PLAN_H
#define ESR_SYNTH_PLAN_H

#include <stdint.h>

#include "io/dataset.h"
#include "synth/scene.h"

#define ESR_SYNTH_CAMERA_ANGLE_X 0.691100001335144
#define ESR_SYNTH_CAMERA_RADIUS 4.0
#define ESR_SYNTH_ELEVATION_MIN_DEG 10.0
#define ESR_SYNTH_ELEVATION_MAX_DEG 75.0

struct esr_synth_frame {
    char name[32];                                /* e.g. "r_017", "c003_i200" */
    int cam;                                      /* index into train_cams or test_cams */
    enum esr_light_mode mode;
    float hsv[ESR_SYNTH_MAX_LIGHTS][3];           /* JSON "color" per light */
    float intensity[ESR_SYNTH_MAX_LIGHTS];        /* JSON "intensity" per light */
    float emission[ESR_SYNTH_MAX_LIGHTS][3];      /* emitted radiance this frame renders with */
};

struct esr_synth_plan {
    int n_train_cams, n_test_cams;
    struct esr_camera *train_cams, *test_cams;
    int n_frames[ESR_PHASE_COUNT];
    struct esr_synth_frame *frames[ESR_PHASE_COUNT]; /* train and the four test phases; VAL empty */
};

/* Cameras on the sphere of radius 4 looking at the origin, elevation 10..75 degrees (uniform over
 * that spherical band's area), azimuth uniform; train and test cameras come from different RNG
 * streams of seed. n_train views lights off + n_train other views lights on; n_test test cameras. */
int esr_synth_plan_make(const struct esr_synth_scene *s, int res, int n_train, int n_test, uint64_t seed,
                        struct esr_synth_plan *out);
void esr_synth_plan_free(struct esr_synth_plan *plan);

/* Short phase tag used in mask names ("nv", "nvi", "nvc", "nvic"); NULL for train. */
const char *esr_synth_mask_tag(enum esr_phase_id phase);

/* The six-colour edit palette of FORMAT.md (hue, saturation 1). */
#define ESR_SYNTH_PALETTE_SIZE 6
extern const float esr_synth_palette_hue[ESR_SYNTH_PALETTE_SIZE];
extern const char *const esr_synth_palette_name[ESR_SYNTH_PALETTE_SIZE];

#endif
