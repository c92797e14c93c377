/* Small dense least squares with a ridge towards 1 and scales kept >= 0 (the lights' strength
 * calibration, train/lights.h: one unknown per light, a few at most). */
#ifndef ESR_CORE_RIDGE_SOLVE_H
#define ESR_CORE_RIDGE_SOLVE_H

#ifdef __cplusplus
extern "C" {
#endif

/* Solves the K x K normal equations G s = r (G row-major, symmetric positive semi-definite;
 * neither is changed) with a ridge towards 1 relative to each unknown's own diagonal,
 *     (G + L) s = r + L 1,   L = diag(ridge G_ii + 1e-12),
 * subject to s >= 0 (the least-squares optimum over s >= 0, Lawson and Hanson's active-set
 * method; clamping the unconstrained solution at 0 instead would leave the other unknowns their
 * share of a negative one). K <= ESR_RIDGE_MAX. */
#define ESR_RIDGE_MAX 16
void esr_ridge_solve_nonneg(int K, const double *G, const double *r, double ridge, double *s);

#ifdef __cplusplus
}
#endif
#endif
