/* COLMAP's camera maths: its projection (world -> camera -> normalised image plane -> lens
 * distortion -> pixels) for the models in colmap.h, the inverse of the distortion, and the
 * conversion of its poses to esr's camera-to-world matrices.
 *
 * COLMAP's conventions: x_cam = R(q) x_world + t; the camera looks along +Z with +X right and +Y
 * down in the image; pixel (0, 0)'s centre is at (0.5, 0.5), as in esr. esr (Blender/OpenGL,
 * io/camera.h): the camera looks along -Z, +Y is image-up. */
#ifndef ESR_IO_COLMAP_CAMERA_H
#define ESR_IO_COLMAP_CAMERA_H

#include "import/colmap.h"

/* Every supported model as the general OPENCV form (unused terms 0), plus a skew that no COLMAP
 * model has but calibrated cameras such as DTU's do, so the undistortion (colmap_undistort.h)
 * serves those too. */
struct esr_colmap_intrinsics {
    double fx, fy, cx, cy;
    double skew;   /* pixels of x per unit of normalised y: px = fx u + skew v + cx */
    double k1, k2; /* radial: 1 + k1 r^2 + k2 r^4 */
    double p1, p2; /* tangential */
};

void esr_colmap_intrinsics_of(const struct esr_colmap_camera *cam, struct esr_colmap_intrinsics *k);

/* Distorted normalised image-plane position (ud, vd) <-> continuous pixel position (centres at
 * +0.5), through fx, fy, skew, cx, cy. */
void esr_colmap_to_pixel(const struct esr_colmap_intrinsics *k, double ud, double vd, double *px, double *py);
void esr_colmap_from_pixel(const struct esr_colmap_intrinsics *k, double px, double py, double *ud, double *vd);

/* Lens distortion on the normalised image plane (x/z, y/z), COLMAP's formula:
 * ud = u + u (k1 r^2 + k2 r^4) + 2 p1 u v + p2 (r^2 + 2 u^2), vd likewise with u, v and p1, p2
 * swapped. */
void esr_colmap_distort(const struct esr_colmap_intrinsics *k, double u, double v, double *ud, double *vd);
/* Its inverse by Newton's method; returns ESR_ERR (no message) when it does not converge to
 * 1e-10, e.g. beyond the radius where the distortion folds back. */
int esr_colmap_undistort(const struct esr_colmap_intrinsics *k, double ud, double vd, double *u, double *v);

/* World point -> continuous pixel position of image `im` taken with `cam`; 0 when the point is
 * not in front of the camera. */
int esr_colmap_project(const struct esr_colmap_camera *cam, const struct esr_colmap_image *im,
                       const double world[3], double *px, double *py);


/* Camera-to-world matrix of image `im` in esr's convention: rotation R^T diag(1, -1, -1) (the
 * camera's +Y and +Z flipped to image-up and backwards) and centre -R^T t. */
void esr_colmap_camera_to_world(const struct esr_colmap_image *im, double c2w[3][4]);

#endif
