#include "io/camera.h"

#include <math.h>

float esr_focal_from_fov(int width, float camera_angle_x)
{
    return 0.5f * (float)width / tanf(0.5f * camera_angle_x);
}

void esr_camera_ray(const struct esr_camera *cam, float px, float py, float origin[3], float dir[3])
{
    float d_cam[3] = {(px - 0.5f * (float)cam->width) / cam->focal, -(py - 0.5f * (float)cam->height) / cam->focal,
                      -1.0f};
    float norm = 0.0f;
    for (int r = 0; r < 3; r++) {
        dir[r] = cam->c2w[r][0] * d_cam[0] + cam->c2w[r][1] * d_cam[1] + cam->c2w[r][2] * d_cam[2];
        norm += dir[r] * dir[r];
        origin[r] = cam->c2w[r][3];
    }
    norm = 1.0f / sqrtf(norm);
    for (int r = 0; r < 3; r++)
        dir[r] *= norm;
}

void esr_camera_pixel_rays(const struct esr_camera *cam, float *origins, float *dirs)
{
    long long n = (long long)cam->width * cam->height;
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < n; i++) {
        float px = (float)(i % cam->width) + 0.5f, py = (float)(i / cam->width) + 0.5f;
        esr_camera_ray(cam, px, py, origins + 3 * i, dirs + 3 * i);
    }
}

int esr_camera_project(const struct esr_camera *cam, const float world[3], float *px, float *py)
{
    /* Camera coordinates: R^T (world - centre); R is a rotation so its transpose inverts it. */
    float rel[3], p[3];
    for (int r = 0; r < 3; r++)
        rel[r] = world[r] - cam->c2w[r][3];
    for (int c = 0; c < 3; c++)
        p[c] = cam->c2w[0][c] * rel[0] + cam->c2w[1][c] * rel[1] + cam->c2w[2][c] * rel[2];
    if (p[2] >= 0.0f)
        return 0; /* the camera looks along -Z */
    *px = 0.5f * (float)cam->width + cam->focal * p[0] / -p[2];
    *py = 0.5f * (float)cam->height - cam->focal * p[1] / -p[2];
    return 1;
}
