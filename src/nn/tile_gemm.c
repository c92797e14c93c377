/* Register-blocked tile GEMM; see nn/tile_gemm.h. */
#include "nn/tile_gemm.h"

#include <string.h>

#include "core/isa.h"
#include "core/simd.h"

#define NR 16     /* columns per micro-block: two 8-float vectors */
#define MR_MAX 8  /* rows per micro-block on the widest path */

typedef float v8 __attribute__((vector_size(32)));
typedef int v8i __attribute__((vector_size(32)));

/* Vectors go through pointers: passing 32-byte vectors by value draws GCC's ABI note in the
 * baseline build, although these helpers are always inlined. */
ESR_INLINE void load8(v8 *v, const float *p) { memcpy(v, p, sizeof(*v)); }
ESR_INLINE void store8(float *p, const v8 *v) { memcpy(p, v, sizeof(*v)); }
ESR_INLINE void relu8(v8 *x)
{
    v8 zero = {0};
    *x = (v8)((v8i)*x & (*x > zero));
}

/* Non-ReLU activations on a stored block (output layers only: few columns, not hot). */
ESR_INLINE void act_block(enum esr_nn_act act, float *c, int ldc, int rows, int cols)
{
    for (int r = 0; r < rows; r++)
        for (int j = 0; j < cols; j++)
            c[r * ldc + j] = esr_nn_act_fwd(act, c[r * ldc + j]);
}

/* mr x (8 nv) block of C over the full k; mr and nv (1 or 2 vectors) are literals at every call
 * so the accumulators live in registers. A(r, p) = a[r * rs + p * ks]. b and bias point at 8 nv
 * readable floats per row (padded by the caller if needed).
 * Exempt from the eight-argument rule: a BLAS-convention GEMM microkernel (sizes, strides apart). */
ESR_INLINE void micro(int mr, int nv, const float *a, size_t rs, size_t ks, const float *b,
                      int ldb, float *c, int ldc, int k, const float *bias, int accumulate,
                      enum esr_nn_act act)
{
    v8 acc[2][MR_MAX];
    for (int v = 0; v < nv; v++)
        for (int r = 0; r < mr; r++) {
            if (accumulate)
                load8(&acc[v][r], c + r * ldc + 8 * v);
            else if (bias)
                load8(&acc[v][r], bias + 8 * v);
            else
                acc[v][r] = (v8){0};
        }
    for (int p = 0; p < k; p++) {
        v8 bv[2];
        for (int v = 0; v < nv; v++)
            load8(&bv[v], b + p * ldb + 8 * v);
        for (int r = 0; r < mr; r++) {
            float s = a[r * rs + p * ks];
            v8 x = {s, s, s, s, s, s, s, s};
            for (int v = 0; v < nv; v++)
                acc[v][r] += x * bv[v];
        }
    }
    for (int v = 0; v < nv; v++)
        for (int r = 0; r < mr; r++) {
            if (act == ESR_NN_ACT_RELU)
                relu8(&acc[v][r]);
            store8(c + r * ldc + 8 * v, &acc[v][r]);
        }
    if (act != ESR_NN_ACT_RELU && act != ESR_NN_ACT_NONE)
        act_block(act, c, ldc, mr, 8 * nv);
}

/* All rows of one panel of 8 nv columns: blocks of mr_main rows, then single rows. rs and ks are
 * A's row and k strides, literals at the call sites below so the common ks = 1 folds away.
 * Exempt from the eight-argument rule: a BLAS-convention GEMM panel kernel, as micro. */
ESR_INLINE void panel_strided(int mr_main, int nv, const struct esr_gemm_tile *t, size_t rs,
                              size_t ks, const float *b, int ldb, float *c, int ldc,
                              const float *bias)
{
    int r = 0;
    for (; r + mr_main <= t->m; r += mr_main)
        micro(mr_main, nv, t->a + r * rs, rs, ks, b, ldb, c + (size_t)r * ldc, ldc, t->k, bias,
              t->accumulate, t->act);
    for (; r < t->m; r++)
        micro(1, nv, t->a + r * rs, rs, ks, b, ldb, c + (size_t)r * ldc, ldc, t->k, bias,
              t->accumulate, t->act);
}

/* nv = 1 serves narrow outputs (RGB heads: 3 columns) at half the padded work. */
ESR_INLINE void panel(int mr_main, int nv, const struct esr_gemm_tile *t, const float *b, int ldb,
                      float *c, int ldc, const float *bias)
{
    if (t->trans_a && nv == 1)
        panel_strided(mr_main, 1, t, 1, (size_t)t->lda, b, ldb, c, ldc, bias);
    else if (t->trans_a)
        panel_strided(mr_main, 2, t, 1, (size_t)t->lda, b, ldb, c, ldc, bias);
    else if (nv == 1)
        panel_strided(mr_main, 1, t, (size_t)t->lda, 1, b, ldb, c, ldc, bias);
    else
        panel_strided(mr_main, 2, t, (size_t)t->lda, 1, b, ldb, c, ldc, bias);
}

/* Full panels run in place; the last partial panel (n % 16 columns) runs on zero-padded copies
 * of B, the bias and C so the micro-kernel never reads or writes past the matrix. */
ESR_INLINE void gemm_impl(int mr_main, const struct esr_gemm_tile *t)
{
    int j = 0;
    for (; j + NR <= t->n; j += NR)
        panel(mr_main, 2, t, t->b + j, t->ldb, t->c + j, t->ldc, t->bias ? t->bias + j : NULL);
    if (j == t->n)
        return;
    int cols = t->n - j;
    float bp[ESR_GEMM_MAX_DIM * NR], cp[ESR_GEMM_MAX_DIM * NR], biasp[NR] = {0};
    for (int p = 0; p < t->k; p++) {
        memset(bp + p * NR, 0, sizeof(float) * NR);
        memcpy(bp + p * NR, t->b + (size_t)p * t->ldb + j, sizeof(float) * cols);
    }
    if (t->bias)
        memcpy(biasp, t->bias + j, sizeof(float) * cols);
    for (int r = 0; r < t->m; r++) {
        memset(cp + r * NR, 0, sizeof(float) * NR);
        if (t->accumulate)
            memcpy(cp + r * NR, t->c + (size_t)r * t->ldc + j, sizeof(float) * cols);
    }
    panel(mr_main, cols <= 8 ? 1 : 2, t, bp, NR, cp, NR, t->bias ? biasp : NULL);
    for (int r = 0; r < t->m; r++)
        memcpy(t->c + (size_t)r * t->ldc + j, cp + r * NR, sizeof(float) * cols);
}

/* A portable build carries one path per ISA and picks at run time. A build for the host
 * (-march=native, ESR_NATIVE) has only the host's path: its own target flags are no subset of
 * arch=x86-64-v3/v4 (AES, SHA...), so the clones could not inline gemm_impl there. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(__AVX2__)
#define GEMM_MULTI_ISA 1
/* 16 accumulators + 2 B vectors + 1 broadcast fit AVX-512VL's 32 registers; AVX2's 16 hold 6
 * rows (12 accumulators). */
__attribute__((target("arch=x86-64-v4"))) static void gemm_v4(const struct esr_gemm_tile *t)
{
    gemm_impl(8, t);
}
__attribute__((target("arch=x86-64-v3"))) static void gemm_v3(const struct esr_gemm_tile *t)
{
    gemm_impl(6, t);
}
#endif
#if defined(__AVX512F__) && defined(__AVX512VL__)
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(8, t); }
#define GEMM_BASE_NAME "avx512"
#elif defined(__AVX2__)
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(6, t); }
#define GEMM_BASE_NAME "avx2"
#else
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(4, t); }
#define GEMM_BASE_NAME "generic"
#endif

struct gemm_impl_choice {
    void (*fn)(const struct esr_gemm_tile *t);
    const char *name;
};

static struct gemm_impl_choice gemm_pick(void)
{
    struct gemm_impl_choice ch = {gemm_base, GEMM_BASE_NAME};
#ifdef GEMM_MULTI_ISA
    const enum esr_isa cap = esr_isa_cap();
    if (cap >= ESR_ISA_AVX512 && __builtin_cpu_supports("x86-64-v4")) {
        ch.fn = gemm_v4;
        ch.name = "avx512";
    } else if (cap >= ESR_ISA_AVX2 && __builtin_cpu_supports("x86-64-v3")) {
        ch.fn = gemm_v3;
        ch.name = "avx2";
    } /* else the portable path */
#endif
    return ch;
}

/* Picking per call costs two loads of the CPU-feature word: nothing next to a tile, and no
 * shared mutable state. */
void esr_gemm_tile(const struct esr_gemm_tile *t) { gemm_pick().fn(t); }

const char *esr_gemm_isa(void) { return gemm_pick().name; }
