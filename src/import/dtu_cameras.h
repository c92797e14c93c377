/* DTU cameras as NeuS and IDR distribute them: cameras_sphere.npz holds, per image i,
 * world_mat_<i> (4x4, P = K [R | t]: world -> image, OpenCV's camera frame) and scale_mat_<i>
 * (4x4: the normalised frame, whose unit sphere holds the object, -> world). NeuS projects with
 * world_mat @ scale_mat and splits that into K and a pose (cv2.decomposeProjectionMatrix); so does
 * this, with import/projection.h. */
#ifndef ESR_IO_DTU_CAMERAS_H
#define ESR_IO_DTU_CAMERAS_H

#include "import/colmap_camera.h"
#include "io/npz.h"

struct esr_dtu_camera {
    struct esr_colmap_intrinsics k; /* fx, fy, skew, cx, cy; no distortion */
    double c2w[3][4];               /* camera-to-world, esr's convention (looks along -Z, +Y image-up),
                                       in the normalised frame */
};

/* Camera i, for the photo named `image` (in messages). Fails naming the file, the key and the
 * photo when world_mat_<i> or scale_mat_<i> is missing or not a 4x4 float array, the projection
 * is singular, or the unit sphere's centre lies behind the camera. */
int esr_dtu_camera_read(const struct esr_npz *z, int i, const char *image, struct esr_dtu_camera *out);

#endif
