/* Register-blocked tile GEMM; see nn/tile_gemm.h. */
#include "nn/tile_gemm.h"

#include <string.h>

#include "core/isa.h"
#include "core/simd.h"

#define NR 16     /* columns per micro-block of 8-float vectors: two vectors */
#define NR_WIDE 32 /* columns per micro-block of 16-float vectors (AVX-512): two vectors */
#define MR_MAX 8  /* rows per micro-block on the widest path */

typedef float v8 __attribute__((vector_size(32)));
typedef int v8i __attribute__((vector_size(32)));
typedef float v16 __attribute__((vector_size(64)));
typedef int v16i __attribute__((vector_size(64)));

/* Unaligned vector loads and stores as one instruction each. Vectors go through pointers:
 * passing 32-byte vectors by value draws GCC's ABI note in the baseline build, although these
 * helpers are always inlined. (A memcpy into the accumulator array made GCC build the
 * accumulators on the stack from two 16-byte halves under -mtune=generic and then load them
 * whole: a failed store forward per accumulator, 40% of the AVX2 forward's time in `perf`.) */
typedef float v8u __attribute__((vector_size(32), aligned(4), may_alias));
typedef float v16u __attribute__((vector_size(64), aligned(4), may_alias));
ESR_INLINE void load8(v8 *v, const float *p) { *v = *(const v8u *)p; }
ESR_INLINE void store8(float *p, const v8 *v) { *(v8u *)p = *v; }
ESR_INLINE void relu8(v8 *x)
{
    v8 zero = {0};
    *x = (v8)((v8i)*x & (*x > zero));
}
ESR_INLINE void load16(v16 *v, const float *p) { *v = *(const v16u *)p; }
ESR_INLINE void store16(float *p, const v16 *v) { *(v16u *)p = *v; }
ESR_INLINE void relu16(v16 *x)
{
    v16 zero = {0};
    *x = (v16)((v16i)*x & (*x > zero));
}

/* Non-ReLU activations on a stored block (output layers only: few columns, not hot). */
ESR_INLINE void act_block(enum esr_nn_act act, float *c, int ldc, int rows, int cols)
{
    for (int r = 0; r < rows; r++)
        for (int j = 0; j < cols; j++)
            c[r * ldc + j] = esr_nn_act_fwd(act, c[r * ldc + j]);
}

/* The micro-kernels and panels, once per vector width (nn/tile_gemm_micro.h): micro8 and
 * panel_strided8 on 8-float vectors, micro16 and panel_strided16 on 16-float ones. Each C
 * element is the same chain of fused multiply-adds in either, so the widths agree bit for bit. */
#define TG_W 8
#include "nn/tile_gemm_micro.h"
#undef TG_W
#define TG_W 16
#include "nn/tile_gemm_micro.h"
#undef TG_W

/* nv = 1 serves narrow outputs (RGB heads: 3 columns) at half the padded work. */
ESR_INLINE void panel(int mr_main, int nv, const struct esr_gemm_tile *t, const float *b, int ldb,
                      float *c, int ldc, const float *bias)
{
    if (t->trans_a && nv == 1)
        panel_strided8(mr_main, 1, t, 1, (size_t)t->lda, b, ldb, c, ldc, bias);
    else if (t->trans_a)
        panel_strided8(mr_main, 2, t, 1, (size_t)t->lda, b, ldb, c, ldc, bias);
    else if (nv == 1)
        panel_strided8(mr_main, 1, t, (size_t)t->lda, 1, b, ldb, c, ldc, bias);
    else
        panel_strided8(mr_main, 2, t, (size_t)t->lda, 1, b, ldb, c, ldc, bias);
}

/* A 32-column panel on 16-float vectors (AVX-512 only). */
ESR_INLINE void panel_wide(int mr_main, const struct esr_gemm_tile *t, const float *b, float *c,
                           const float *bias)
{
    if (t->trans_a)
        panel_strided16(mr_main, 2, t, 1, (size_t)t->lda, b, t->ldb, c, t->ldc, bias);
    else
        panel_strided16(mr_main, 2, t, (size_t)t->lda, 1, b, t->ldb, c, t->ldc, bias);
}

/* Full panels run in place (on the AVX-512 path 32 columns at a time in 16-float vectors, then
 * 16); the last partial panel (n % 16 columns) runs on zero-padded copies
 * of B, the bias and C so the micro-kernel never reads or writes past the matrix. */
ESR_INLINE void gemm_impl(int mr_main, int wide, const struct esr_gemm_tile *t)
{
    int j = 0;
    if (wide) /* 32-column panels on 16-float vectors, the rest as below */
        for (; j + NR_WIDE <= t->n; j += NR_WIDE)
            panel_wide(mr_main, t, t->b + j, t->c + j, t->bias ? t->bias + j : NULL);
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
    gemm_impl(8, 1, t);
}
__attribute__((target("arch=x86-64-v3"))) static void gemm_v3(const struct esr_gemm_tile *t)
{
    gemm_impl(6, 0, t);
}
#endif
#if defined(__AVX512F__) && defined(__AVX512VL__)
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(8, 1, t); }
#define GEMM_BASE_NAME "avx512"
#elif defined(__AVX2__)
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(6, 0, t); }
#define GEMM_BASE_NAME "avx2"
#else
static void gemm_base(const struct esr_gemm_tile *t) { gemm_impl(4, 0, t); }
#define GEMM_BASE_NAME "generic"
#endif

struct gemm_impl_choice {
    void (*fn)(const struct esr_gemm_tile *t);
    const char *name;
};

static struct gemm_impl_choice gemm_pick(enum esr_isa cap)
{
    struct gemm_impl_choice ch = {gemm_base, GEMM_BASE_NAME};
#ifdef GEMM_MULTI_ISA
    if (cap >= ESR_ISA_AVX512 && __builtin_cpu_supports("x86-64-v4")) {
        ch.fn = gemm_v4;
        ch.name = "avx512";
    } else if (cap >= ESR_ISA_AVX2 && __builtin_cpu_supports("x86-64-v3")) {
        ch.fn = gemm_v3;
        ch.name = "avx2";
    } /* else the portable path */
#else
    (void)cap;
#endif
    return ch;
}

/* Picking per call costs two loads of the CPU-feature word: nothing next to a tile, and no
 * shared mutable state. */
void esr_gemm_tile(const struct esr_gemm_tile *t) { gemm_pick(esr_isa_cap()).fn(t); }

const char *esr_gemm_isa(void) { return gemm_pick(esr_isa_cap()).name; }

const char *esr_gemm_tile_upto(enum esr_isa cap, const struct esr_gemm_tile *t)
{
    const struct gemm_impl_choice ch = gemm_pick(cap);
    ch.fn(t);
    return ch.name;
}
