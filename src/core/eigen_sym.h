/* Eigen-decomposition of a small real symmetric matrix (n <= 4) by cyclic Jacobi rotations.
 * Small and exact enough for the pose alignment (Horn's 4x4 quaternion matrix), where a library
 * would be a dependency for forty lines; Jacobi keeps the eigenvectors orthonormal to rounding
 * even for repeated eigenvalues. */
#ifndef ESR_CORE_EIGEN_SYM_H
#define ESR_CORE_EIGEN_SYM_H

#define ESR_EIGEN_SYM_MAX 4

/* a: n x n, row-major, symmetric (only its upper triangle is read). values: n eigenvalues in
 * descending order; vectors: n x n row-major, column k the unit eigenvector of values[k].
 * Fails on n outside 1..4, a non-finite entry, or no convergence (which does not happen for
 * finite input; the check guards the loop bound). */
int esr_eigen_sym(int n, const double *a, double *values, double *vectors);

#endif
