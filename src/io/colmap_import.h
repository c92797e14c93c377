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
 * centred pinhole shared by all frames (io/colmap_undistort.h) whose field of view is the largest
 * that every camera covers, and resampled so its longer side has `size` pixels. The scene is
 * placed by io/colmap_scene.h. Written into a staging folder renamed at the end, so DATA is never
 * half-written. */
#ifndef ESR_IO_COLMAP_IMPORT_H
#define ESR_IO_COLMAP_IMPORT_H

#include "io/colmap_scene.h"

struct esr_colmap_import_opts {
    const char *model_dir;  /* COLMAP sparse model (text or binary) */
    const char *images_dir; /* IMAGES: off/ and on/ */
    const char *out_dir;    /* DATA; absent or empty unless force */
    int size;               /* longer side of the written images, pixels */
    int force;              /* replace a non-empty out_dir */
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
};

/* Fails naming the file on: a model that cannot be read, fewer than 3 registered images, an
 * image outside off/ and on/, two photos that would get the same output name, a missing or
 * undecodable photo, a photo whose size is not its camera's, or a camera whose distortion
 * leaves no undistorted view. Nothing is left in out_dir on failure. */
int esr_colmap_import(const struct esr_colmap_import_opts *o, struct esr_colmap_import_result *r);

#endif
