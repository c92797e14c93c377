/* Chi-square goodness-of-fit helpers for the statistical tests (header-only, double precision). */
#ifndef ESR_TEST_STATS_H
#define ESR_TEST_STATS_H

#include <math.h>
#include <stddef.h>

/* Pearson's statistic sum (observed - expected)^2 / expected over n bins. */
static inline double test_chi2_statistic(const double *observed, const double *expected, size_t n)
{
    double chi2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = observed[i] - expected[i];
        chi2 += d * d / expected[i];
    }
    return chi2;
}

/* Upper quantile of chi-square with df degrees of freedom at standard-normal score z
 * (Wilson-Hilferty; z = 4 is a false-alarm rate of ~3e-5, accurate to a few % for df >= 10). */
static inline double test_chi2_critical(double df, double z)
{
    double a = 2.0 / (9.0 * df);
    double t = 1.0 - a + z * sqrt(a);
    return df * t * t * t;
}

#endif
