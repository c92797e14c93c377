/* Cyclic Jacobi eigen-decomposition of a small symmetric matrix (see eigen_sym.h). */
#include "core/eigen_sym.h"

#include <math.h>
#include <string.h>

#include "core/error.h"

#define MAX_SWEEPS 64

/* Sum of squares of the off-diagonal entries, the quantity each rotation reduces. */
static double off_diagonal(int n, const double m[ESR_EIGEN_SYM_MAX][ESR_EIGEN_SYM_MAX])
{
    double s = 0.0;
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++)
            s += m[i][j] * m[i][j];
    return s;
}

/* One rotation in the (p, q) plane that zeroes m[p][q] (Golub & Van Loan, Algorithm 8.4.1:
 * the smaller root of t^2 + 2 theta t - 1 = 0 keeps the rotation angle under pi/4, which is what
 * makes the sweeps converge); v accumulates the rotations. */
static void rotate(int n, double m[ESR_EIGEN_SYM_MAX][ESR_EIGEN_SYM_MAX], double v[ESR_EIGEN_SYM_MAX][ESR_EIGEN_SYM_MAX],
                   int p, int q)
{
    if (m[p][q] == 0.0)
        return;
    double theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
    double t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
    double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
    for (int k = 0; k < n; k++) { /* m = m J */
        double mkp = m[k][p], mkq = m[k][q];
        m[k][p] = c * mkp - s * mkq;
        m[k][q] = s * mkp + c * mkq;
    }
    for (int k = 0; k < n; k++) { /* m = J^T m */
        double mpk = m[p][k], mqk = m[q][k];
        m[p][k] = c * mpk - s * mqk;
        m[q][k] = s * mpk + c * mqk;
    }
    m[p][q] = m[q][p] = 0.0; /* exact by construction; rounding would leave ~1e-17 */
    for (int k = 0; k < n; k++) {
        double vkp = v[k][p], vkq = v[k][q];
        v[k][p] = c * vkp - s * vkq;
        v[k][q] = s * vkp + c * vkq;
    }
}

int esr_eigen_sym(int n, const double *a, double *values, double *vectors)
{
    if (n < 1 || n > ESR_EIGEN_SYM_MAX)
        return ESR_FAIL("eigen-decomposition of a %dx%d matrix: only 1..%d are supported", n, n, ESR_EIGEN_SYM_MAX);
    double m[ESR_EIGEN_SYM_MAX][ESR_EIGEN_SYM_MAX], v[ESR_EIGEN_SYM_MAX][ESR_EIGEN_SYM_MAX];
    double total = 0.0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double x = a[(i <= j ? i : j) * n + (i <= j ? j : i)]; /* upper triangle, mirrored */
            if (!isfinite(x))
                return ESR_FAIL("eigen-decomposition: entry (%d, %d) is not finite", i, j);
            m[i][j] = x;
            v[i][j] = i == j;
            total += x * x;
        }
    int sweep = 0;
    /* stop when the off-diagonal part is at rounding level of the whole matrix */
    while (off_diagonal(n, m) > 1e-30 * total && sweep < MAX_SWEEPS) {
        for (int p = 0; p < n; p++)
            for (int q = p + 1; q < n; q++)
                rotate(n, m, v, p, q);
        sweep++;
    }
    if (sweep == MAX_SWEEPS)
        return ESR_FAIL("eigen-decomposition did not converge in %d sweeps", MAX_SWEEPS);
    int order[ESR_EIGEN_SYM_MAX];
    for (int i = 0; i < n; i++)
        order[i] = i;
    for (int i = 1; i < n; i++) /* insertion sort, descending */
        for (int j = i; j > 0 && m[order[j]][order[j]] > m[order[j - 1]][order[j - 1]]; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    for (int k = 0; k < n; k++) {
        values[k] = m[order[k]][order[k]];
        for (int i = 0; i < n; i++)
            vectors[i * n + k] = v[i][order[k]];
    }
    return ESR_OK;
}
