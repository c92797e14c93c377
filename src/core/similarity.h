/* Similarity transforms y = scale * R x + t between two sets of corresponding 3D points, fitted
 * by least squares: the rotation by Horn's quaternion method (the top eigenvector of a 4x4
 * symmetric matrix built from the cross-covariance; always a proper rotation, so no reflection
 * fix-up as in an SVD), the scale and translation as Umeyama (1991) gives them for that rotation.
 * Used to compare recovered camera poses with known ones. */
#ifndef ESR_CORE_SIMILARITY_H
#define ESR_CORE_SIMILARITY_H

struct esr_similarity {
    double scale;
    double rotation[3][3]; /* row-major, proper (det +1) */
    double translation[3];
};

/* Fits to minimise sum |y_i - (scale R x_i + t)|^2 over the n point pairs (x, y: n * 3 doubles).
 * Fails when n < 3, an input is not finite, the x points coincide, or either set lies on one
 * line (the rotation about that line is then not determined). */
int esr_similarity_fit(const double *x, const double *y, int n, struct esr_similarity *out);

/* y = scale * R x + t. */
void esr_similarity_apply(const struct esr_similarity *s, const double x[3], double y[3]);

/* R of a Hamilton quaternion (w, x, y, z), normalised first (also COLMAP's image poses). */
void esr_quaternion_to_rotation(const double q[4], double r[3][3]);

/* The angle in degrees of the rotation a^T b taking a's frame to b's (0..180), full precision near 0
 * and 180 (atan2 of its sine and cosine). */
double esr_rotation_angle_deg(const double a[3][3], const double b[3][3]);

#endif
