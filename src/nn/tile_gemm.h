/* The dense kernel under the MLPs: one cache-resident tile of C = A B (+ bias or + C), with the
 * activation fused into the store. Register-blocked micro-kernel on 8-float vectors, built three
 * times (AVX-512VL with 32 vector registers, AVX2+FMA, baseline SSE) and picked once by the CPU's
 * features. Each C element sums over k in increasing order whatever the blocking, so a row's
 * result does not depend on which tile or thread computed it. */
#ifndef ESR_NN_TILE_GEMM_H
#define ESR_NN_TILE_GEMM_H

#include "nn/activation.h"

#define ESR_GEMM_MAX_DIM 256 /* m, n and k of one call */

struct esr_gemm_tile {
    const float *a;    /* [m][lda], or [k][lda] read as its transpose when trans_a */
    const float *b;    /* [k][ldb] */
    float *c;          /* [m][ldc] */
    const float *bias; /* [n] added to every row, or NULL; ignored when accumulate */
    int m, n, k;       /* each 1..ESR_GEMM_MAX_DIM (k may be 0: C = bias or C) */
    int lda, ldb, ldc;
    int trans_a;       /* 1: use A^T (weight gradients X^T dY without a transposed copy) */
    int accumulate;    /* 1: C += A B; 0: C = A B + bias */
    enum esr_nn_act act; /* applied to the result before it is stored */
};

/* Computes one tile as described above. */
void esr_gemm_tile(const struct esr_gemm_tile *t);
/* Name of the code path picked for this CPU ("avx512", "avx2", "generic"). */
const char *esr_gemm_isa(void);

#endif
