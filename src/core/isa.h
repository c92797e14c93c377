/* The widest instruction set the kernels that pick theirs at run time may use: the CPU's, or
 * less when ESR_MAX_ISA says so ("avx2", "generic"), so one machine can time the code paths a
 * machine without AVX-512 runs (`esr bench`). The MLP tile GEMM honours it (nn/tile_gemm) and
 * `esr` hands it to oneDNN before its first call; the hot loops' x86-64-v3 clones (core/simd.h)
 * follow the CPU, which on an AVX-512 machine is what an AVX2 machine runs. */
#ifndef ESR_CORE_ISA_H
#define ESR_CORE_ISA_H

enum esr_isa { ESR_ISA_GENERIC, ESR_ISA_AVX2, ESR_ISA_AVX512 };

/* The cap from ESR_MAX_ISA (read once): ESR_ISA_AVX512 (no cap) when unset or "avx512". */
enum esr_isa esr_isa_cap(void);

/* 0 when ESR_MAX_ISA is unset or names a level ("avx512", "avx2", "generic"); -1 otherwise. */
int esr_isa_cap_valid(void);

/* "avx512", "avx2", "generic". */
const char *esr_isa_name(enum esr_isa isa);

#endif
