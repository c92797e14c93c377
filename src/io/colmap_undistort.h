/* Photos from COLMAP cameras (any supported model, principal point anywhere, fx != fy) resampled
 * to the camera esr uses: a pinhole with square pixels and the principal point at the image
 * centre, no distortion, at a chosen size. */
#ifndef ESR_IO_COLMAP_UNDISTORT_H
#define ESR_IO_COLMAP_UNDISTORT_H

#include "io/colmap.h"
#include "io/image.h"

/* An undistorted centred pinhole view: pixel (i, j)'s centre looks along the normalised
 * direction ((i + 0.5 - width/2) / focal, (j + 0.5 - height/2) / focal, 1) in COLMAP's camera
 * frame (y down). */
struct esr_pinhole_view {
    int width, height;
    double focal; /* pixels */
};

/* Half extents, as tangents of the half fields of view, of the largest rectangle centred on the
 * optical axis that lies inside cam's image once undistorted: the border of the image is mapped
 * through the inverted distortion, the rectangle bounded by its innermost points, then shrunk
 * until its own border maps inside the image. Fails naming the camera when the distortion cannot
 * be inverted at the image border or the principal point lies outside the image. */
int esr_colmap_valid_extent(const struct esr_colmap_camera *cam, double *half_x, double *half_y);

/* Resamples src (cam's pixels as stored, any channel count) into view: every output pixel
 * averages k x k samples spread over its area (k = ceil(source focal / view focal), at most 16),
 * each taken from src by bilinear interpolation at the distorted position, so shrinking is an
 * area filter and no source pixel is skipped. Parallel over rows. */
int esr_colmap_undistort_image(const struct esr_colmap_camera *cam, const struct esr_image *src,
                               const struct esr_pinhole_view *view, struct esr_image *dst);

#endif
