/* Sorting and the median (see order.h). */
#include "core/order.h"

#include <stdlib.h>

static int ascending_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static int ascending_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

void esr_sort_floats(float *v, size_t n) { qsort(v, n, sizeof *v, ascending_float); }

void esr_sort_doubles(double *v, size_t n) { qsort(v, n, sizeof *v, ascending_double); }

double esr_median_doubles(double *v, size_t n)
{
    esr_sort_doubles(v, n);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
