/* MLP: gradients against central differences of a double-precision reference, the forward
 * against that reference, inference == training forward, d_in modes, thread-count determinism;
 * the training-path tests run for every engine (fused, oneDNN, OpenBLAS). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "nn/mlp.h"

static enum esr_mlp_engine engine; /* of the group running */

struct fixture {
    struct esr_nn_params p;
    struct esr_mlp mlp;
    struct esr_mlp_ctx ctx;
    size_t n;
    float *in, *out, *d_out, *d_in;
};

static void fill(float *x, size_t n, uint64_t stream, float scale)
{
    struct esr_rng rng = esr_rng_init(99, stream);
    for (size_t i = 0; i < n; i++)
        x[i] = scale * (2.0f * esr_rng_float(&rng) - 1.0f);
}

static void fixture_init(struct fixture *f, const struct esr_mlp_desc *d, size_t n)
{
    memset(f, 0, sizeof(*f));
    assert_int_equal(esr_nn_params_init(&f->p, 3), ESR_OK);
    size_t dummy;
    assert_int_equal(esr_nn_params_take(&f->p, 5, &dummy), ESR_OK); /* MLP not at offset 0 */
    assert_int_equal(esr_mlp_init(&f->mlp, d, &f->p), ESR_OK);
    esr_mlp_init_weights(&f->mlp, f->p.w, 5, NAN);
    assert_int_equal(esr_mlp_ctx_init(&f->ctx, &f->mlp, n, engine), ESR_OK);
    f->n = n;
    f->in = malloc(n * d->n_in * sizeof(float));
    f->d_in = malloc(n * d->n_in * sizeof(float));
    f->out = malloc(n * d->n_out * sizeof(float));
    f->d_out = malloc(n * d->n_out * sizeof(float));
    fill(f->in, n * d->n_in, 1, 1.0f);
    fill(f->d_out, n * d->n_out, 2, 1.0f);
}

static void fixture_free(struct fixture *f)
{
    esr_mlp_ctx_free(&f->ctx);
    esr_nn_params_free(&f->p);
    free(f->in);
    free(f->d_in);
    free(f->out);
    free(f->d_out);
}

static double act_ref(enum esr_nn_act a, double z)
{
    switch (a) {
    case ESR_NN_ACT_RELU: return z > 0 ? z : 0;
    case ESR_NN_ACT_SIGMOID: return 1 / (1 + exp(-z));
    case ESR_NN_ACT_SOFTPLUS: return z > 20 ? z : log1p(exp(z));
    case ESR_NN_ACT_TRUNC_EXP: return exp(z);
    default: return z;
    }
}

/* Textbook forward of one row in double, from the documented parameter layout. */
static void ref_row(const struct esr_mlp *m, const double *w, const double *x, double *y)
{
    double a[ESR_MLP_MAX_WIDTH], b[ESR_MLP_MAX_WIDTH];
    memcpy(a, x, sizeof(double) * m->desc.n_in);
    for (int l = 0; l < m->n_layers; l++) {
        int fi = m->fan_in[l], fo = m->fan_out[l];
        int last = l == m->n_layers - 1;
        for (int o = 0; o < fo; o++) {
            double z = w[m->b_off[l] + o];
            for (int i = 0; i < fi; i++)
                z += a[i] * w[m->w_off[l] + (size_t)i * fo + o];
            b[o] = act_ref(last ? m->desc.out_act : m->desc.hidden_act, z);
        }
        memcpy(a, b, sizeof(double) * fo);
    }
    memcpy(y, a, sizeof(double) * m->desc.n_out);
}

/* L = sum over rows/outputs of d_out * mlp(in), in double. */
static double ref_loss(const struct fixture *f, const double *w, const double *xin)
{
    const struct esr_mlp_desc *d = &f->mlp.desc;
    double y[ESR_MLP_MAX_WIDTH], loss = 0;
    for (size_t r = 0; r < f->n; r++) {
        ref_row(&f->mlp, w, xin + r * d->n_in, y);
        for (int o = 0; o < d->n_out; o++)
            loss += y[o] * f->d_out[r * d->n_out + o];
    }
    return loss;
}

static double *to_double(const float *x, size_t n)
{
    double *y = malloc(n * sizeof(double));
    for (size_t i = 0; i < n; i++)
        y[i] = x[i];
    return y;
}

static void assert_close(double got, double want, double rtol, double atol, const char *what,
                         size_t idx)
{
    if (fabs(got - want) > atol + rtol * fabs(want))
        fail_msg("%s[%zu]: got %.8g, want %.8g", what, idx, got, want);
}

/* d ref_loss / d *v by central differences (v points into w or x). */
static double central_diff(const struct fixture *f, const double *w, const double *x, double *v)
{
    const double h = 1e-6, keep = *v;
    *v = keep + h;
    double lp = ref_loss(f, w, x);
    *v = keep - h;
    double lm = ref_loss(f, w, x);
    *v = keep;
    return (lp - lm) / (2 * h);
}

/* Checks every `stride`-th parameter and input against central differences. */
static void check_gradients(const struct esr_mlp_desc *d, size_t n, size_t stride)
{
    struct fixture f;
    fixture_init(&f, d, n);
    const struct esr_mlp *m = &f.mlp;
    assert_int_equal(esr_mlp_fwd(m, f.p.w, &f.ctx, f.in, f.out, n), ESR_OK);
    assert_int_equal(esr_mlp_bwd(m, f.p.w, f.p.g, &f.ctx, f.d_out, f.d_in, ESR_NN_GRAD_OVERWRITE),
                     ESR_OK);
    double *w = to_double(f.p.w, f.p.count), *x = to_double(f.in, n * d->n_in);
    for (size_t i = m->offset; i < m->offset + m->count; i += stride)
        assert_close(f.p.g[i], central_diff(&f, w, x, w + i), 2e-3, 2e-4, "d_param", i);
    for (size_t i = 0; i < n * d->n_in; i += stride)
        assert_close(f.d_in[i], central_diff(&f, w, x, x + i), 2e-3, 2e-4, "d_in", i);
    /* Parameters outside the MLP's range get no gradient. */
    for (size_t i = 0; i < m->offset; i++)
        assert_true(f.p.g[i] == 0.0f);
    free(w);
    free(x);
    fixture_free(&f);
}

static void test_gradients_each_output_activation(void **state)
{
    (void)state;
    static const enum esr_nn_act acts[] = {ESR_NN_ACT_NONE, ESR_NN_ACT_SIGMOID,
                                           ESR_NN_ACT_SOFTPLUS, ESR_NN_ACT_TRUNC_EXP,
                                           ESR_NN_ACT_RELU};
    for (size_t a = 0; a < sizeof(acts) / sizeof(acts[0]); a++) {
        /* width 11: a padded two-vector panel; 3 outputs: a one-vector panel */
        struct esr_mlp_desc d = {5, 11, 2, 3, ESR_NN_ACT_RELU, acts[a]};
        check_gradients(&d, 11, 1);
    }
    /* Non-ReLU hidden activation and a single linear layer. */
    struct esr_mlp_desc soft = {4, 6, 1, 2, ESR_NN_ACT_SOFTPLUS, ESR_NN_ACT_SIGMOID};
    check_gradients(&soft, 5, 1);
    struct esr_mlp_desc linear = {3, 1, 0, 2, ESR_NN_ACT_RELU, ESR_NN_ACT_NONE};
    check_gradients(&linear, 4, 1);
}

/* Real layer shapes, several tiles with a partial last one, vector and remainder paths. */
static void test_gradients_real_shapes(void **state)
{
    (void)state;
    struct esr_mlp_desc d = {39, 64, 2, 3, ESR_NN_ACT_RELU, ESR_NN_ACT_SOFTPLUS};
    check_gradients(&d, ESR_MLP_TILE * 2 + 37, 97);
}

static void test_forward_matches_reference_and_infer(void **state)
{
    (void)state;
    /* 29 outputs: one full 16-column panel and a padded 13-column one. */
    struct esr_mlp_desc d = {39, 64, 3, 29, ESR_NN_ACT_RELU, ESR_NN_ACT_SIGMOID};
    size_t n = ESR_MLP_TILE * 3 + 5;
    struct fixture f;
    fixture_init(&f, &d, n);
    assert_int_equal(esr_mlp_fwd(&f.mlp, f.p.w, &f.ctx, f.in, f.out, n), ESR_OK);
    double *w = to_double(f.p.w, f.p.count), *x = to_double(f.in, n * d.n_in);
    double y[ESR_MLP_MAX_WIDTH];
    for (size_t r = 0; r < n; r++) {
        ref_row(&f.mlp, w, x + r * d.n_in, y);
        for (int o = 0; o < d.n_out; o++)
            assert_close(f.out[r * d.n_out + o], y[o], 1e-5, 1e-6, "out", r * d.n_out + o);
    }
    float *inf = malloc(n * d.n_out * sizeof(float));
    esr_mlp_infer(&f.mlp, f.p.w, f.in, inf, n);
    if (engine == ESR_MLP_ENGINE_FUSED) /* the same kernel: bitwise */
        assert_memory_equal(inf, f.out, n * d.n_out * sizeof(float));
    for (size_t i = 0; i < n * d.n_out; i++)
        assert_close(inf[i], f.out[i], 1e-5, 1e-6, "infer", i);
    free(inf);
    free(w);
    free(x);
    fixture_free(&f);
}

static void test_d_in_modes(void **state)
{
    (void)state;
    struct esr_mlp_desc d = {20, 32, 1, 4, ESR_NN_ACT_RELU, ESR_NN_ACT_NONE};
    size_t n = 70, nin = n * d.n_in;
    struct fixture f;
    fixture_init(&f, &d, n);
    assert_int_equal(esr_mlp_fwd(&f.mlp, f.p.w, &f.ctx, f.in, f.out, n), ESR_OK);
    assert_int_equal(esr_mlp_bwd(&f.mlp, f.p.w, f.p.g, &f.ctx, f.d_out, f.d_in,
                                 ESR_NN_GRAD_OVERWRITE), ESR_OK);
    float *acc = malloc(nin * sizeof(float)), *g1 = malloc(f.mlp.count * sizeof(float));
    memcpy(g1, f.p.g + f.mlp.offset, f.mlp.count * sizeof(float));
    for (size_t i = 0; i < nin; i++)
        acc[i] = (float)i;
    assert_int_equal(esr_mlp_bwd(&f.mlp, f.p.w, f.p.g, &f.ctx, f.d_out, acc,
                                 ESR_NN_GRAD_ACCUMULATE), ESR_OK);
    for (size_t i = 0; i < nin; i++)
        assert_float_equal(acc[i], (float)i + f.d_in[i], 1e-4f * (1.0f + (float)i));
    /* Parameter gradients accumulate too: a second backward doubles them. */
    for (size_t i = 0; i < f.mlp.count; i++)
        assert_float_equal(f.p.g[f.mlp.offset + i], 2.0f * g1[i], 1e-5f * (1.0f + fabsf(g1[i])));
    assert_int_equal(esr_mlp_bwd(&f.mlp, f.p.w, f.p.g, &f.ctx, f.d_out, NULL, ESR_NN_GRAD_IGNORE),
                     ESR_OK);
    assert_int_equal(esr_mlp_bwd(&f.mlp, f.p.w, f.p.g, &f.ctx, f.d_out, NULL,
                                 ESR_NN_GRAD_OVERWRITE), ESR_ERR);
    esr_error_clear();
    free(acc);
    free(g1);
    fixture_free(&f);
}

/* Forward output, parameter gradients and d_in for a given thread count. */
static void run_threads(int threads, const struct esr_mlp_desc *d, size_t n, float *out,
                        float *grads, float *d_in)
{
    omp_set_num_threads(threads);
    struct fixture f;
    fixture_init(&f, d, n);
    assert_int_equal(f.ctx.n_threads, threads);
    assert_int_equal(esr_mlp_fwd(&f.mlp, f.p.w, &f.ctx, f.in, f.out, n), ESR_OK);
    assert_int_equal(esr_mlp_bwd(&f.mlp, f.p.w, f.p.g, &f.ctx, f.d_out, f.d_in,
                                 ESR_NN_GRAD_OVERWRITE), ESR_OK);
    memcpy(out, f.out, n * d->n_out * sizeof(float));
    memcpy(grads, f.p.g + f.mlp.offset, f.mlp.count * sizeof(float));
    memcpy(d_in, f.d_in, n * d->n_in * sizeof(float));
    fixture_free(&f);
}

static void test_thread_count_determinism(void **state)
{
    (void)state;
    struct esr_mlp_desc d = {39, 64, 2, 3, ESR_NN_ACT_RELU, ESR_NN_ACT_SOFTPLUS};
    size_t n = ESR_MLP_TILE * 40 + 3, count = esr_mlp_param_count(&d);
    float *o1 = malloc(n * 3 * sizeof(float)), *o2 = malloc(n * 3 * sizeof(float));
    float *g1 = malloc(count * sizeof(float)), *g2 = malloc(count * sizeof(float));
    float *x1 = malloc(n * 39 * sizeof(float)), *x2 = malloc(n * 39 * sizeof(float));
    int keep = omp_get_max_threads();
    run_threads(1, &d, n, o1, g1, x1);
    run_threads(2, &d, n, o2, g2, x2);
    omp_set_num_threads(keep);
    assert_memory_equal(o1, o2, n * 3 * sizeof(float));
    assert_memory_equal(g1, g2, count * sizeof(float));
    assert_memory_equal(x1, x2, n * 39 * sizeof(float));
    free(o1);
    free(o2);
    free(g1);
    free(g2);
    free(x1);
    free(x2);
}

static void test_bad_input(void **state)
{
    (void)state;
    struct esr_nn_params p;
    struct esr_mlp m;
    assert_int_equal(esr_nn_params_init(&p, 0), ESR_OK);
    struct esr_mlp_desc too_wide = {3, ESR_MLP_MAX_WIDTH + 1, 2, 3, ESR_NN_ACT_RELU,
                                    ESR_NN_ACT_NONE};
    assert_int_equal(esr_mlp_init(&m, &too_wide, &p), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "invalid MLP"));
    esr_error_clear();
    struct esr_mlp_desc bad_act = {3, 8, 1, 3, ESR_NN_ACT_RELU, (enum esr_nn_act)42};
    assert_int_equal(esr_mlp_init(&m, &bad_act, &p), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_mlp_param_count(&bad_act), 0);

    struct esr_mlp_desc d = {3, 8, 1, 2, ESR_NN_ACT_RELU, ESR_NN_ACT_NONE};
    assert_int_equal(esr_mlp_param_count(&d), (size_t)(3 * 8 + 8 + 8 * 2 + 2));
    assert_int_equal(esr_mlp_init(&m, &d, &p), ESR_OK);
    struct esr_mlp_ctx c;
    assert_int_equal(esr_mlp_ctx_init(&c, &m, 4, engine), ESR_OK);
    float in[5 * 3] = {0}, out[5 * 2], dout[5 * 2] = {0};
    assert_int_equal(esr_mlp_bwd(&m, p.w, p.g, &c, dout, NULL, ESR_NN_GRAD_IGNORE), ESR_ERR);
    esr_error_clear();
    assert_int_equal(esr_mlp_fwd(&m, p.w, &c, in, out, 5), ESR_ERR);
    assert_non_null(strstr(esr_error_message(), "exceeds"));
    esr_error_clear();
    esr_mlp_ctx_free(&c);
    esr_nn_params_free(&p);
}

/* Last-bias init and seeded, reproducible weights within the Kaiming bound. */
static void test_init_weights(void **state)
{
    (void)state;
    struct esr_nn_params p;
    struct esr_mlp m;
    assert_int_equal(esr_nn_params_init(&p, 0), ESR_OK);
    struct esr_mlp_desc d = {16, 32, 1, 3, ESR_NN_ACT_RELU, ESR_NN_ACT_SOFTPLUS};
    assert_int_equal(esr_mlp_init(&m, &d, &p), ESR_OK);
    esr_mlp_init_weights(&m, p.w, 11, 0.0f);
    for (int o = 0; o < 3; o++)
        assert_true(p.w[m.b_off[1] + o] == 0.0f);
    float bound = sqrtf(6.0f / 16.0f), maxabs = 0;
    for (int i = 0; i < 16 * 32; i++)
        maxabs = fmaxf(maxabs, fabsf(p.w[m.w_off[0] + i]));
    assert_true(maxabs <= bound && maxabs > 0.8f * bound);
    float *copy = malloc(m.count * sizeof(float));
    memcpy(copy, p.w + m.offset, m.count * sizeof(float));
    esr_mlp_init_weights(&m, p.w, 11, 0.0f);
    assert_memory_equal(copy, p.w + m.offset, m.count * sizeof(float));
    esr_mlp_init_weights(&m, p.w, 12, 0.0f);
    assert_memory_not_equal(copy, p.w + m.offset, m.count * sizeof(float));
    free(copy);
    esr_nn_params_free(&p);
}

static int use_fused(void **state)
{
    (void)state;
    engine = ESR_MLP_ENGINE_FUSED;
    return 0;
}

static int use_onednn(void **state)
{
    (void)state;
    engine = ESR_MLP_ENGINE_ONEDNN;
    return 0;
}

static int use_openblas(void **state)
{
    (void)state;
    engine = ESR_MLP_ENGINE_OPENBLAS;
    return 0;
}

int main(void)
{
    const struct CMUnitTest fused[] = {
        cmocka_unit_test(test_gradients_each_output_activation),
        cmocka_unit_test(test_gradients_real_shapes),
        cmocka_unit_test(test_forward_matches_reference_and_infer),
        cmocka_unit_test(test_d_in_modes),
        cmocka_unit_test(test_thread_count_determinism),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_init_weights),
    };
    /* library sums are not promised to be thread-count independent */
    const struct CMUnitTest library[] = {
        cmocka_unit_test(test_gradients_each_output_activation),
        cmocka_unit_test(test_gradients_real_shapes),
        cmocka_unit_test(test_forward_matches_reference_and_infer),
        cmocka_unit_test(test_d_in_modes),
        cmocka_unit_test(test_bad_input),
    };
    int failed = cmocka_run_group_tests_name("fused", fused, use_fused, NULL);
    failed += cmocka_run_group_tests_name("onednn", library, use_onednn, NULL);
    failed += cmocka_run_group_tests_name("openblas", library, use_openblas, NULL);
    return failed;
}
