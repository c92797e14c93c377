/* SSIM as in JAXNeRF / mip-NeRF `compute_ssim` (see metrics.h for the exact variant).
 * Separable: a horizontal 11-tap pass over every row of the five moment images (a, b, a^2, b^2,
 * ab), then a vertical pass that produces one output row at a time and reduces it straight into
 * the SSIM sum. Rows are independent, so both passes run OpenMP-parallel over rows; each output
 * row's sum is kept separately and added up serially, so the result is identical for any thread
 * count. */
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "eval/metrics.h"
#include "eval/metrics_internal.h"

enum { SSIM_TAPS = 11, SSIM_MOMENTS = 5 };

#define SSIM_SIGMA 1.5
#define SSIM_C1 (0.01 * 0.01) /* (K1 * max_val)^2, max_val = 1 */
#define SSIM_C2 (0.03 * 0.03) /* (K2 * max_val)^2 */

/* Normalised 1-D Gaussian, centred on tap 5 (JAXNeRF's `shift` is 0 for an odd size). */
static void ssim_filter(double w[SSIM_TAPS])
{
    double sum = 0.0;
    for (int i = 0; i < SSIM_TAPS; i++) {
        double t = (i - SSIM_TAPS / 2) / SSIM_SIGMA;
        w[i] = exp(-0.5 * t * t);
        sum += w[i];
    }
    for (int i = 0; i < SSIM_TAPS; i++)
        w[i] /= sum;
}

/* One SSIM map value from the five filtered moments, with JAXNeRF's clipping. */
static inline double ssim_pixel(double mu0, double mu1, double e00, double e11, double e01)
{
    double s00 = fmax(0.0, e00 - mu0 * mu0);
    double s11 = fmax(0.0, e11 - mu1 * mu1);
    double s01 = e01 - mu0 * mu1;
    double bound = sqrt(s00 * s11);
    s01 = s01 < 0.0 ? -fmin(bound, -s01) : fmin(bound, s01);
    double numer = (2.0 * mu0 * mu1 + SSIM_C1) * (2.0 * s01 + SSIM_C2);
    double denom = (mu0 * mu0 + mu1 * mu1 + SSIM_C1) * (s00 + s11 + SSIM_C2);
    return numer / denom;
}

/* Horizontal pass of channel c: h[m][y*ow + x] = sum_k w[k] * moment_m(y, x+k). */
static void ssim_pass_rows(const struct esr_image *a, const struct esr_image *b, int c, const double *w,
                           double *h)
{
    int width = a->width, height = a->height, nc = a->channels, ow = width - (SSIM_TAPS - 1);
    size_t plane = (size_t)height * ow;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < height; y++) {
        const float *ra = a->data + (size_t)y * width * nc + c;
        const float *rb = b->data + (size_t)y * width * nc + c;
        double *out = h + (size_t)y * ow;
        for (int x = 0; x < ow; x++) {
            double s0 = 0, s1 = 0, s00 = 0, s11 = 0, s01 = 0;
            for (int k = 0; k < SSIM_TAPS; k++) {
                double va = ra[(size_t)(x + k) * nc], vb = rb[(size_t)(x + k) * nc];
                s0 += w[k] * va;
                s1 += w[k] * vb;
                s00 += w[k] * va * va;
                s11 += w[k] * vb * vb;
                s01 += w[k] * va * vb;
            }
            out[x] = s0;
            out[plane + x] = s1;
            out[2 * plane + x] = s00;
            out[3 * plane + x] = s11;
            out[4 * plane + x] = s01;
        }
    }
}

/* Vertical pass + SSIM map; row_sum[y] receives the sum of output row y. */
static void ssim_pass_columns(const double *h, int ow, int height, const double *w, double *row_sum)
{
    int oh = height - (SSIM_TAPS - 1);
    size_t plane = (size_t)height * ow;
#pragma omp parallel for schedule(static)
    for (int y = 0; y < oh; y++) {
        double sum = 0.0;
        for (int x = 0; x < ow; x++) {
            double m[SSIM_MOMENTS] = {0, 0, 0, 0, 0};
            for (int k = 0; k < SSIM_TAPS; k++) {
                const double *col = h + (size_t)(y + k) * ow + x;
                for (int q = 0; q < SSIM_MOMENTS; q++)
                    m[q] += w[k] * col[q * plane];
            }
            sum += ssim_pixel(m[0], m[1], m[2], m[3], m[4]);
        }
        row_sum[y] = sum;
    }
}

int esr_metric_ssim(const struct esr_image *a, const struct esr_image *b, double *out)
{
    ESR_TRY(esr_metric_check_same_shape(a, b, "SSIM"));
    if (a->width < SSIM_TAPS || a->height < SSIM_TAPS)
        return ESR_FAIL("SSIM: image is %dx%d but the 11x11 window needs at least 11x11 pixels", a->width,
                        a->height);
    int ow = a->width - (SSIM_TAPS - 1), oh = a->height - (SSIM_TAPS - 1);
    double *h = malloc(sizeof *h * SSIM_MOMENTS * (size_t)a->height * ow);
    double *row_sum = malloc(sizeof *row_sum * (size_t)oh);
    if (!h || !row_sum) {
        free(h);
        free(row_sum);
        return ESR_FAIL("SSIM: out of memory for a %dx%d image", a->width, a->height);
    }
    double w[SSIM_TAPS];
    ssim_filter(w);
    double total = 0.0;
    for (int c = 0; c < a->channels; c++) {
        ssim_pass_rows(a, b, c, w, h);
        ssim_pass_columns(h, ow, a->height, w, row_sum);
        for (int y = 0; y < oh; y++)
            total += row_sum[y];
    }
    free(h);
    free(row_sum);
    *out = total / ((double)ow * oh * a->channels);
    return ESR_OK;
}
