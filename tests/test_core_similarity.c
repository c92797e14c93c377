/* The pose-alignment maths: the Jacobi eigen-decomposition against matrices built from known
 * eigenvectors and eigenvalues (distinct and repeated), the similarity fit recovering known
 * transforms (general, coplanar, a half turn, with noise against the closed-form optimum's
 * property), its refusals, and the rotation angle at 0, small, general and 180 degrees. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "core/eigen_sym.h"
#include "core/error.h"
#include "core/similarity.h"

#define PI 3.14159265358979323846

/* A fixed pseudo-random sequence in [-1, 1) (no dependence on the library's RNG). */
static double next_uniform(uint64_t *state)
{
    *state = *state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*state >> 11) / (double)(1ull << 52) - 1.0;
}

static void axis_angle(const double axis[3], double deg, double r[3][3])
{
    double n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]), h = 0.5 * deg * PI / 180.0;
    double q[4] = {cos(h), sin(h) * axis[0] / n, sin(h) * axis[1] / n, sin(h) * axis[2] / n};
    esr_quaternion_to_rotation(q, r);
}

/* A 4x4 orthogonal matrix: a product of plane rotations by the given angles. */
static void orthogonal4(const double angles[6], double q[16])
{
    memset(q, 0, 16 * sizeof *q);
    for (int i = 0; i < 4; i++)
        q[5 * i] = 1.0;
    int k = 0;
    for (int p = 0; p < 4; p++)
        for (int r = p + 1; r < 4; r++, k++) {
            double c = cos(angles[k]), s = sin(angles[k]);
            for (int i = 0; i < 4; i++) {
                double a = q[4 * i + p], b = q[4 * i + r];
                q[4 * i + p] = c * a - s * b;
                q[4 * i + r] = s * a + c * b;
            }
        }
}

/* Checks A V = V diag(values), V orthonormal, values descending. */
static void assert_decomposes(int n, const double *a, const double *values, const double *v, double tol)
{
    for (int k = 1; k < n; k++)
        assert_true(values[k] <= values[k - 1]);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < n; k++) {
            double av = 0.0, dot = 0.0;
            for (int j = 0; j < n; j++) {
                av += a[i * n + j] * v[j * n + k];
                dot += v[j * n + i] * v[j * n + k];
            }
            assert_true(fabs(av - values[k] * v[i * n + k]) < tol);
            assert_true(fabs(dot - (i == k)) < tol);
        }
}

static void test_eigen_known_spectra(void **state)
{
    (void)state;
    static const double spectra[3][4] = {{3.0, -1.0, 0.5, 7.0}, {2.0, 2.0, -1.0, -1.0}, {1e-9, 0.0, 0.0, 5.0}};
    static const double angles[6] = {0.3, -1.1, 0.7, 2.0, -0.4, 0.9};
    double q[16];
    orthogonal4(angles, q);
    for (int s = 0; s < 3; s++) {
        double a[16] = {0.0}, values[4], v[16];
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++)
                for (int k = 0; k < 4; k++)
                    a[4 * i + j] += q[4 * i + k] * spectra[s][k] * q[4 * j + k];
        assert_int_equal(esr_eigen_sym(4, a, values, v), ESR_OK);
        double sorted[4];
        memcpy(sorted, spectra[s], sizeof sorted);
        for (int i = 0; i < 4; i++) /* descending */
            for (int j = i + 1; j < 4; j++)
                if (sorted[j] > sorted[i]) {
                    double t = sorted[i];
                    sorted[i] = sorted[j];
                    sorted[j] = t;
                }
        for (int k = 0; k < 4; k++)
            assert_true(fabs(values[k] - sorted[k]) < 1e-12);
        assert_decomposes(4, a, values, v, 1e-12);
    }
    /* a diagonal matrix, a 1x1, and a 3x3 with a repeated eigenvalue (identity + rank one) */
    const double d[9] = {1.0, 0.0, 0.0, 0.0, -2.0, 0.0, 0.0, 0.0, 4.0}, one = -3.5;
    const double rep[9] = {2.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 2.0}; /* eigenvalues 4, 1, 1 */
    double values[4], v[16];
    assert_int_equal(esr_eigen_sym(3, d, values, v), ESR_OK);
    assert_true(values[0] == 4.0 && values[1] == 1.0 && values[2] == -2.0);
    assert_decomposes(3, d, values, v, 1e-15);
    assert_int_equal(esr_eigen_sym(1, &one, values, v), ESR_OK);
    assert_true(values[0] == -3.5 && v[0] == 1.0);
    assert_int_equal(esr_eigen_sym(3, rep, values, v), ESR_OK);
    assert_true(fabs(values[0] - 4.0) < 1e-14 && fabs(values[1] - 1.0) < 1e-14 && fabs(values[2] - 1.0) < 1e-14);
    assert_decomposes(3, rep, values, v, 1e-14);
}

static void test_eigen_refusals(void **state)
{
    (void)state;
    double a[16] = {0.0}, values[4], v[16];
    esr_error_clear();
    assert_int_equal(esr_eigen_sym(5, a, values, v), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "5x5"));
    esr_error_clear();
    assert_int_equal(esr_eigen_sym(0, a, values, v), ESR_ERR);
    esr_error_clear();
    a[1] = NAN;
    assert_int_equal(esr_eigen_sym(2, a, values, v), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "not finite"));
    esr_error_clear();
}

/* The similarity x -> scale R x + t. */
static struct esr_similarity similarity(double scale, const double r[3][3], const double t[3])
{
    struct esr_similarity tr;
    tr.scale = scale;
    for (int a = 0; a < 3; a++) {
        tr.translation[a] = t[a];
        for (int b = 0; b < 3; b++)
            tr.rotation[a][b] = r[a][b];
    }
    return tr;
}

/* y_i = tr(x_i) (+ noise), n points from `state` (z squeezed by z_scale). */
static void make_pairs(uint64_t seed, int n, double z_scale, const struct esr_similarity *tr, double noise,
                       double *x, double *y)
{
    const double scale = tr->scale, (*r)[3] = tr->rotation, *t = tr->translation;
    uint64_t state = seed;
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++)
            x[3 * i + a] = 3.0 * next_uniform(&state) * (a == 2 ? z_scale : 1.0) + (a == 0 ? 10.0 : 0.0);
        for (int a = 0; a < 3; a++)
            y[3 * i + a] = scale * (r[a][0] * x[3 * i] + r[a][1] * x[3 * i + 1] + r[a][2] * x[3 * i + 2]) + t[a] +
                           noise * next_uniform(&state);
    }
}

static void assert_recovers(const struct esr_similarity *s, const struct esr_similarity *truth, double tol)
{
    const double scale = truth->scale, (*r)[3] = truth->rotation, *t = truth->translation;
    assert_true(fabs(s->scale - scale) < tol * scale);
    for (int a = 0; a < 3; a++) {
        assert_true(fabs(s->translation[a] - t[a]) < tol * 10.0);
        for (int b = 0; b < 3; b++)
            assert_true(fabs(s->rotation[a][b] - r[a][b]) < tol);
    }
}

static void test_similarity_recovers_known_transforms(void **state)
{
    (void)state;
    enum { N = 40 };
    double x[3 * N], y[3 * N];
    const double axes[4][3] = {{1, 2, 3}, {0, 0, 1}, {-1, 0.5, 0.2}, {0.3, -0.9, 0.1}};
    const double degrees[4] = {37.0, 180.0, 179.99, 0.0};
    const double scales[4] = {0.25, 4.0, 1.0, 13.5};
    const double t[3] = {-2.0, 5.0, 0.75};
    for (int c = 0; c < 4; c++) {
        double r[3][3];
        axis_angle(axes[c], degrees[c], r);
        const struct esr_similarity tr = similarity(scales[c], r, t);
        struct esr_similarity s;
        /* general points, then points on one plane (a ring of cameras) */
        for (int flat = 0; flat < 2; flat++) {
            make_pairs(7 + (uint64_t)c, N, flat ? 0.0 : 1.0, &tr, 0.0, x, y);
            assert_int_equal(esr_similarity_fit(x, y, N, &s), ESR_OK);
            assert_recovers(&s, &tr, 1e-10);
        }
        /* the minimum: 3 points */
        make_pairs(99, 3, 1.0, &tr, 0.0, x, y);
        assert_int_equal(esr_similarity_fit(x, y, 3, &s), ESR_OK);
        assert_recovers(&s, &tr, 1e-9);
    }
}

/* With noise the fit is the least-squares optimum: any small change of its parameters raises
 * the residual; and it lands close to the transform the data came from. */
static void test_similarity_noisy_is_optimal(void **state)
{
    (void)state;
    enum { N = 60 };
    double x[3 * N], y[3 * N], r[3][3];
    const double axis[3] = {0.2, 1.0, -0.4}, t[3] = {1.0, -1.0, 2.0};
    axis_angle(axis, 63.0, r);
    const struct esr_similarity tr = similarity(2.5, r, t);
    make_pairs(3, N, 1.0, &tr, 0.01, x, y);
    struct esr_similarity s;
    assert_int_equal(esr_similarity_fit(x, y, N, &s), ESR_OK);
    assert_recovers(&s, &tr, 2e-3);
    const double base = 0.0;
    double res0 = base;
    for (int i = 0; i < N; i++) {
        double p[3];
        esr_similarity_apply(&s, &x[3 * i], p);
        for (int a = 0; a < 3; a++)
            res0 += pow(p[a] - y[3 * i + a], 2);
    }
    for (int k = 0; k < 7; k++) { /* scale, three small rotations, three translations */
        for (int sign = -1; sign <= 1; sign += 2) {
            struct esr_similarity m = s;
            double h = 1e-4 * sign;
            if (k == 0) {
                m.scale *= 1.0 + h;
            } else if (k < 4) {
                double ax[3] = {k == 1, k == 2, k == 3}, dr[3][3];
                axis_angle(ax, h * 180.0 / PI, dr);
                for (int a = 0; a < 3; a++)
                    for (int b = 0; b < 3; b++)
                        m.rotation[a][b] = dr[a][0] * s.rotation[0][b] + dr[a][1] * s.rotation[1][b] +
                                           dr[a][2] * s.rotation[2][b];
            } else {
                m.translation[k - 4] += h;
            }
            double res = 0.0;
            for (int i = 0; i < N; i++) {
                double p[3];
                esr_similarity_apply(&m, &x[3 * i], p);
                for (int a = 0; a < 3; a++)
                    res += pow(p[a] - y[3 * i + a], 2);
            }
            assert_true(res > res0);
        }
    }
}

/* A mirrored copy has no rotation onto it: the fit still returns a proper rotation. */
static void test_similarity_reflection_gives_rotation(void **state)
{
    (void)state;
    enum { N = 20 };
    double x[3 * N], y[3 * N], id[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double t[3] = {0, 0, 0};
    const struct esr_similarity tr = similarity(1.0, id, t);
    make_pairs(11, N, 1.0, &tr, 0.0, x, y);
    for (int i = 0; i < N; i++)
        y[3 * i + 2] = -y[3 * i + 2];
    struct esr_similarity s;
    assert_int_equal(esr_similarity_fit(x, y, N, &s), ESR_OK);
    const double(*r)[3] = s.rotation;
    double det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
                 r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    assert_true(fabs(det - 1.0) < 1e-12);
}

static void test_similarity_refusals(void **state)
{
    (void)state;
    double x[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, y[12];
    memcpy(y, x, sizeof y);
    struct esr_similarity s;
    esr_error_clear();
    assert_int_equal(esr_similarity_fit(x, y, 2, &s), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "at least 3"));
    esr_error_clear();
    double same[9] = {1, 2, 3, 1, 2, 3, 1, 2, 3};
    assert_int_equal(esr_similarity_fit(same, y, 3, &s), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "coincide"));
    esr_error_clear();
    double line[12] = {0, 0, 0, 1, 1, 1, 2, 2, 2, -3, -3, -3};
    assert_int_equal(esr_similarity_fit(line, y, 4, &s), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "one line"));
    esr_error_clear();
    assert_int_equal(esr_similarity_fit(x, line, 4, &s), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "one line"));
    esr_error_clear();
    y[4] = INFINITY;
    assert_int_equal(esr_similarity_fit(x, y, 4, &s), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "not finite"));
    esr_error_clear();
}

static void test_rotation_angle(void **state)
{
    (void)state;
    const double axis[3] = {0.4, -0.2, 0.9}, degrees[6] = {0.0, 1e-7, 0.01, 42.0, 179.9999, 180.0};
    double base[3][3], turn[3][3], b[3][3];
    axis_angle((const double[3]){1.0, 1.0, 0.0}, 71.0, base);
    for (int k = 0; k < 6; k++) {
        axis_angle(axis, degrees[k], turn);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                b[i][j] = base[i][0] * turn[0][j] + base[i][1] * turn[1][j] + base[i][2] * turn[2][j];
        double got = esr_rotation_angle_deg(base, b);
        assert_true(fabs(got - degrees[k]) < 1e-9 * fmax(1.0, degrees[k]) + 1e-12);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_eigen_known_spectra),
        cmocka_unit_test(test_eigen_refusals),
        cmocka_unit_test(test_similarity_recovers_known_transforms),
        cmocka_unit_test(test_similarity_noisy_is_optimal),
        cmocka_unit_test(test_similarity_reflection_gives_rotation),
        cmocka_unit_test(test_similarity_refusals),
        cmocka_unit_test(test_rotation_angle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
