/* The MLP tile GEMM (nn/tile_gemm): every code path this CPU and build have computes C = A B
 * (+ bias, + C, ReLU) against a double-precision product on shapes that exercise each panel
 * width (32-column AVX-512 panels, 16-column panels, the padded remainder) and the row
 * remainders, plain and with A transposed; and the AVX-512 path (16-float vectors) agrees with
 * the AVX2 path (8-float vectors) bit for bit, as the MLP's determinism promises. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "nn/tile_gemm.h"

enum { MAXD = 70 };

struct shape {
    int m, n, k, trans_a, accumulate, bias, relu;
};

static float value(uint32_t i, uint32_t salt)
{
    uint32_t h = (i + 1u) * 2654435761u ^ salt * 40503u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    return (float)(h >> 8) / 16777216.0f - 0.5f;
}

/* C on the path up to `cap`; c starts as `c0` (read when accumulating). Returns the path. */
static const char *run(enum esr_isa cap, const struct shape *s, const float *a, const float *b,
                       const float *bias, const float *c0, float *c)
{
    memcpy(c, c0, sizeof(float) * MAXD * MAXD);
    const struct esr_gemm_tile t = {
        .a = a, .b = b, .c = c, .bias = s->bias ? bias : NULL, .m = s->m, .n = s->n, .k = s->k,
        .lda = s->trans_a ? s->m : s->k, .ldb = s->n, .ldc = s->n, .trans_a = s->trans_a,
        .accumulate = s->accumulate, .act = s->relu ? ESR_NN_ACT_RELU : ESR_NN_ACT_NONE,
    };
    return esr_gemm_tile_upto(cap, &t);
}

static void test_paths_against_double_and_each_other(void **state)
{
    (void)state;
    static float a[MAXD * MAXD], b[MAXD * MAXD], bias[MAXD], c0[MAXD * MAXD];
    static float c_wide[MAXD * MAXD], c_avx2[MAXD * MAXD], c_gen[MAXD * MAXD];
    for (int i = 0; i < MAXD * MAXD; i++) {
        a[i] = value((uint32_t)i, 1), b[i] = value((uint32_t)i, 2), c0[i] = value((uint32_t)i, 3);
    }
    for (int j = 0; j < MAXD; j++)
        bias[j] = value((uint32_t)j, 4);
    const int ms[] = {1, 5, 8, 13, 64}, ns[] = {3, 16, 22, 32, 40, 64, 67}, ks[] = {1, 22, 64};
    int compared = 0;
    for (size_t im = 0; im < sizeof ms / sizeof *ms; im++)
        for (size_t in = 0; in < sizeof ns / sizeof *ns; in++)
            for (size_t ik = 0; ik < sizeof ks / sizeof *ks; ik++)
                for (int variant = 0; variant < 4; variant++) {
                    const struct shape s = {ms[im], ns[in], ks[ik], variant & 1, variant == 2,
                                            variant != 2, variant == 3};
                    const char *p_wide = run(ESR_ISA_AVX512, &s, a, b, bias, c0, c_wide);
                    const char *p_avx2 = run(ESR_ISA_AVX2, &s, a, b, bias, c0, c_avx2);
                    run(ESR_ISA_GENERIC, &s, a, b, bias, c0, c_gen);
                    for (int r = 0; r < s.m; r++)
                        for (int j = 0; j < s.n; j++) {
                            double want = s.accumulate ? c0[r * s.n + j] : s.bias ? bias[j] : 0.0;
                            for (int p = 0; p < s.k; p++)
                                want += (double)(s.trans_a ? a[p * s.m + r] : a[r * s.k + p]) *
                                        b[p * s.n + j];
                            if (s.relu && want < 0.0)
                                want = 0.0;
                            const float *got[3] = {c_wide, c_avx2, c_gen};
                            for (int q = 0; q < 3; q++)
                                assert_true(fabs(got[q][r * s.n + j] - want) < 2e-5 * (1 + s.k));
                        }
                    /* outside the m x n result nothing is written */
                    assert_memory_equal(c_wide + s.m * s.n, c0 + s.m * s.n,
                                        sizeof(float) * (size_t)(MAXD * MAXD - s.m * s.n));
                    if (!strcmp(p_wide, "avx512") && !strcmp(p_avx2, "avx2")) {
                        assert_memory_equal(c_wide, c_avx2, sizeof(float) * (size_t)(s.m * s.n));
                        compared++;
                    }
                }
    /* a CPU or build without both paths (the sanitizer build has one) compares none */
    print_message("AVX-512 and AVX2 paths compared bit for bit on %d shapes\n", compared);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paths_against_double_and_each_other),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
