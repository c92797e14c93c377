/* ESR_MAX_ISA (core/isa.h): the cap is read once, the MLP tile GEMM runs the capped path and
 * still computes C = A B + bias, and `esr` refuses a value that names no path. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/isa.h"
#include "nn/tile_gemm.h"
#include "test_support.h"

/* The generic path, chosen by the cap on any CPU, against a double-precision product. */
static void test_generic_cap_runs_generic_gemm(void **state)
{
    (void)state;
    setenv("ESR_MAX_ISA", "generic", 1); /* before the first esr_isa_cap() of this process */
    assert_int_equal(esr_isa_cap(), ESR_ISA_GENERIC);
    assert_string_equal(esr_gemm_isa(), "generic");
    setenv("ESR_MAX_ISA", "avx512", 1);
    assert_int_equal(esr_isa_cap(), ESR_ISA_GENERIC); /* read once: a run does not change paths */
    enum { M = 37, N = 29, K = 23 };
    float a[M * K], b[K * N], bias[N], c[M * N];
    for (int i = 0; i < M * K; i++)
        a[i] = (float)((i * 37) % 17) / 17.0f - 0.5f;
    for (int i = 0; i < K * N; i++)
        b[i] = (float)((i * 11) % 13) / 13.0f - 0.4f;
    for (int j = 0; j < N; j++)
        bias[j] = 0.1f * (float)j - 1.0f;
    const struct esr_gemm_tile t = {a, b, c, bias, M, N, K, K, N, N, 0, 0, ESR_NN_ACT_NONE};
    esr_gemm_tile(&t);
    double worst = 0.0;
    for (int r = 0; r < M; r++)
        for (int j = 0; j < N; j++) {
            double want = bias[j];
            for (int p = 0; p < K; p++)
                want += (double)a[r * K + p] * b[p * N + j];
            worst = fmax(worst, fabs(want - c[r * N + j]));
        }
    assert_true(worst < 1e-5);
}

/* `esr --version` names the capped path; a value that names none is refused, naming it. */
static void test_cli_cap(void **state)
{
    (void)state;
    char out[4096];
    assert_int_equal(test_run_esr_after("ESR_MAX_ISA=avx2 ", "--version", out, sizeof out), 0);
    assert_non_null(strstr(out, "capped by ESR_MAX_ISA=avx2"));
    assert_true(strstr(out, "MLP kernels avx2") || strstr(out, "MLP kernels generic")); /* a CPU without AVX2 */
    assert_int_equal(test_run_esr_after("ESR_MAX_ISA=sse4 ", "--version", out, sizeof out), 1);
    assert_non_null(strstr(out, "ESR_MAX_ISA='sse4' is not a code path (avx512, avx2 or generic)"));
    assert_int_equal(test_run_esr_after("ESR_MAX_ISA= ", "--version", out, sizeof out), 0); /* unset-like */
    assert_null(strstr(out, "capped"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_generic_cap_runs_generic_gemm),
        cmocka_unit_test(test_cli_cap),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
