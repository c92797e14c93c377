/* The strength solve's fit (train/lights/solve.h, esr_lights_solve_fit): per channel, a
 * non-negative robust least squares over exact rows and hinged lower-bound rows. */
#include "train/lights/solve.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/order.h"
#include "core/ridge_solve.h"

/* Huber reweighting rounds, and its constant in residual scales */
#define FIT_ROUNDS 12
#define HUBER_K 1.345
/* ridge towards 1 relative to each light's own normal-equation diagonal: a light no row reaches
 * keeps its start */
#define FIT_RIDGE 1e-6

/* Inverts the K x K symmetric positive definite g (row-major) into inv by Gauss-Jordan with
 * partial pivoting; returns 0, -1 when singular. */
static int invert(int K, const double *g, double *inv)
{
    double a[ESR_MAX_LIGHTS * 2 * ESR_MAX_LIGHTS];
    const int W = 2 * K;
    for (int i = 0; i < K; i++)
        for (int j = 0; j < W; j++)
            a[i * W + j] = j < K ? g[i * K + j] : (j - K == i);
    for (int c = 0; c < K; c++) {
        int piv = c;
        for (int r = c + 1; r < K; r++)
            if (fabs(a[r * W + c]) > fabs(a[piv * W + c]))
                piv = r;
        if (!(fabs(a[piv * W + c]) > 1e-300))
            return -1;
        for (int j = 0; j < W && piv != c; j++) {
            const double t = a[c * W + j];
            a[c * W + j] = a[piv * W + j], a[piv * W + j] = t;
        }
        const double d = a[c * W + c];
        for (int j = 0; j < W; j++)
            a[c * W + j] /= d;
        for (int r = 0; r < K; r++) {
            if (r == c || a[r * W + c] == 0.0)
                continue;
            const double f = a[r * W + c];
            for (int j = 0; j < W; j++)
                a[r * W + j] -= f * a[c * W + j];
        }
    }
    for (int i = 0; i < K; i++)
        for (int j = 0; j < K; j++)
            inv[i * K + j] = a[i * W + K + j];
    return 0;
}

/* Row i's residual in channel c at s (columns: a, or the mean of a and a2), and whether it counts (a lower bound only while the fit
 * is below it). */
static int residual(const struct esr_solve_rows *rows, size_t i, int c, const double *s, double *r)
{
    const int K = rows->K;
    const float *a = rows->a, *a2 = rows->a2, *y = rows->y;
    const uint8_t *kind = rows->kind;
    const size_t at = i * 3 + (size_t)c;
    if (kind[at] == 0)
        return 0;
    double fit = 0.0;
    for (int k = 0; k < K; k++) {
        const size_t j = at * (size_t)K + (size_t)k;
        fit += (a2 ? 0.5 * ((double)a[j] + (double)a2[j]) : (double)a[j]) * s[k];
    }
    *r = (double)y[at] - fit;
    return kind[at] == 1 || *r > 0.0;
}

int esr_lights_solve_fit(const struct esr_solve_rows *rows, double s[3][ESR_MAX_LIGHTS],
                         double *cov, double sigma[3])
{
    const int K = rows->K;
    const size_t n = rows->n;
    const float *a = rows->a, *a2 = rows->a2, *y = rows->y;
    const uint8_t *kind = rows->kind;
    double *absr = malloc((n ? n : 1) * sizeof(double));
    if (!absr)
        return -1;
    for (int c = 0; c < 3; c++) {
        /* solved for t = s / u, u the start: the ridge then pulls a light no row reaches
         * towards its start, not towards the field as trained */
        double u[ESR_MAX_LIGHTS], t[ESR_MAX_LIGHTS];
        for (int k = 0; k < K; k++)
            u[k] = s[c][k] > 0.0 && isfinite(s[c][k]) ? s[c][k] : 1.0, t[k] = 1.0;
        double scale = 0.0; /* the residuals' scale; 0: the first round is a plain fit */
        double G[ESR_MAX_LIGHTS * ESR_MAX_LIGHTS];
        for (int round = 0; round <= FIT_ROUNDS; round++) {
            double rhs[ESR_MAX_LIGHTS] = {0};
            memset(G, 0, sizeof G);
            for (size_t i = 0; i < n; i++) {
                double r;
                if (!residual(rows, i, c, s[c], &r))
                    continue;
                const double w = scale > 0.0 && fabs(r) > HUBER_K * scale ? HUBER_K * scale / fabs(r) : 1.0;
                const float *ai = a + (i * 3 + (size_t)c) * (size_t)K;
                const float *bi = a2 ? a2 + (i * 3 + (size_t)c) * (size_t)K : ai;
                const double yi = y[i * 3 + (size_t)c];
                for (int k = 0; k < K; k++) {
                    const double ak = ai[k] * u[k], bk = bi[k] * u[k];
                    rhs[k] += w * 0.5 * (ak + bk) * yi;
                    /* two independent estimates: E[a_k b_j] = E[a_k] E[b_j], no noise variance
                     * on the diagonal to bias a noisy light's scale towards 0 */
                    for (int j = 0; j <= k; j++)
                        G[k * K + j] += w * 0.5 * (ak * bi[j] + bk * ai[j]) * u[j];
                }
            }
            for (int k = 0; k < K; k++)
                for (int j = 0; j < k; j++)
                    G[j * K + k] = G[k * K + j];
            esr_ridge_solve_nonneg(K, G, rhs, FIT_RIDGE, t);
            for (int k = 0; k < K; k++)
                s[c][k] = t[k] * u[k];
            size_t m = 0;
            for (size_t i = 0; i < n; i++) {
                double r;
                if (kind[i * 3 + (size_t)c] == 1 && residual(rows, i, c, s[c], &r))
                    absr[m++] = fabs(r);
            }
            scale = m ? 1.4826 * esr_median_doubles(absr, m) : 0.0;
            if (!(scale > 0.0))
                break;
        }
        sigma[c] = scale;
        if (!cov)
            continue;
        /* the covariance of the lights off their bound: sigma^2 (G + ridge)^-1 (the last
         * round's Huber weights; the ridge as the solve has it, so that two lights only the
         * sum of is known come out nearly opposite rather than singular) */
        double *cv = cov + (size_t)c * ESR_MAX_LIGHTS * ESR_MAX_LIGHTS;
        memset(cv, 0, ESR_MAX_LIGHTS * ESR_MAX_LIGHTS * sizeof(double));
        int free_ids[ESR_MAX_LIGHTS], nfree = 0;
        for (int k = 0; k < K; k++)
            if (s[c][k] > 0.0 && G[k * K + k] > 0.0)
                free_ids[nfree++] = k;
        double g[ESR_MAX_LIGHTS * ESR_MAX_LIGHTS], inv[ESR_MAX_LIGHTS * ESR_MAX_LIGHTS];
        for (int i = 0; i < nfree; i++)
            for (int j = 0; j < nfree; j++) {
                const int ki = free_ids[i], kj = free_ids[j];
                g[i * nfree + j] = G[ki * K + kj] + (i == j ? FIT_RIDGE * G[ki * K + ki] + 1e-12 : 0.0);
            }
        if (nfree > 0 && invert(nfree, g, inv) == 0)
            for (int i = 0; i < nfree; i++)
                for (int j = 0; j < nfree; j++) {
                    const int ki = free_ids[i], kj = free_ids[j];
                    cv[ki * K + kj] = scale * scale * inv[i * nfree + j] * u[ki] * u[kj];
                }
    }
    free(absr);
    return 0;
}
