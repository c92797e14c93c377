/* A DTU scan as NeuS and IDR distribute it turned into a dataset in the ESR layout
 * (../shared/scenes/FORMAT.md).
 *
 * Input (SCAN): cameras_sphere.npz (import/dtu_cameras.h), image/<n>.png (or .jpg; n the camera
 * index, e.g. 000000.png), optionally mask/<n>.png or mask/%03d.png (grey or RGB, > 127 is
 * foreground). Every photo is a lights-off training frame.
 *
 * Output: DATA/transforms/transforms_train.json (camera_angle_x; per frame file_path
 * "train/<stem>_off", the camera-to-world transform_matrix, one light "off", "dtu_image" and
 * "dtu_camera": the photo and its camera index), the photos as 8-bit PNGs DATA/train/<stem>_off.png
 * (RGB; RGBA with the mask as alpha when the scan has masks, which esr composites on white as it
 * does NeRF-synthetic), and DATA/import.json (the mapping from the normalised frame, whether
 * masks were used). Each photo is resampled into one centred pinhole with square pixels shared by
 * all frames (import/colmap_undistort.h), `size` pixels on the longer side. The normalised frame's
 * unit sphere becomes esr's unit sphere (scale 1, or less if the cameras' median distance exceeds
 * 4), turned so the cameras' mean image-up is +Z (import/colmap_scene.h). Written into a staging
 * folder renamed at the end, so DATA is never half-written. */
#ifndef ESR_IO_DTU_IMPORT_H
#define ESR_IO_DTU_IMPORT_H

#include "import/colmap_scene.h"

struct esr_dtu_import_opts {
    const char *scan_dir;   /* SCAN */
    const char *out_dir;    /* DATA; absent or empty unless force */
    int size;               /* longer side of the written images, pixels */
    int force;              /* replace a non-empty out_dir */
    void (*progress)(void *user, int done, int total); /* after each photo; may be NULL */
    void *user;
};

struct esr_dtu_import_result {
    int n_frames;
    int masks;                    /* 1 when mask/ was used as alpha */
    int source_width, source_height;
    int width, height;            /* of the written images */
    double focal;                 /* pixels */
    double camera_angle_x;
    struct esr_scene_frame frame; /* esr = scale * rotation * normalised */
    double cam_dist_min, cam_dist_max;
};

/* Fails naming the file on: a missing image/ folder or cameras_sphere.npz, a photo name that is
 * not a number, a photo without its camera (world_mat_<n>, scale_mat_<n>) or, when mask/ exists,
 * without its mask, an array that is not a 4x4 float .npy, a photo or mask that does not decode,
 * photos of different sizes, a mask whose size is not its photo's. Nothing is left in out_dir on
 * failure. */
int esr_dtu_import(const struct esr_dtu_import_opts *o, struct esr_dtu_import_result *r);

#endif
