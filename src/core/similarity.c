/* Least-squares similarity between point sets (see similarity.h). */
#include "core/similarity.h"

#include <math.h>
#include <string.h>

#include "core/eigen_sym.h"
#include "core/error.h"

#define PI 3.14159265358979323846

static void centroid(const double *p, int n, double c[3])
{
    c[0] = c[1] = c[2] = 0.0;
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            c[a] += p[3 * i + a];
    for (int a = 0; a < 3; a++)
        c[a] /= n;
}

/* 1 when the centred points (stride 3) span at most a line: the second eigenvalue of their
 * scatter matrix is at rounding level of the first. */
static int collinear(const double *p, const double c[3], int n, int *status)
{
    double s[9] = {0.0}, values[3], vectors[9];
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                s[3 * a + b] += (p[3 * i + a] - c[a]) * (p[3 * i + b] - c[b]);
    *status = esr_eigen_sym(3, s, values, vectors);
    return *status == ESR_OK && values[1] <= 1e-12 * values[0];
}

/* Horn's 4x4 matrix N for the cross-covariance S[a][b] = sum x'_a y'_b: the unit quaternion
 * maximising q^T N q rotates the x points onto the y points. */
static void horn_matrix(const double s[3][3], double nm[16])
{
    const double xx = s[0][0], xy = s[0][1], xz = s[0][2], yx = s[1][0], yy = s[1][1], yz = s[1][2], zx = s[2][0],
                 zy = s[2][1], zz = s[2][2];
    const double rows[4][4] = {
        {xx + yy + zz, yz - zy, zx - xz, xy - yx},
        {yz - zy, xx - yy - zz, xy + yx, zx + xz},
        {zx - xz, xy + yx, -xx + yy - zz, yz + zy},
        {xy - yx, zx + xz, yz + zy, -xx - yy + zz},
    };
    memcpy(nm, rows, sizeof rows);
}

void esr_quaternion_to_rotation(const double q_in[4], double r[3][3])
{
    double len = sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
    double w = q_in[0] / len, x = q_in[1] / len, y = q_in[2] / len, z = q_in[3] / len;
    r[0][0] = 1 - 2 * (y * y + z * z);
    r[0][1] = 2 * (x * y - w * z);
    r[0][2] = 2 * (x * z + w * y);
    r[1][0] = 2 * (x * y + w * z);
    r[1][1] = 1 - 2 * (x * x + z * z);
    r[1][2] = 2 * (y * z - w * x);
    r[2][0] = 2 * (x * z - w * y);
    r[2][1] = 2 * (y * z + w * x);
    r[2][2] = 1 - 2 * (x * x + y * y);
}

int esr_similarity_fit(const double *x, const double *y, int n, struct esr_similarity *out)
{
    if (n < 3)
        return ESR_FAIL("a similarity needs at least 3 point pairs, got %d", n);
    for (int i = 0; i < 3 * n; i++)
        if (!isfinite(x[i]) || !isfinite(y[i]))
            return ESR_FAIL("point pair %d is not finite", i / 3);
    double cx[3], cy[3], s[3][3] = {{0.0}}, var_x = 0.0;
    centroid(x, n, cx);
    centroid(y, n, cy);
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            var_x += (x[3 * i + a] - cx[a]) * (x[3 * i + a] - cx[a]);
            for (int b = 0; b < 3; b++)
                s[a][b] += (x[3 * i + a] - cx[a]) * (y[3 * i + b] - cy[b]);
        }
    if (!(var_x > 0.0))
        return ESR_FAIL("the %d source points coincide; no similarity is determined", n);
    int status;
    if (collinear(x, cx, n, &status) || (status == ESR_OK && collinear(y, cy, n, &status)))
        return ESR_FAIL("the %d points lie on one line; the rotation about it is not determined", n);
    ESR_TRY(status);
    double nm[16], values[4], vectors[16];
    horn_matrix(s, nm);
    ESR_TRY(esr_eigen_sym(4, nm, values, vectors));
    double q[4] = {vectors[0], vectors[4], vectors[8], vectors[12]}; /* column 0: the largest */
    esr_quaternion_to_rotation(q, out->rotation);
    /* Umeyama's scale for this rotation: sum y' . R x' / sum |x'|^2 */
    double dot = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            dot += out->rotation[b][a] * s[a][b];
    out->scale = dot / var_x;
    if (!(out->scale > 0.0)) /* the top eigenvalue is >= 0 (N is traceless); 0 means no shared shape */
        return ESR_FAIL("the %d point pairs have no correlated spread; no similarity is determined", n);
    for (int a = 0; a < 3; a++)
        out->translation[a] = cy[a] - out->scale * (out->rotation[a][0] * cx[0] + out->rotation[a][1] * cx[1] +
                                                    out->rotation[a][2] * cx[2]);
    return ESR_OK;
}

void esr_similarity_apply(const struct esr_similarity *s, const double x[3], double y[3])
{
    for (int a = 0; a < 3; a++)
        y[a] = s->scale * (s->rotation[a][0] * x[0] + s->rotation[a][1] * x[1] + s->rotation[a][2] * x[2]) +
               s->translation[a];
}

double esr_rotation_angle_deg(const double a[3][3], const double b[3][3])
{
    double r[3][3]; /* a^T b */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
    /* sin from the antisymmetric part, cos from the trace: atan2 keeps full precision at both ends,
     * where acos of the trace alone loses half the digits near 0 */
    double w[3] = {r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]};
    double sin2 = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]), cos2 = r[0][0] + r[1][1] + r[2][2] - 1.0;
    return atan2(sin2, cos2) * 180.0 / PI;
}
