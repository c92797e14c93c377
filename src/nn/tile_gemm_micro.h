/* The tile GEMM's micro-kernel and row panel at one vector width: included by nn/tile_gemm.c
 * once per width with TG_W defined as 8 or 16 (floats per vector), which gives micro8 /
 * panel_strided8 on v8 and micro16 / panel_strided16 on v16. Not a public header. */
#ifndef TG_W
#error "define TG_W (8 or 16) before including nn/tile_gemm_micro.h"
#endif

#define TG_CAT_(a, b) a##b
#define TG_CAT(a, b) TG_CAT_(a, b)
#define TG_VEC TG_CAT(v, TG_W)
#define TG_LOAD TG_CAT(load, TG_W)
#define TG_STORE TG_CAT(store, TG_W)
#define TG_RELU TG_CAT(relu, TG_W)
#define TG_MICRO TG_CAT(micro, TG_W)
#define TG_PANEL TG_CAT(panel_strided, TG_W)
#if TG_W == 8
#define TG_SPLAT(s) s, s, s, s, s, s, s, s
#else
#define TG_SPLAT(s) s, s, s, s, s, s, s, s, s, s, s, s, s, s, s, s
#endif

/* mr x (TG_W nv) block of C over the full k; mr and nv (1 or 2 vectors) are literals at every
 * call so the accumulators live in registers. A(r, p) = a[r * rs + p * ks]. b and bias point at
 * TG_W nv readable floats per row (padded by the caller if needed). Each element starts at its
 * bias (or C) and adds a(r, p) b(p, j) in increasing p by fused multiply-adds.
 * Exempt from the eight-argument rule: a BLAS-convention GEMM microkernel (sizes, strides apart). */
ESR_INLINE void TG_MICRO(int mr, int nv, const float *a, size_t rs, size_t ks, const float *b,
                         int ldb, float *c, int ldc, int k, const float *bias, int accumulate,
                         enum esr_nn_act act)
{
    TG_VEC acc[2][MR_MAX];
    for (int v = 0; v < nv; v++)
        for (int r = 0; r < mr; r++) {
            if (accumulate)
                TG_LOAD(&acc[v][r], c + r * ldc + TG_W * v);
            else if (bias)
                TG_LOAD(&acc[v][r], bias + TG_W * v);
            else
                acc[v][r] = (TG_VEC){0};
        }
    for (int p = 0; p < k; p++) {
        TG_VEC bv[2];
        for (int v = 0; v < nv; v++)
            TG_LOAD(&bv[v], b + p * ldb + TG_W * v);
        for (int r = 0; r < mr; r++) {
            const float s = a[r * rs + p * ks];
            TG_VEC x = {TG_SPLAT(s)};
            for (int v = 0; v < nv; v++)
                acc[v][r] += x * bv[v];
        }
    }
    for (int v = 0; v < nv; v++)
        for (int r = 0; r < mr; r++) {
            if (act == ESR_NN_ACT_RELU)
                TG_RELU(&acc[v][r]);
            TG_STORE(c + r * ldc + TG_W * v, &acc[v][r]);
        }
    if (act != ESR_NN_ACT_RELU && act != ESR_NN_ACT_NONE)
        act_block(act, c, ldc, mr, TG_W * nv);
}

/* All rows of one panel of TG_W nv columns: blocks of mr_main rows, then single rows. rs and ks
 * are A's row and k strides, literals at the call sites so the common ks = 1 folds away.
 * Exempt from the eight-argument rule: a BLAS-convention GEMM panel kernel, as the micro-kernel. */
ESR_INLINE void TG_PANEL(int mr_main, int nv, const struct esr_gemm_tile *t, size_t rs, size_t ks,
                         const float *b, int ldb, float *c, int ldc, const float *bias)
{
    int r = 0;
    for (; r + mr_main <= t->m; r += mr_main)
        TG_MICRO(mr_main, nv, t->a + r * rs, rs, ks, b, ldb, c + (size_t)r * ldc, ldc, t->k, bias,
                 t->accumulate, t->act);
    for (; r < t->m; r++)
        TG_MICRO(1, nv, t->a + r * rs, rs, ks, b, ldb, c + (size_t)r * ldc, ldc, t->k, bias,
                 t->accumulate, t->act);
}

#undef TG_CAT_
#undef TG_CAT
#undef TG_VEC
#undef TG_LOAD
#undef TG_STORE
#undef TG_RELU
#undef TG_MICRO
#undef TG_PANEL
#undef TG_SPLAT
