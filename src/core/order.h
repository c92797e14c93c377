/* Sorting and the median: qsort with its comparisons written once (the calibration, the pdra
 * stage's emitter level, the normal and pose statistics all sort numbers). */
#ifndef ESR_CORE_ORDER_H
#define ESR_CORE_ORDER_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Ascending, in place (NaNs in no particular place). */
void esr_sort_floats(float *v, size_t n);
void esr_sort_doubles(double *v, size_t n);
/* The median of v[0..n-1], the mean of the middle two for an even n; n > 0. Sorts v. */
double esr_median_doubles(double *v, size_t n);

#ifdef __cplusplus
}
#endif
#endif
