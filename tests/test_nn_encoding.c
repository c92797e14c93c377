/* Positional encoding: values by hand, layout into strided rows, backward against central
 * differences, d_in modes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <string.h>

#include "nn/encoding.h"

static void test_values_and_layout(void **state)
{
    (void)state;
    struct esr_pe pe = {2, 2};
    assert_int_equal(esr_pe_out_dims(&pe), 10);
    struct esr_pe_rows rows = {2, 3, 12}; /* padded strides: the encoder must skip the gaps */
    float in[6] = {0.5f, -1.25f, 99.0f, 2.0f, 0.0f, 99.0f}, out[24];
    for (int i = 0; i < 24; i++)
        out[i] = -7.0f;
    esr_pe_fwd(&pe, &rows, in, out);
    const double x0 = 0.5, x1 = -1.25;
    const double want[10] = {x0, x1, sin(x0), sin(x1), cos(x0), cos(x1),
                             sin(2 * x0), sin(2 * x1), cos(2 * x0), cos(2 * x1)};
    for (int j = 0; j < 10; j++)
        assert_float_equal(out[j], want[j], 1e-6);
    assert_float_equal(out[10], -7.0f, 0);
    assert_float_equal(out[11], -7.0f, 0);
    assert_float_equal(out[12], 2.0f, 0);
    assert_float_equal(out[14], sinf(2.0f), 1e-6);
    assert_float_equal(out[16], cosf(2.0f), 1e-6);
    assert_float_equal(out[20], cosf(4.0f), 1e-6);
}

/* The doubling recurrence over the octaves the models use (5, and 8 for margin) stays within
 * 2^octave float ulps of sin and cos taken in double. */
static void test_octaves_against_double(void **state)
{
    (void)state;
    enum { N = 2001, F = 8 };
    struct esr_pe pe = {1, F};
    struct esr_pe_rows rows = {1, 1, 1 + 2 * F};
    float out[1 + 2 * F];
    double worst[F] = {0};
    for (int i = 0; i < N; i++) {
        const float x = -2.0f + 4.0f * (float)i / (N - 1);
        esr_pe_fwd(&pe, &rows, &x, out);
        for (int k = 0; k < F; k++) {
            const double a = ldexp((double)x, k);
            worst[k] = fmax(worst[k], fmax(fabs(out[1 + 2 * k] - sin(a)), fabs(out[2 + 2 * k] - cos(a))));
        }
    }
    for (int k = 0; k < F; k++)
        if (!(worst[k] <= ldexp(1.2e-7, k + 1)))
            fail_msg("octave %d: largest error %g", k, worst[k]);
}

/* sum_j w_j PE(x)_j in double, for the finite-difference reference. */
static double weighted(const struct esr_pe *pe, const double *x, const float *w)
{
    double s = 0;
    for (int d = 0; d < pe->n_dims; d++) {
        s += w[d] * x[d];
        double f = 1;
        for (int k = 0; k < pe->n_freqs; k++, f *= 2) {
            s += w[(1 + 2 * k) * pe->n_dims + d] * sin(f * x[d]);
            s += w[(2 + 2 * k) * pe->n_dims + d] * cos(f * x[d]);
        }
    }
    return s;
}

static void test_backward_matches_central_differences(void **state)
{
    (void)state;
    struct esr_pe pe = {3, 5};
    const int no = esr_pe_out_dims(&pe);
    struct esr_pe_rows rows = {4, 3, (size_t)no};
    float in[12], d_out[4 * 33], d_in[12], acc[12];
    for (int i = 0; i < 12; i++)
        in[i] = 0.37f * (float)i - 2.0f;
    for (int i = 0; i < 4 * no; i++)
        d_out[i] = sinf(1.7f * (float)i);
    esr_pe_bwd(&pe, &rows, in, d_out, d_in, ESR_NN_GRAD_OVERWRITE);
    for (int r = 0; r < 4; r++)
        for (int d = 0; d < 3; d++) {
            double x[3] = {in[r * 3], in[r * 3 + 1], in[r * 3 + 2]}, h = 1e-6;
            x[d] += h;
            double lp = weighted(&pe, x, d_out + r * no);
            x[d] -= 2 * h;
            double lm = weighted(&pe, x, d_out + r * no);
            double fd = (lp - lm) / (2 * h);
            assert_true(fabs(d_in[r * 3 + d] - fd) <= 1e-4 * (1 + fabs(fd)));
        }
    for (int i = 0; i < 12; i++)
        acc[i] = 1.0f;
    esr_pe_bwd(&pe, &rows, in, d_out, acc, ESR_NN_GRAD_ACCUMULATE);
    for (int i = 0; i < 12; i++)
        assert_float_equal(acc[i], 1.0f + d_in[i], 1e-5);
    memcpy(acc, d_in, sizeof(acc));
    esr_pe_bwd(&pe, &rows, in, d_out, acc, ESR_NN_GRAD_IGNORE);
    assert_memory_equal(acc, d_in, sizeof(acc));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_values_and_layout),
        cmocka_unit_test(test_octaves_against_double),
        cmocka_unit_test(test_backward_matches_central_differences),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
