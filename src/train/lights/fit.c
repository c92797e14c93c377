/* The lights' calibration fit (see lights/fit.h). */
#include "train/lights/fit.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/order.h"
#include "core/ridge_solve.h"
#include "train/lights/lights.h"

_Static_assert(ESR_MAX_LIGHTS <= ESR_RIDGE_MAX, "the calibration solves one unknown per light");

/* Huber's loss of a residual u in units of its scale (the weights esr_ridge_fit_robust uses). */
static double huber(double u)
{
    const double c = 1.345, au = fabs(u);
    return au <= c ? 0.5 * u * u : c * (au - 0.5 * c);
}

int esr_calib_fit(const struct esr_calib_problem *pb, const int *emits,
                  double scale[3][ESR_MAX_LIGHTS], const double *sigma, double *sigma_out,
                  double *loss)
{
    const struct esr_lights *L = pb->L;
    const struct esr_calib_rows *rows = pb->rows;
    const int *fit = pb->fit, nf = pb->nf;
    double *ca = pb->ca, *cy = pb->cy;
    const int K = L->n;
    for (int c = 0; c < 3; c++) {
        for (size_t p = 0; p < rows->n; p++) { /* channel c's rows of the fitted lights */
            const size_t row = p * 3 + (size_t)c;
            const double r = rows->r[row] / rows->median[c];
            double a[ESR_MAX_LIGHTS], b = rows->b[row];
            for (int k = 0; k < K; k++) {
                const size_t at = row * (size_t)K + (size_t)k;
                a[k] = rows->a[at];
                if (emits && emits[k])
                    a[k] += rows->ar[at];
                else if (rows->br) /* a dark rim's own emission is other surfaces' light */
                    b += rows->br[at];
            }
            cy[p] = rows->emo[row] - r * b;
            double *col = ca + p * (size_t)nf;
            esr_lights_fit_columns(L, fit, nf, a, col);
            for (int f = 0; f < nf; f++)
                col[f] *= r;
        }
        if (esr_ridge_fit_robust(nf, rows->n, ca, cy, ESR_CALIB_RIDGE, ESR_CALIB_ROBUST_ROUNDS,
                                 scale[c]) != 0)
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

/* The points' paired change of loss from `from` to `to` (rows: point p, channel c at p * 3 + c;
 * a point's three channels are one observation, not three): its mean over its standard error. */
static double paired_t(const double *to, const double *from, size_t np)
{
    double sum = 0.0, sum2 = 0.0;
    for (size_t p = 0; p < np; p++) {
        const double d = to[p * 3] + to[p * 3 + 1] + to[p * 3 + 2] -
                         (from[p * 3] + from[p * 3 + 1] + from[p * 3 + 2]);
        sum += d, sum2 += d * d;
    }
    const double mean = np ? sum / (double)np : 0.0;
    const double var = np > 1 ? (sum2 - sum * mean) / (double)(np - 1) : 0.0;
    return var > 0.0 ? mean / sqrt(var / (double)np) : 0.0;
}

int esr_calib_decide_rims(const struct esr_calib_problem *pb, const int *has_rim,
                          int emits[ESR_MAX_LIGHTS], float t_on[ESR_MAX_LIGHTS])
{
    const struct esr_lights *L = pb->L;
    const struct esr_calib_rows *rows = pb->rows;
    double scale[3][ESR_MAX_LIGHTS], sigma[3];
    const size_t nr = rows->n * 3;
    double *best = malloc((nr ? nr : 1) * sizeof(double));
    double *loss = malloc((nr ? nr : 1) * sizeof(double));
    memset(emits, 0, ESR_MAX_LIGHTS * sizeof(int));
    memset(t_on, 0, ESR_MAX_LIGHTS * sizeof(float));
    int rc = best && loss ? 0 : -1;
    if (rc == 0)
        rc = esr_calib_fit(pb, emits, scale, NULL, sigma, NULL);
    if (rc == 0)
        rc = esr_calib_fit(pb, emits, scale, sigma, NULL, best);
    /* forward: the rim whose light helps most, while one helps clearly (a rim once on stays on) */
    for (;;) {
        int pick = -1;
        double t_pick = -ESR_CALIB_RIM_T;
        for (int k = 0; rc == 0 && k < L->n; k++) {
            if (!has_rim[k] || emits[k])
                continue;
            emits[k] = 1;
            rc = esr_calib_fit(pb, emits, scale, sigma, NULL, loss);
            emits[k] = 0;
            const double t = paired_t(loss, best, rows->n);
            if (rc == 0 && t < t_pick)
                pick = k, t_pick = t;
        }
        if (rc != 0 || pick < 0)
            break;
        emits[pick] = 1;
        rc = esr_calib_fit(pb, emits, scale, sigma, NULL, best);
    }
    /* what each rim's light does against the final choice, for the report */
    for (int k = 0; rc == 0 && k < L->n; k++) {
        if (!has_rim[k])
            continue;
        emits[k] = !emits[k];
        rc = esr_calib_fit(pb, emits, scale, sigma, NULL, loss);
        emits[k] = !emits[k];
        const double t = paired_t(loss, best, rows->n);
        t_on[k] = (float)(emits[k] ? -t : t);
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
