/* RQ decomposition of a projection matrix's left 3x3 by Gram-Schmidt from its last row (see
 * projection.h): M's rows are m3 = k22 r3, m2 = k11 r2 + k12 r3, m1 = k00 r1 + k01 r2 + k02 r3. */
#include "import/projection.h"

#include <math.h>
#include <string.h>

#include "core/error.h"

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double det3(const double m[3][3])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* Row `row` of M made orthogonal to the rows of r below it, its components along them added to
 * k; twice, so the rounding of the first pass is removed too. Returns the remaining length. */
static double orthogonalise(const double m[3][3], int row, double k[3][3], double r[3][3])
{
    double w[3] = {m[row][0], m[row][1], m[row][2]};
    for (int pass = 0; pass < 2; pass++)
        for (int j = row + 1; j < 3; j++) {
            double c = dot3(w, r[j]);
            k[row][j] += c;
            for (int a = 0; a < 3; a++)
                w[a] -= c * r[j][a];
        }
    double len = sqrt(dot3(w, w));
    for (int a = 0; a < 3; a++)
        r[row][a] = w[a] / len;
    return len;
}

int esr_projection_decompose(const double p[3][4], const char *what, struct esr_projection_parts *out)
{
    double m[3][3], p4[3], scale = 0.0;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            m[i][j] = p[i][j];
            scale = fmax(scale, fabs(m[i][j]));
        }
        p4[i] = p[i][3];
    }
    const double det = det3(m);
    if (!isfinite(det) || !isfinite(p4[0] + p4[1] + p4[2]) || !(fabs(det) > 1e-12 * scale * scale * scale))
        return ESR_FAIL("%s: the projection matrix is singular or not finite (det %g)", what, det);
    const double sign = det < 0.0 ? -1.0 : 1.0; /* -P projects the same: take the one with det M > 0 */
    for (int i = 0; i < 3; i++) {
        p4[i] *= sign;
        for (int j = 0; j < 3; j++)
            m[i][j] *= sign;
    }
    double k[3][3], r[3][3];
    memset(k, 0, sizeof k);
    for (int row = 2; row >= 0; row--)
        k[row][row] = orthogonalise(m, row, k, r);
    /* C = -M^-1 p4 = -R^T K^-1 p4, K^-1 p4 by back-substitution */
    double y[3];
    for (int i = 2; i >= 0; i--) {
        double s = p4[i];
        for (int j = i + 1; j < 3; j++)
            s -= k[i][j] * y[j];
        y[i] = s / k[i][i];
    }
    for (int a = 0; a < 3; a++)
        out->centre[a] = -(r[0][a] * y[0] + r[1][a] * y[1] + r[2][a] * y[2]);
    const double k22 = k[2][2];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            out->k[i][j] = k[i][j] / k22;
            out->r[i][j] = r[i][j];
        }
    return ESR_OK;
}
