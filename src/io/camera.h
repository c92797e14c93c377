/* Pinhole cameras in the Blender/OpenGL convention used by the dataset (see FORMAT.md):
 * camera looks along local -Z, +Y is image-up, +X image-right; pixel centres at +0.5. */
#ifndef ESR_IO_CAMERA_H
#define ESR_IO_CAMERA_H

struct esr_camera {
    float c2w[3][4]; /* camera-to-world rotation | centre, row-major */
    int width, height;
    float focal;     /* pixels: 0.5 * width / tan(0.5 * camera_angle_x) */
};

/* Focal length in pixels of a pinhole with full horizontal field of view camera_angle_x (radians). */
float esr_focal_from_fov(int width, float camera_angle_x);

/* Ray through continuous pixel position (px, py), px in [0,width) from the left, py in
 * [0,height) from the top; the centre of pixel (i, j) is (i + 0.5, j + 0.5).
 * dir is unit length. */
void esr_camera_ray(const struct esr_camera *cam, float px, float py, float origin[3], float dir[3]);

/* The ray of every pixel centre, row by row (pixel index = row * width + column): origins and
 * dirs hold width * height * 3 floats. The one place whole-view rays are made (training ray set,
 * view rendering). Parallel over pixels. */
void esr_camera_pixel_rays(const struct esr_camera *cam, float *origins, float *dirs);

/* Projects a world point to continuous pixel coordinates (inverse of esr_camera_ray, assuming the
 * rotation part of c2w is orthonormal); returns 0 when it is not in front of the camera. */
int esr_camera_project(const struct esr_camera *cam, const float world[3], float *px, float *py);

/* Camera k of n (out) on the level circle through first's centre around the vertical axis
 * through centre (first's height, size and focal kept), looking at centre with +Z up. ESR_ERR,
 * saying so, when first lies straight above or below centre (within 1e-4 of its distance): the
 * circle is a point and a view down the axis has no up. */
int esr_camera_orbit(const struct esr_camera *first, const float centre[3], int k, int n,
                     struct esr_camera *out);

#endif
