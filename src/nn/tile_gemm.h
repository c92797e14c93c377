/* The dense kernel under the MLPs: one cache-resident tile of C = A B (+ bias or + C), with the
 * activation fused into the store. Register-blocked micro-kernel on 8-float vectors, built three
 * times (AVX-512VL with 32 vector registers, AVX2+FMA, baseline SSE) and picked once by the CPU's
 * features; on AVX-512 the panels of 32 columns run on 16-float vectors. Each C element sums
 * over k in increasing order by fused multiply-adds whatever the blocking and the vector width,
 * so a row's result does not depend on which tile or thread computed it, and the AVX-512 and
 * AVX2 paths agree bit for bit (the generic path, without FMA, rounds differently). */
#ifndef ESR_NN_TILE_GEMM_H
#define ESR_NN_TILE_GEMM_H

#include "core/isa.h"
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
/* The tile on the widest path this CPU and build have up to `cap` (whatever ESR_MAX_ISA
 * says), for tests that compare the paths; returns the name of the path it ran. */
const char *esr_gemm_tile_upto(enum esr_isa cap, const struct esr_gemm_tile *t);

#endif
