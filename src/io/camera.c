#include "io/camera.h"

#include <math.h>

#include "core/error.h"
#include "core/vec3.h"

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

int esr_camera_orbit(const struct esr_camera *first, const float centre[3], int k, int n,
                     struct esr_camera *out)
{
    const struct esr_vec3 c = esr_v3(centre[0], centre[1], centre[2]);
    const struct esr_vec3 at = esr_v3(first->c2w[0][3], first->c2w[1][3], first->c2w[2][3]);
    const float dx = at.x - c.x, dy = at.y - c.y, radius = sqrtf(dx * dx + dy * dy);
    if (!(radius > 1e-4f * esr_v3_length(esr_v3_sub(at, c))))
        return ESR_FAIL("the orbit's first camera (%g, %g, %g) is straight above or below the "
                        "scene's centre (%g, %g, %g): its circle around the vertical axis is a "
                        "point; render dataset views with --views instead",
                        (double)at.x, (double)at.y, (double)at.z, (double)c.x, (double)c.y,
                        (double)c.z);
    const float phi = atan2f(dy, dx) + 6.2831853f * (float)k / (float)n;
    const struct esr_vec3 pos = esr_v3(c.x + radius * cosf(phi), c.y + radius * sinf(phi), at.z);
    const struct esr_vec3 f = esr_v3_normalize(esr_v3_sub(c, pos));
    const struct esr_vec3 r = esr_v3_normalize(esr_v3_cross(f, esr_v3(0.0f, 0.0f, 1.0f)));
    const struct esr_vec3 u = esr_v3_cross(r, f);
    const float cols[4][3] = {{r.x, r.y, r.z}, {u.x, u.y, u.z}, {-f.x, -f.y, -f.z}, {pos.x, pos.y, pos.z}};
    *out = *first;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            out->c2w[i][j] = cols[j][i];
    return ESR_OK;
}
