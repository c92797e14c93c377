/* Scene datasets: the authors' ESR-NeRF layout (../shared/scenes/FORMAT.md, five phases with
 * per-frame lights) and the plain NeRF-synthetic layout (train/val/test, all frames "off").
 * Loading reads and validates the JSON; images are read on demand. */
#ifndef ESR_IO_DATASET_H
#define ESR_IO_DATASET_H

#include "io/camera.h"
#include "io/image.h"

enum esr_phase_id {
    ESR_PHASE_TRAIN,
    ESR_PHASE_TEST_NV,
    ESR_PHASE_TEST_NVI,
    ESR_PHASE_TEST_NVC,
    ESR_PHASE_TEST_NVIC,
    ESR_PHASE_VAL, /* NeRF-synthetic only */
    ESR_PHASE_COUNT
};
const char *esr_phase_name(enum esr_phase_id phase); /* "train", "test_nv", ... */
int esr_phase_from_name(const char *name, enum esr_phase_id *out);

enum esr_light_mode {
    ESR_LIGHT_OFF,
    ESR_LIGHT_ON,
    ESR_LIGHT_I_CHANGE,
    ESR_LIGHT_C_CHANGE,
    ESR_LIGHT_IC_CHANGE,
    ESR_LIGHT_MODE_COUNT
};
const char *esr_light_mode_name(enum esr_light_mode mode); /* "off", "on", "i_change", ... */

enum esr_layout { ESR_LAYOUT_ESR, ESR_LAYOUT_NERF_SYNTHETIC };

#define ESR_PATH_MAX 1024
#define ESR_NAME_MAX 128

struct esr_light_state {
    enum esr_light_mode mode;
    float hsv[3];      /* target colour; [0,0,1] = original colour */
    float intensity;   /* multiplier of the light's "on" strength */
    char mask_path[ESR_PATH_MAX]; /* relative, no extension; "" when none */
};

struct esr_frame {
    char file_path[ESR_PATH_MAX]; /* relative to the scene dir, no extension */
    char name[ESR_NAME_MAX];      /* last path component, e.g. "c003_on" */
    struct esr_camera camera;
    int lights_on;                /* 1 when any light has intensity > 0 */
    struct esr_light_state *lights; /* dataset.n_lights entries */
    /* the photo's exposure as its camera recorded it (the frame's "exposure": EXIF ExposureTime,
     * FNumber, ISO, which `esr import colmap` and `esr synth --exif` write): has_exposure 1 and
     * exposure_ev = log2(time * ISO / f-number^2), the light the sensor took in, in stops */
    int has_exposure;
    double exposure_ev;
};

struct esr_phase {
    int present;
    int n_frames;
    struct esr_frame *frames;
};

#define ESR_MAX_TRUE_LIGHTS 16

/* A light as scene.json records it (ground truth, evaluation only). */
struct esr_true_light {
    char name[64];
    float radiance[3];            /* emitted radiance when on: linear RGB x strength */
};

struct esr_dataset {
    char root[ESR_PATH_MAX];
    enum esr_layout layout;
    int width, height;        /* the size most of the first 5 decodable training images have */
    float camera_angle_x;
    float focal;
    int n_lights;
    float bbox_min[3], bbox_max[3]; /* scene box: scene.json when present, else [-1.5,1.5]^3 */
    int bbox_from_scene;      /* 1 when bbox_min/max come from scene.json */
    int bbox_made_cubic;      /* 1 when scene.json's box was not a cube and was widened to one
                                 about its centre (the model's voxels are cubes) */
    int n_true_lights;        /* scene.json's "lights" with "emitted_radiance_on" (0: none) */
    struct esr_true_light true_lights[ESR_MAX_TRUE_LIGHTS];
    struct esr_phase phases[ESR_PHASE_COUNT];
};

/* Where the scene box came from, for reports: "scene.json", "scene.json, widened to a cube" or
 * "default". */
const char *esr_dataset_bbox_source(const struct esr_dataset *ds);

/* Reads the transforms JSON of every phase and the image size (the one most of the first 5
 * training images that decode have; esr_dataset_check reports the images that differ). The layout is
 * detected: DIR/transforms/transforms_train.json (ESR; test phases whose file is absent are
 * marked not present) or DIR/transforms_train.json (NeRF-synthetic: train, val, test -> the
 * test_nv slot; no lights). Fails with a message naming the file (and frame) and the problem on
 * malformed or incomplete JSON, unknown light modes, non-finite or degenerate matrices, a light
 * count that differs between frames, or no training image among them that decodes. On failure ds
 * is left freed. */
int esr_dataset_load(const char *dir, struct esr_dataset *ds);
void esr_dataset_free(struct esr_dataset *ds);

/* The JSON readers behind esr_dataset_load, from size bytes of text in memory (name stands for
 * the file in messages; the fuzz harness drives them): one phase's transforms file into
 * ds->phases[phase], for a ds prepared as the loader does (zeroed, layout and root set, n_lights
 * -1 until a frame fixes it; free it with esr_dataset_free on success and failure), and
 * scene.json's bounding box and true lights. Frames whose file_path or mask_path is absolute or
 * has a ".." component, matrices that are not rigid, and a file_path repeated in a phase are
 * refused. */
int esr_dataset_parse_transforms(struct esr_dataset *ds, enum esr_phase_id phase, const char *text, size_t size,
                                 const char *name);
int esr_dataset_parse_scene(struct esr_dataset *ds, const char *text, size_t size, const char *name);

/* The lighting mode of a frame: its first light's mode ("off" when the dataset has no lights). */
enum esr_light_mode esr_frame_mode(const struct esr_dataset *ds, const struct esr_frame *f);
/* Name of the phase's transforms file as this layout spells it, e.g. "transforms_test.json". */
const char *esr_phase_file_name(const struct esr_dataset *ds, enum esr_phase_id phase);

/* The name of the lights-off frame of the camera of lights-on frame `name` ("c003_on" ->
 * "c003_off", the layout's naming); 0 when name does not end in "_on" or out is too small. */
int esr_frame_off_partner(const char *name, char *out, size_t n);

/* Full path of a frame's image (".png" appended unless file_path ends in .png, .jpg or .jpeg) / its EXR / its emission mask / light K's mask
 * ("" when the light has no mask_path). */
void esr_frame_image_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n);
void esr_frame_exr_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n);
void esr_frame_emission_path(const struct esr_dataset *ds, const struct esr_frame *f, char *out, size_t n);
void esr_frame_light_mask_path(const struct esr_dataset *ds, const struct esr_frame *f, int light, char *out,
                               size_t n);

/* Loads a frame's image (PNG, or JPEG when file_path names one) composited on white as RGB (the authors' loader: rgb*a + (1-a)), also
 * returning alpha when `alpha` is non-NULL (1 channel). Checks the size against the dataset. */
int esr_frame_load_rgb(const struct esr_dataset *ds, const struct esr_frame *f, struct esr_image *rgb,
                       struct esr_image *alpha);

/* Checks every referenced file exists, decodes, and has the dataset's size: each frame's PNG,
 * each light mask named in the JSON, and for test phases that have an exr/ (emission/) folder
 * the frame's EXR (emission mask). Calls `report` once per problem found, in frame order.
 * Returns the number of problems (0 = valid), or ESR_ERR if the check itself could not run. */
typedef void (*esr_problem_fn)(void *user, const char *message);
int esr_dataset_check(const struct esr_dataset *ds, esr_problem_fn report, void *user);

#endif
