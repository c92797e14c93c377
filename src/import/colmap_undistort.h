/* Photos from COLMAP cameras (any supported model, principal point anywhere, fx != fy) and other
 * calibrated cameras given in the same form (DTU's: skew, no distortion) resampled to the camera
 * esr uses: a pinhole with square pixels and the principal point at the image centre, no
 * distortion, at a chosen size. The esr_undistort_* functions take any lens as intrinsics
 * (colmap_camera.h) and an image size; the esr_colmap_* ones are those for a COLMAP camera. */
#ifndef ESR_IO_COLMAP_UNDISTORT_H
#define ESR_IO_COLMAP_UNDISTORT_H

#include "import/colmap.h"
#include "import/colmap_camera.h"
#include "io/image.h"

/* An undistorted centred pinhole view: pixel (i, j)'s centre looks along the normalised
 * direction ((i + 0.5 - width/2) / focal, (j + 0.5 - height/2) / focal, 1) in COLMAP's camera
 * frame (y down). */
struct esr_pinhole_view {
    int width, height;
    double focal; /* pixels */
};

/* The view whose half extents (tangents of the half fields of view) are half_x, half_y, with
 * `size` pixels on its longer side. Fails when the shorter side would have no pixel. */
int esr_pinhole_view_fit(double half_x, double half_y, int size, struct esr_pinhole_view *v);

/* Half extents, as tangents of the half fields of view, of the largest rectangle centred on the
 * optical axis that lies inside cam's image once undistorted: the border of the image is mapped
 * through the inverted distortion, the rectangle bounded by its innermost points, then shrunk
 * until its own border maps inside the image. Fails naming the camera when the distortion cannot
 * be inverted at the image border or the principal point lies outside the image (`camera` names
 * it in the message). */
int esr_undistort_extent(const struct esr_colmap_intrinsics *k, int width, int height, const char *camera,
                         double *half_x, double *half_y);
int esr_colmap_valid_extent(const struct esr_colmap_camera *cam, double *half_x, double *half_y);

/* Resamples src (cam's pixels as stored, any channel count) into view: every output pixel
 * averages k x k samples spread over its area (k = ceil(source focal / view focal), at most 16),
 * each taken from src by bilinear interpolation at the distorted position, so shrinking is an
 * area filter and no source pixel is skipped. Parallel over rows. */
int esr_undistort_resample(const struct esr_colmap_intrinsics *k, const struct esr_image *src,
                           const struct esr_pinhole_view *view, struct esr_image *dst);
/* The same for a COLMAP camera; fails when src's size is not cam's. */
int esr_colmap_undistort_image(const struct esr_colmap_camera *cam, const struct esr_image *src,
                               const struct esr_pinhole_view *view, struct esr_image *dst);

#endif
