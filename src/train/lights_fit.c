/* The lights' calibration fit (see lights_fit.h). */
#include "train/lights_fit.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/order.h"
#include "core/ridge_solve.h"
#include "train/lights.h"

_Static_assert(ESR_MAX_LIGHTS <= ESR_RIDGE_MAX, "the calibration solves one unknown per light");

/* Huber's loss of a residual u in units of its scale (the weights esr_ridge_fit_robust uses). */
static double huber(double u)
{
    const double c = 1.345, au = fabs(u);
    return au <= c ? 0.5 * u * u : c * (au - 0.5 * c);
}

int esr_calib_fit(const struct esr_lights *L, const struct esr_calib_rows *rows, const int *fit,
                      int nf, const int *emits, double *ca, double *cy,
                      double scale[3][ESR_MAX_LIGHTS], const double *sigma, double *sigma_out,
                      double *loss)
{
    const int K = L->n;
    for (int c = 0; c < 3; c++) {
        for (size_t p = 0; p < rows->n; p++) { /* channel c's rows of the fitted lights */
            const size_t row = p * 3 + (size_t)c;
            const double r = rows->r[row] / rows->median[c];
            double a[ESR_MAX_LIGHTS];
            for (int k = 0; k < K; k++)
                a[k] = rows->a[row * (size_t)K + (size_t)k] +
                       (emits && emits[k] ? rows->ar[row * (size_t)K + (size_t)k] : 0.0);
            cy[p] = rows->emo[row] - r * rows->b[row];
            double *col = ca + p * (size_t)nf;
            esr_lights_fit_columns(L, fit, nf, a, col);
            for (int f = 0; f < nf; f++)
                col[f] *= r;
        }
        if (esr_ridge_fit_robust(nf, rows->n, ca, cy, ESR_CALIB_RIDGE, ESR_CALIB_ROBUST_ROUNDS, scale[c]) != 0)
            return -1;
        for (size_t p = 0; p < rows->n; p++) { /* the residuals, into cy */
            double e = cy[p];
            for (int f = 0; f < nf; f++)
                e -= ca[p * (size_t)nf + (size_t)f] * scale[c][f];
            cy[p] = fabs(e);
        }
        if (sigma && loss)
            for (size_t p = 0; p < rows->n; p++)
                loss[p * 3 + (size_t)c] = sigma[c] > 0.0 ? huber(cy[p] / sigma[c]) : 0.0;
        if (sigma_out)
            sigma_out[c] = rows->n ? 1.4826 * esr_median_doubles(cy, rows->n) : 0.0;
    }
    return 0;
}

int esr_calib_decide_rims(const struct esr_lights *L, const struct esr_calib_rows *rows, const int *fit,
                       int nf, const int *has_rim, double *ca, double *cy, int emits[ESR_MAX_LIGHTS],
                       float t_on[ESR_MAX_LIGHTS])
{
    double scale[3][ESR_MAX_LIGHTS], sigma[3];
    const size_t nr = rows->n * 3;
    double *best = malloc((nr ? nr : 1) * sizeof(double)), *loss = malloc((nr ? nr : 1) * sizeof(double));
    memset(emits, 0, ESR_MAX_LIGHTS * sizeof(int));
    memset(t_on, 0, ESR_MAX_LIGHTS * sizeof(float));
    int rc = best && loss ? 0 : -1;
    if (rc == 0)
        rc = esr_calib_fit(L, rows, fit, nf, NULL, ca, cy, scale, NULL, sigma, NULL);
    if (rc == 0)
        rc = esr_calib_fit(L, rows, fit, nf, emits, ca, cy, scale, sigma, NULL, best);
    for (int changed = 1; rc == 0 && changed;) {
        changed = 0;
        for (int k = 0; rc == 0 && k < L->n; k++) {
            if (!has_rim[k])
                continue;
            emits[k] = !emits[k];
            rc = esr_calib_fit(L, rows, fit, nf, emits, ca, cy, scale, sigma, NULL, loss);
            /* the points' paired change of loss (a point's three channels are one observation,
             * not three): its mean over its standard error */
            const size_t np = rows->n;
            double sum = 0.0, sum2 = 0.0;
            for (size_t p = 0; p < np; p++) {
                const double d = loss[p * 3] + loss[p * 3 + 1] + loss[p * 3 + 2] -
                                 (best[p * 3] + best[p * 3 + 1] + best[p * 3 + 2]);
                sum += d, sum2 += d * d;
            }
            const double mean = np ? sum / (double)np : 0.0;
            const double var = np > 1 ? (sum2 - sum * mean) / (double)(np - 1) : 0.0;
            const double t = var > 0.0 ? mean / sqrt(var / (double)np) : 0.0;
            t_on[k] = (float)(emits[k] ? t : -t);
            if (rc == 0 && t < -ESR_CALIB_RIM_T) {
                memcpy(best, loss, nr * sizeof(double));
                changed = 1;
            } else {
                emits[k] = !emits[k];
            }
        }
    }
    free(best), free(loss);
    return rc;
}


int esr_lights_rim_text(const struct esr_lights *L, int id, char *out, size_t size)
{
    if (size)
        out[0] = '\0';
    if (id < 0 || id >= L->n || L->rim[id].points == 0)
        return 0;
    const struct esr_light_rim *r = &L->rim[id];
    if (r->emits)
        snprintf(out, size, "light %d: its rim of %ld surface point%s that only lights-off or "
                 "clipped photos show emits: the light it casts fits the photos better by %.1f "
                 "standard errors", id, r->points, r->points == 1 ? "" : "s", -(double)r->t_on);
    else
        snprintf(out, size, "light %d: its rim of %ld surface point%s that only lights-off or "
                 "clipped photos show stays dark: the light it would cast fits the photos no "
                 "better (%.1f standard errors, %.0f needed)", id, r->points,
                 r->points == 1 ? "" : "s", -(double)r->t_on, ESR_CALIB_RIM_T);
    return 1;
}
