/* Batch loops over the DVGO density -> alpha kernels of density.h. */
#include "fields/density.h"

void esr_density_alpha_batch_fwd(const float *density, size_t n, float shift, float interval,
                                 float *alpha)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        alpha[i] = esr_density_alpha_fwd(density[i], shift, interval);
}

void esr_density_alpha_batch_bwd(const float *density, size_t n, float shift, float interval,
                                 const float *d_alpha, float *d_density)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        d_density[i] += esr_density_alpha_bwd(density[i], shift, interval, d_alpha[i]);
}
