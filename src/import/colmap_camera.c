/* COLMAP's camera models and poses (see colmap_camera.h). */
#include "import/colmap_camera.h"

#include <math.h>
#include <string.h>

#include "core/error.h"
#include "core/similarity.h"

void esr_colmap_intrinsics_of(const struct esr_colmap_camera *cam, struct esr_colmap_intrinsics *k)
{
    const double *p = cam->params;
    memset(k, 0, sizeof *k);
    switch (cam->model) {
    case ESR_COLMAP_SIMPLE_PINHOLE:
    case ESR_COLMAP_SIMPLE_RADIAL:
    case ESR_COLMAP_RADIAL: /* f, cx, cy [, k1 [, k2]] */
        k->fx = k->fy = p[0];
        k->cx = p[1];
        k->cy = p[2];
        k->k1 = p[3];
        k->k2 = p[4];
        break;
    case ESR_COLMAP_PINHOLE:
    case ESR_COLMAP_OPENCV: /* fx, fy, cx, cy [, k1, k2, p1, p2] */
    default:
        k->fx = p[0];
        k->fy = p[1];
        k->cx = p[2];
        k->cy = p[3];
        k->k1 = p[4];
        k->k2 = p[5];
        k->p1 = p[6];
        k->p2 = p[7];
        break;
    }
}

void esr_colmap_to_pixel(const struct esr_colmap_intrinsics *k, double ud, double vd, double *px, double *py)
{
    *px = k->fx * ud + k->skew * vd + k->cx;
    *py = k->fy * vd + k->cy;
}

void esr_colmap_from_pixel(const struct esr_colmap_intrinsics *k, double px, double py, double *ud, double *vd)
{
    *vd = (py - k->cy) / k->fy;
    *ud = (px - k->cx - k->skew * *vd) / k->fx;
}

void esr_colmap_distort(const struct esr_colmap_intrinsics *k, double u, double v, double *ud, double *vd)
{
    double u2 = u * u, v2 = v * v, uv = u * v, r2 = u2 + v2;
    double radial = k->k1 * r2 + k->k2 * r2 * r2;
    *ud = u + u * radial + 2.0 * k->p1 * uv + k->p2 * (r2 + 2.0 * u2);
    *vd = v + v * radial + 2.0 * k->p2 * uv + k->p1 * (r2 + 2.0 * v2);
}

int esr_colmap_undistort(const struct esr_colmap_intrinsics *k, double ud, double vd, double *u, double *v)
{
    double x = ud, y = vd;
    for (int it = 0; it < 100; it++) {
        double fx, fy;
        esr_colmap_distort(k, x, y, &fx, &fy);
        double ex = fx - ud, ey = fy - vd;
        if (ex * ex + ey * ey < 1e-24)
            break;
        /* the distortion's Jacobian */
        double r2 = x * x + y * y, radial = k->k1 * r2 + k->k2 * r2 * r2;
        double dradial = 2.0 * (k->k1 + 2.0 * k->k2 * r2); /* d radial / d x = x dradial */
        double a = 1.0 + radial + x * x * dradial + 2.0 * k->p1 * y + 6.0 * k->p2 * x;
        double b = x * y * dradial + 2.0 * k->p1 * x + 2.0 * k->p2 * y;
        double d = 1.0 + radial + y * y * dradial + 2.0 * k->p2 * x + 6.0 * k->p1 * y;
        double det = a * d - b * b;
        if (!(fabs(det) > 1e-12))
            return ESR_ERR;
        x -= (d * ex - b * ey) / det;
        y -= (a * ey - b * ex) / det;
        if (!isfinite(x) || !isfinite(y))
            return ESR_ERR;
    }
    double fx, fy;
    esr_colmap_distort(k, x, y, &fx, &fy);
    if (!(hypot(fx - ud, fy - vd) < 1e-10))
        return ESR_ERR;
    *u = x;
    *v = y;
    return ESR_OK;
}

int esr_colmap_project(const struct esr_colmap_camera *cam, const struct esr_colmap_image *im,
                       const double world[3], double *px, double *py)
{
    double r[3][3], c[3];
    esr_quaternion_to_rotation(im->q, r);
    for (int i = 0; i < 3; i++)
        c[i] = r[i][0] * world[0] + r[i][1] * world[1] + r[i][2] * world[2] + im->t[i];
    if (!(c[2] > 0.0))
        return 0;
    struct esr_colmap_intrinsics k;
    esr_colmap_intrinsics_of(cam, &k);
    double ud, vd;
    esr_colmap_distort(&k, c[0] / c[2], c[1] / c[2], &ud, &vd);
    esr_colmap_to_pixel(&k, ud, vd, px, py);
    return 1;
}

void esr_colmap_camera_to_world(const struct esr_colmap_image *im, double c2w[3][4])
{
    static const double flip[3] = {1.0, -1.0, -1.0};
    double r[3][3];
    esr_quaternion_to_rotation(im->q, r);
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            c2w[row][col] = r[col][row] * flip[col]; /* R^T, columns = camera axes in the world */
        c2w[row][3] = -(r[0][row] * im->t[0] + r[1][row] * im->t[1] + r[2][row] * im->t[2]);
    }
}
