/* A photographed capture posed by COLMAP turned into a dataset in the ESR layout
 * (../shared/scenes/FORMAT.md) that every esr command reads.
 *
 * Capture layout: IMAGES/off/ holds the photos taken with the lights off, IMAGES/on/ those with
 * the lights on (JPEG or PNG, any names, subfolders allowed); the COLMAP model names them as
 * COLMAP records them, relative to IMAGES ("off/x.jpg").
 *
 * Output: DATA/transforms/transforms_train.json (camera_angle_x; per frame file_path
 * "train/<stem>_<off|on>", the camera-to-world transform_matrix, one light whose mode and
 * intensity say off or on, and "colmap_image": the photo's name in the model), the photos as
 * 8-bit RGB PNGs DATA/train/<stem>_<off|on>.png, and DATA/import.json (where the scene was put:
 * centre, rotation, scale; the model and image folders). Every photo is undistorted to one
 * centred pinhole shared by all frames (import/colmap_undistort.h) whose field of view is the largest
 * that every camera covers, and resampled so its longer side has `size` pixels. The scene is
 * placed by import/colmap_scene.h. Written into a staging folder renamed at the end, so DATA is never
 * half-written. */
#ifndef ESR_IO_COLMAP_IMPORT_H
#define ESR_IO_COLMAP_IMPORT_H

#include "import/colmap_align.h"
#include "import/colmap_scene.h"

struct esr_colmap_import_opts {
    const char *model_dir;  /* COLMAP sparse model (text or binary) */
    const char *images_dir; /* IMAGES: off/ and on/ */
    const char *out_dir;    /* DATA; absent or empty unless force */
    int size;               /* longer side of the written images, pixels */
    int force;              /* replace a non-empty out_dir */
    const char *align_to;   /* NULL, or the true dataset the photos were rendered from: see below */
    const char *masks_dir;  /* NULL, or foreground masks in COLMAP's layout: MASKS/<image name>.png
                               (off/x.jpg -> MASKS/off/x.jpg.png, as colmap's
                               --ImageReader.mask_path reads them), or MASKS/off/x.png; one per
                               registered photo, its size, > 127 foreground; they become alpha */
    void (*progress)(void *user, int done, int total); /* after each photo; may be NULL */
    void *user;
};

struct esr_colmap_import_result {
    const char *format;      /* "text" or "binary" */
    int n_frames, n_off, n_on;
    int width, height;       /* of the written images */
    double focal;            /* pixels */
    double camera_angle_x;
    struct esr_scene_frame frame;
    double cam_dist_min, cam_dist_max; /* camera centres' distances from the origin (esr world) */
    int aligned;             /* align_to given: the fields below are set */
    struct esr_colmap_alignment alignment;
    double view_coverage;    /* the true pinhole's half field of view that every COLMAP camera's
                                valid extent covers, as a fraction (1: all; below 1 the outermost
                                output pixels repeat the photos' edge) */
    int n_test_views;        /* test_nv frames copied from the true dataset */
    /* EXIF exposure (ExposureTime, FNumber, ISO) recorded per frame from the JPEG photos: how
     * many carried it, and how many carried absurd values (left out), the first one's reason */
    int n_exposure, n_exposure_bad;
    char exposure_bad[256];
};

/* With align_to (a synthetic capture whose true cameras are known, e.g. `esr synth`'s training
 * renders posed by COLMAP; import/colmap_align.h): the scene is placed by the similarity that aligns
 * the COLMAP cameras to the true ones, so the import lives in the true world; the photos are
 * written in the true dataset's pinhole (its size and camera_angle_x; `size` is not used) and the
 * true test_nv phase is copied in (import/colmap_test_views.h), so both datasets are scored on the
 * same test views; import.json records the camera errors.
 *
 * Fails naming the file on: a model that cannot be read, fewer than 3 registered images, an
 * image outside off/ and on/, two photos that would get the same output name, a missing or
 * undecodable photo, a photo whose size is not its camera's, or a camera whose distortion
 * leaves no undistorted view; with align_to also on a true dataset that does not load, an image
 * with no true train frame of its name, or no test_nv phase. Nothing is left in out_dir on failure. */
int esr_colmap_import(const struct esr_colmap_import_opts *o, struct esr_colmap_import_result *r);

#endif
