/* Small dense ridge least squares with s >= 0 (see ridge_solve.h). */
#include "core/ridge_solve.h"

#include <math.h>
#include <stdlib.h>

#include "core/order.h"

/* Solves G s = r by Gaussian elimination with partial pivoting; G and r are overwritten. */
static void solve_dense(int K, double *G, double *r, double *s)
{
    for (int c = 0; c < K; c++) {
        int piv = c;
        for (int i = c + 1; i < K; i++)
            if (fabs(G[i * K + c]) > fabs(G[piv * K + c]))
                piv = i;
        for (int j = 0; j < K; j++) {
            double t = G[c * K + j];
            G[c * K + j] = G[piv * K + j];
            G[piv * K + j] = t;
        }
        double t = r[c];
        r[c] = r[piv];
        r[piv] = t;
        for (int i = c + 1; i < K; i++) {
            const double f = G[i * K + c] / G[c * K + c];
            for (int j = c; j < K; j++)
                G[i * K + j] -= f * G[c * K + j];
            r[i] -= f * r[c];
        }
    }
    for (int i = K - 1; i >= 0; i--) {
        double v = r[i];
        for (int j = i + 1; j < K; j++)
            v -= G[i * K + j] * s[j];
        s[i] = v / G[i * K + i];
    }
}

/* x = the solution of H restricted to the unknowns in P (map[0..k)), b likewise. */
static void solve_subset(int K, const double *H, const double *b, const int *map, int k, double *x)
{
    double Gs[ESR_RIDGE_MAX * ESR_RIDGE_MAX], rs[ESR_RIDGE_MAX];
    for (int a = 0; a < k; a++) {
        rs[a] = b[map[a]];
        for (int e = 0; e < k; e++)
            Gs[a * k + e] = H[map[a] * K + map[e]];
    }
    solve_dense(k, Gs, rs, x);
}

/* Lawson and Hanson's active-set method on the ridge-augmented problem, minimise
 * 1/2 s'Hs - b's over s >= 0 with H = G + L, b = r + L 1 (H positive definite). */
void esr_ridge_solve_nonneg(int K, const double *G, const double *r, double ridge, double *s)
{
    double H[ESR_RIDGE_MAX * ESR_RIDGE_MAX], b[ESR_RIDGE_MAX];
    for (int i = 0; i < K; i++) {
        const double lam = ridge * G[i * K + i] + 1e-12;
        for (int j = 0; j < K; j++)
            H[i * K + j] = G[i * K + j] + (i == j ? lam : 0.0);
        b[i] = r[i] + lam;
        s[i] = 0.0;
    }
    int free_set[ESR_RIDGE_MAX] = {0};
    for (int outer = 0; outer < 4 * K + 4; outer++) {
        int best = -1;
        double best_w = 0.0;
        for (int j = 0; j < K; j++) {
            if (free_set[j])
                continue;
            double w = b[j]; /* the negative gradient, against rounding relative to b_j */
            for (int e = 0; e < K; e++)
                w -= H[j * K + e] * s[e];
            if (w > 1e-9 * fabs(b[j]) && w > best_w)
                best_w = w, best = j;
        }
        if (best < 0)
            return; /* optimal: no bound unknown would lower the objective */
        free_set[best] = 1;
        for (int inner = 0; inner <= K; inner++) {
            int map[ESR_RIDGE_MAX], k = 0;
            for (int j = 0; j < K; j++)
                if (free_set[j])
                    map[k++] = j;
            double x[ESR_RIDGE_MAX], z[ESR_RIDGE_MAX] = {0};
            solve_subset(K, H, b, map, k, x);
            for (int a = 0; a < k; a++)
                z[map[a]] = x[a];
            double alpha = 1.0;
            for (int a = 0; a < k; a++) {
                const int j = map[a];
                if (z[j] <= 0.0 && s[j] - z[j] > 0.0)
                    alpha = fmin(alpha, s[j] / (s[j] - z[j]));
            }
            for (int j = 0; j < K; j++)
                s[j] += alpha * (z[j] - s[j]);
            if (alpha >= 1.0)
                break;
            double s_max = 0.0;
            for (int j = 0; j < K; j++)
                s_max = fmax(s_max, fabs(s[j]));
            for (int j = 0; j < K; j++) /* the unknowns the step stopped at 0 are bound again */
                if (free_set[j] && s[j] <= 1e-12 * s_max)
                    free_set[j] = 0, s[j] = 0.0;
        }
    }
}

/* Weighted normal equations G = sum w a a', r = sum w y a of n rows. */
static void normal_equations(int K, size_t n, const double *a, const double *y, const double *w,
                             double *G, double *r)
{
    for (int i = 0; i < K * K; i++)
        G[i] = 0.0;
    for (int i = 0; i < K; i++)
        r[i] = 0.0;
    for (size_t p = 0; p < n; p++) {
        const double *ap = a + p * (size_t)K, wp = w ? w[p] : 1.0;
        for (int i = 0; i < K; i++) {
            r[i] += wp * ap[i] * y[p];
            for (int j = 0; j < K; j++)
                G[i * K + j] += wp * ap[i] * ap[j];
        }
    }
}

int esr_ridge_fit_robust(int K, size_t n, const double *a, const double *y, double ridge,
                         int rounds, double *s)
{
    double G[ESR_RIDGE_MAX * ESR_RIDGE_MAX], r[ESR_RIDGE_MAX];
    normal_equations(K, n, a, y, NULL, G, r);
    esr_ridge_solve_nonneg(K, G, r, ridge, s);
    if (rounds <= 0 || n == 0)
        return 0;
    double *res = malloc(n * sizeof(double)), *sorted = malloc(n * sizeof(double));
    if (!res || !sorted) {
        free(res), free(sorted);
        return -1;
    }
    for (int round = 0; round < rounds; round++) {
        for (size_t p = 0; p < n; p++) {
            double v = y[p];
            for (int i = 0; i < K; i++)
                v -= a[p * (size_t)K + i] * s[i];
            res[p] = fabs(v);
            sorted[p] = res[p];
        }
        const double med = esr_median_doubles(sorted, n);
        const double cut = 1.345 * 1.4826 * med;
        if (!(cut > 0.0))
            break; /* most rows fit exactly: nothing to down-weight */
        for (size_t p = 0; p < n; p++)
            res[p] = res[p] > cut ? cut / res[p] : 1.0; /* the weights, in place */
        normal_equations(K, n, a, y, res, G, r);
        esr_ridge_solve_nonneg(K, G, r, ridge, s);
    }
    free(res), free(sorted);
    return 0;
}
