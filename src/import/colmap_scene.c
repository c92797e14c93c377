/* The imported scene's placement in esr's world (see colmap_scene.h). */
#include "import/colmap_scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/order.h"
#include "import/colmap_camera.h"

/* The q-quantile (0..1, nearest rank) of v[0..n-1], n > 0; v is sorted in place. */
static double quantile(double *v, long n, double q)
{
    esr_sort_doubles(v, (size_t)n);
    long i = (long)floor(q * (double)(n - 1) + 0.5);
    return v[i];
}

/* The q-quantile of the distances of n points (stride 3) from c. */
static int distance_quantile(const double *pts, long n, const double c[3], double q, double *out)
{
    double *d = malloc((size_t)n * sizeof *d);
    if (!d)
        return ESR_FAIL("out of memory placing the scene (%ld points)", n);
    for (long i = 0; i < n; i++)
        d[i] = sqrt(pow(pts[3 * i] - c[0], 2) + pow(pts[3 * i + 1] - c[1], 2) + pow(pts[3 * i + 2] - c[2], 2));
    *out = quantile(d, n, q);
    free(d);
    return ESR_OK;
}

/* Per-axis median of n points (stride 3). */
static int median_point(const double *pts, long n, double centre[3])
{
    double *v = malloc((size_t)n * sizeof *v);
    if (!v)
        return ESR_FAIL("out of memory placing the scene (%ld points)", n);
    for (int a = 0; a < 3; a++) {
        for (long i = 0; i < n; i++)
            v[i] = pts[3 * i + a];
        centre[a] = quantile(v, n, 0.5);
    }
    free(v);
    return ESR_OK;
}

/* Rotation taking the unit vector a onto +Z (Rodrigues about a x z); identity when a is +Z,
 * a half turn about X when a is -Z. */
static void rotation_to_z(const double a[3], double r[3][3])
{
    double c = a[2], axis[3] = {a[1], -a[0], 0.0}; /* a x (0, 0, 1) */
    double s = sqrt(axis[0] * axis[0] + axis[1] * axis[1]);
    memset(r, 0, 9 * sizeof(double));
    if (s < 1e-12) {
        r[0][0] = 1.0;
        r[1][1] = r[2][2] = c > 0.0 ? 1.0 : -1.0;
        return;
    }
    double k[3] = {axis[0] / s, axis[1] / s, 0.0}, t = 1.0 - c;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = t * k[i] * k[j] + (i == j ? c : 0.0);
    r[0][1] -= s * k[2];
    r[1][0] += s * k[2];
    r[0][2] += s * k[1];
    r[2][0] -= s * k[1];
    r[1][2] -= s * k[0];
    r[2][1] += s * k[0];
}

/* Mean image-up direction of the cameras (the c2w matrices' second column) when they agree on
 * it; +Z (no rotation) otherwise. */
static void mean_up(const double (*c2w)[3][4], int n, double up[3])
{
    double sum[3] = {0.0, 0.0, 0.0};
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            sum[a] += c2w[i][a][1];
    double len = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
    int agree = len > 0.3 * n;
    for (int a = 0; a < 3; a++)
        up[a] = agree ? sum[a] / len : (a == 2);
}

int esr_scene_frame_place(const double (*c2w)[3][4], int n, struct esr_scene_frame *f)
{
    if (n < 1)
        return ESR_FAIL("no cameras to place the scene by");
    if (!(f->radius > 0.0) || !isfinite(f->radius))
        return ESR_FAIL("the scene's points and cameras all coincide; cannot scale the scene");
    double *dist = malloc((size_t)n * sizeof *dist);
    if (!dist)
        return ESR_FAIL("out of memory placing the scene");
    for (int i = 0; i < n; i++)
        dist[i] = sqrt(pow(c2w[i][0][3] - f->centre[0], 2) + pow(c2w[i][1][3] - f->centre[1], 2) +
                       pow(c2w[i][2][3] - f->centre[2], 2));
    double cam_dist = quantile(dist, n, 0.5);
    free(dist);
    f->scale = 1.0 / f->radius;
    if (cam_dist > 0.0 && 4.0 / cam_dist < f->scale)
        f->scale = 4.0 / cam_dist;
    /* cameras so far out that their distance overflows would put every camera at the centre */
    if (!(f->scale > 0.0) || !isfinite(f->scale))
        return ESR_FAIL("the cameras' median distance from the scene's centre (%g) and its radius (%g) give no "
                        "usable scale", cam_dist, f->radius);
    double up[3];
    mean_up(c2w, n, up);
    rotation_to_z(up, f->rotation);
    return ESR_OK;
}

int esr_colmap_scene_frame(const struct esr_colmap_model *m, struct esr_scene_frame *f)
{
    if (m->n_images < 1)
        return ESR_FAIL("the COLMAP model has no registered images to place the scene by");
    double (*c2w)[3][4] = malloc((size_t)m->n_images * sizeof *c2w);
    double *centres = malloc((size_t)m->n_images * 3 * sizeof *centres);
    if (!c2w || !centres) {
        free(c2w);
        free(centres);
        return ESR_FAIL("out of memory placing the scene");
    }
    for (int i = 0; i < m->n_images; i++) {
        esr_colmap_camera_to_world(&m->images[i], c2w[i]);
        for (int a = 0; a < 3; a++)
            centres[3 * i + a] = c2w[i][a][3];
    }
    /* the bulk of the points, or without them the camera centres at 4 units, as in esr's datasets */
    f->from_points = m->n_points >= 10;
    const double *pts = f->from_points ? m->points : centres;
    const long n = f->from_points ? m->n_points : m->n_images;
    int status = median_point(pts, n, f->centre);
    if (status == ESR_OK)
        status = distance_quantile(pts, n, f->centre, f->from_points ? 0.9 : 0.5, &f->radius);
    if (status == ESR_OK && !f->from_points)
        f->radius *= 0.25;
    if (status == ESR_OK)
        status = esr_scene_frame_place((const double (*)[3][4])c2w, m->n_images, f);
    free(c2w);
    free(centres);
    return status;
}
void esr_scene_frame_apply(const struct esr_scene_frame *f, const double c2w[3][4], double out[3][4])
{
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            out[r][c] = f->rotation[r][0] * c2w[0][c] + f->rotation[r][1] * c2w[1][c] + f->rotation[r][2] * c2w[2][c];
        out[r][3] = f->scale * (f->rotation[r][0] * (c2w[0][3] - f->centre[0]) +
                                f->rotation[r][1] * (c2w[1][3] - f->centre[1]) +
                                f->rotation[r][2] * (c2w[2][3] - f->centre[2]));
    }
}
