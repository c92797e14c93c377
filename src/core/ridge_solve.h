/* Small dense least squares with a ridge towards 1 and scales kept >= 0 (the lights' strength
 * calibration, train/lights/lights.h: one unknown per light, a few at most). */
#ifndef ESR_CORE_RIDGE_SOLVE_H
#define ESR_CORE_RIDGE_SOLVE_H

#include <stddef.h>

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

/* The same fit from its n rows, y_i ~ a_i . s (a: [n*K] row-major, y: [n]), made robust: after a
 * plain solve, `rounds` times, each row is weighted by Huber's w = min(1, 1.345 sigma / |res|),
 * sigma = 1.4826 median |res| (the residuals' scale were they Gaussian), and the weighted
 * normal equations are solved again. Rows the model cannot explain at all (a mirror's reflection
 * seen as direct light) then pull with a bounded force instead of their squared error. rounds 0
 * is the plain fit. Returns 0, or -1 when out of memory (s then holds the plain fit). */
int esr_ridge_fit_robust(int K, size_t n, const double *a, const double *y, double ridge,
                         int rounds, double *s);

#ifdef __cplusplus
}
#endif
#endif
