/* Portability macros shared by CPU kernels (and, later, a CUDA build). */
#ifndef ESR_CORE_SIMD_H
#define ESR_CORE_SIMD_H

/* The default build targets baseline x86-64 so the binary runs anywhere; hot kernels are
 * compiled twice and picked at load time by the CPU's features (GCC function multiversioning).
 * Under -march=native (ESR_NATIVE) or sanitizers the clones are unnecessary. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX2__) && \
    !defined(__SANITIZE_ADDRESS__)
#define ESR_HOT __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ESR_HOT
#endif

/* The clone of the hot loops this CPU runs, in words (`esr --version`, `esr bench`). */
static inline const char *esr_hot_loops_isa(void)
{
#if defined(__x86_64__) && defined(__GNUC__)
    return __builtin_cpu_supports("x86-64-v3") ? "x86-64-v3 (AVX2, FMA)" : "x86-64 (baseline)";
#else
    return "portable";
#endif
}

#ifdef __cplusplus
#define ESR_RESTRICT __restrict__
#else
#define ESR_RESTRICT restrict
#endif

#define ESR_INLINE static inline __attribute__((always_inline))

#endif
