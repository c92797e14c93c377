/* Ridge least squares with s >= 0 (core/ridge_solve.h) against an independent solution: every
 * subset of the unknowns solved free with the others at 0 (Gauss-Jordan here), the feasible
 * solution of least objective kept; and its robust form on rows with outliers. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>

#include "core/rng.h"
#include "core/ridge_solve.h"

#define KMAX 6

/* The ridge-augmented problem: H = G + L, b = r + L 1, L = diag(ridge G_ii + 1e-12). */
static void augment(int K, const double *G, const double *r, double ridge, double *H, double *b)
{
    for (int i = 0; i < K; i++) {
        const double lam = ridge * G[i * K + i] + 1e-12;
        for (int j = 0; j < K; j++)
            H[i * K + j] = G[i * K + j] + (i == j ? lam : 0.0);
        b[i] = r[i] + lam;
    }
}

static double objective(int K, const double *H, const double *b, const double *s)
{
    double f = 0.0;
    for (int i = 0; i < K; i++) {
        f -= b[i] * s[i];
        for (int j = 0; j < K; j++)
            f += 0.5 * s[i] * H[i * K + j] * s[j];
    }
    return f;
}

/* Gauss-Jordan on the unknowns in mask; returns 0 when singular. */
static int solve_free(int K, const double *H, const double *b, unsigned mask, double *s)
{
    int idx[KMAX], k = 0;
    for (int i = 0; i < K; i++) {
        s[i] = 0.0;
        if (mask >> i & 1)
            idx[k++] = i;
    }
    double a[KMAX][KMAX + 1];
    for (int i = 0; i < k; i++) {
        for (int j = 0; j < k; j++)
            a[i][j] = H[idx[i] * K + idx[j]];
        a[i][k] = b[idx[i]];
    }
    for (int c = 0; c < k; c++) {
        int p = c;
        for (int i = c + 1; i < k; i++)
            if (fabs(a[i][c]) > fabs(a[p][c]))
                p = i;
        if (fabs(a[p][c]) < 1e-300)
            return 0;
        for (int j = 0; j <= k; j++) {
            const double t = a[c][j];
            a[c][j] = a[p][j];
            a[p][j] = t;
        }
        for (int i = 0; i < k; i++) {
            if (i == c)
                continue;
            const double f = a[i][c] / a[c][c];
            for (int j = c; j <= k; j++)
                a[i][j] -= f * a[c][j];
        }
    }
    for (int i = 0; i < k; i++)
        s[idx[i]] = a[i][k] / a[i][i];
    return 1;
}

static void brute_force(int K, const double *G, const double *r, double ridge, double *best)
{
    double H[KMAX * KMAX], b[KMAX], s[KMAX], f_best = INFINITY;
    augment(K, G, r, ridge, H, b);
    for (unsigned mask = 0; mask < 1u << K; mask++) {
        if (!solve_free(K, H, b, mask, s))
            continue;
        int ok = 1;
        for (int i = 0; i < K; i++)
            ok &= s[i] >= 0.0;
        const double f = objective(K, H, b, s);
        if (ok && f < f_best) {
            f_best = f;
            for (int i = 0; i < K; i++)
                best[i] = s[i];
        }
    }
}

/* Normal equations of n random rows A (n x K, entries >= 0 like light contributions) against
 * y = A t + noise, t with some entries negative or 0 so the bound is active. */
static void random_problem(struct esr_rng *rng, int K, double *G, double *r)
{
    enum { N = 12 };
    double A[N][KMAX], y[N], t[KMAX];
    for (int k = 0; k < K; k++)
        t[k] = 4.0 * esr_rng_float(rng) - 1.5;
    for (int i = 0; i < N; i++) {
        y[i] = 0.0;
        for (int k = 0; k < K; k++) {
            A[i][k] = esr_rng_float(rng);
            y[i] += A[i][k] * t[k];
        }
        y[i] += 0.3 * (esr_rng_float(rng) - 0.5);
    }
    for (int a = 0; a < K; a++) {
        r[a] = 0.0;
        for (int i = 0; i < N; i++)
            r[a] += A[i][a] * y[i];
        for (int e = 0; e < K; e++) {
            G[a * K + e] = 0.0;
            for (int i = 0; i < N; i++)
                G[a * K + e] += A[i][a] * A[i][e];
        }
    }
}

static void test_matches_the_best_feasible_subset(void **state)
{
    (void)state;
    struct esr_rng rng = esr_rng_init(77, 3);
    int active_bounds = 0;
    for (int trial = 0; trial < 400; trial++) {
        const int K = 1 + trial % KMAX;
        const double ridge = trial % 2 ? 1e-3 : 0.0;
        double G[KMAX * KMAX], r[KMAX], s[KMAX], want[KMAX];
        random_problem(&rng, K, G, r);
        esr_ridge_solve_nonneg(K, G, r, ridge, s);
        brute_force(K, G, r, ridge, want);
        for (int k = 0; k < K; k++) {
            assert_true(s[k] >= 0.0);
            assert_true(fabs(s[k] - want[k]) < 1e-7 * (1.0 + fabs(want[k])));
            active_bounds += want[k] == 0.0;
        }
    }
    /* the cases exercise the bound, not only free solutions */
    print_message("unknowns at the bound: %d\n", active_bounds);
    assert_true(active_bounds > 100);
}

/* The case clamping gets wrong: y is light 0's alone, light 1 is nearly collinear with it and
 * would come out negative; light 0 must then get all of y, y.a0 / a0.a0. */
static void test_negative_unknown_leaves_the_others_the_whole_fit(void **state)
{
    (void)state;
    const double a0[4] = {1, 1, 1, 1}, a1[4] = {1, 0.9, 0, 0}, y[4] = {1, 0.8, 1.2, 1.2};
    double G[4] = {0}, r[2] = {0}, s[2];
    for (int i = 0; i < 4; i++) {
        G[0] += a0[i] * a0[i], G[1] += a0[i] * a1[i], G[3] += a1[i] * a1[i];
        r[0] += a0[i] * y[i], r[1] += a1[i] * y[i];
    }
    G[2] = G[1];
    const double det = G[0] * G[3] - G[1] * G[2];
    assert_true((G[0] * r[1] - G[2] * r[0]) / det < 0.0); /* the free solution's s1 */
    esr_ridge_solve_nonneg(2, G, r, 0.0, s);
    assert_true(s[1] == 0.0);
    assert_true(fabs(s[0] - r[0] / G[0]) < 1e-9);
}

/* An unknown with no data (a light no point sees) stays at the ridge's prior, 1. */
static void test_unseen_unknown_keeps_the_prior(void **state)
{
    (void)state;
    const double G[4] = {2, 0, 0, 0}, r[2] = {6, 0};
    double s[2];
    esr_ridge_solve_nonneg(2, G, r, 1e-3, s);
    assert_true(fabs(s[1] - 1.0) < 1e-9);
    assert_true(fabs(s[0] - (6.0 + 2e-3) / (2.0 + 2e-3)) < 1e-9);
}

/* n rows of K unknowns, a uniform in [0, 1), y = a . truth + noise in [-0.02, 0.02); every
 * 20th row (5%) also gets an outlier of +5 to +10. */
#define ROWS 400
static void rows_with_outliers(int K, const double *truth, double *a, double *y)
{
    struct esr_rng rng = esr_rng_init(5, 11);
    for (int p = 0; p < ROWS; p++) {
        y[p] = 0.04 * (double)esr_rng_float(&rng) - 0.02;
        for (int i = 0; i < K; i++) {
            a[p * K + i] = (double)esr_rng_float(&rng);
            y[p] += a[p * K + i] * truth[i];
        }
        if (p % 20 == 0)
            y[p] += 5.0 + 5.0 * (double)esr_rng_float(&rng);
    }
}

/* rounds 0 is the plain fit: the same as solving the rows' normal equations. */
static void test_robust_fit_without_rounds_is_the_plain_fit(void **state)
{
    (void)state;
    const int K = 3;
    const double truth[3] = {2.0, 0.5, 3.0};
    double a[ROWS * 3], y[ROWS], G[9] = {0}, r[3] = {0}, want[3], s[3];
    rows_with_outliers(K, truth, a, y);
    for (int p = 0; p < ROWS; p++)
        for (int i = 0; i < K; i++) {
            r[i] += a[p * K + i] * y[p];
            for (int j = 0; j < K; j++)
                G[i * K + j] += a[p * K + i] * a[p * K + j];
        }
    esr_ridge_solve_nonneg(K, G, r, 1e-3, want);
    assert_int_equal(esr_ridge_fit_robust(K, ROWS, a, y, 1e-3, 0, s), 0);
    for (int i = 0; i < K; i++)
        assert_true(fabs(s[i] - want[i]) < 1e-9 * (1.0 + fabs(want[i])));
}

/* 5% gross outliers pull the plain fit off by more than 10% somewhere; the reweighted fit lands
 * within 2% of the truth everywhere. */
static void test_robust_fit_resists_outliers(void **state)
{
    (void)state;
    const int K = 3;
    const double truth[3] = {2.0, 0.5, 3.0};
    double a[ROWS * 3], y[ROWS], plain[3], robust[3], worst_plain = 0.0;
    rows_with_outliers(K, truth, a, y);
    assert_int_equal(esr_ridge_fit_robust(K, ROWS, a, y, 1e-3, 0, plain), 0);
    assert_int_equal(esr_ridge_fit_robust(K, ROWS, a, y, 1e-3, 8, robust), 0);
    for (int i = 0; i < K; i++) {
        worst_plain = fmax(worst_plain, fabs(plain[i] - truth[i]) / truth[i]);
        print_message("unknown %d: truth %.3f plain %.3f robust %.3f\n", i, truth[i], plain[i],
                      robust[i]);
        assert_true(fabs(robust[i] - truth[i]) < 0.02 * truth[i]);
    }
    assert_true(worst_plain > 0.10);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_the_best_feasible_subset),
        cmocka_unit_test(test_negative_unknown_leaves_the_others_the_whole_fit),
        cmocka_unit_test(test_unseen_unknown_keeps_the_prior),
        cmocka_unit_test(test_robust_fit_without_rounds_is_the_plain_fit),
        cmocka_unit_test(test_robust_fit_resists_outliers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
