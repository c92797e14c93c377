/* esr: emissive source reconstruction. Dispatches to the subcommands in commands.h. */
#include <malloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include <oneapi/dnnl/dnnl.h>

#include "core/isa.h"
#include "core/limits.h"
#include "core/simd.h"
#include "core/suggest.h"
#include "nn/tile_gemm.h"

static void print_help(FILE *out)
{
    fprintf(out, "esr - emissive source reconstruction (ESR-NeRF in C)\n\n"
                 "usage: esr <command> [options]\n\ncommands:\n");
    for (int i = 0; cli_commands[i]; i++)
        fprintf(out, "  %-10s %s\n", cli_commands[i]->name, cli_commands[i]->summary);
    fprintf(out, "\n`esr help <command>` (or `esr <command> --help`) describes a command's options;\n"
                 "`esr --version` names the build and its code paths.\n");
}

/* ESR_MEMORY_LIMIT caps the memory a run may hold (core/limits.h): on a shared machine, or to
 * see what a configuration needs. */
static int apply_memory_limit(void)
{
    const char *text = getenv("ESR_MEMORY_LIMIT");
    if (!text || !*text)
        return 0;
    struct esr_limits l = *esr_limits();
    if (!(l.memory_bytes = esr_limits_parse_size(text))) {
        fprintf(stderr, "esr: error: ESR_MEMORY_LIMIT='%s' is not a size (bytes, or a number with K, M, G or T)\n", text);
        return -1;
    }
    esr_limits_set(&l);
    return 0;
}

/* A command that loops over views (render, eval, edit, bench: esr_command.view_loop) allocates
 * each view's workspaces, tens of MiB, and frees them. glibc serves blocks above its (dynamic)
 * threshold by mmap and unmaps them on free, so every view paid its page faults and the kernel's
 * zeroing again: 8% of a direct relight's time in `perf` (clear_page_erms). For these commands
 * blocks up to 32 MiB come from the heap instead, and up to 1 GiB of freed heap stays with the
 * process for the next view. Lamp test_nvi, 15 direct views: 7.7 -> 6.8 s, peak RSS 405 -> 496
 * MiB. Training reuses its workspaces: no faster this way (lts, 150 steps), 86 MiB more, so
 * `train` and `demo` keep glibc's defaults. */
static void keep_freed_memory(void)
{
#ifdef __GLIBC__
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

/* ESR_MAX_ISA caps the run-time code paths (core/isa.h), oneDNN's included: one machine then
 * times what a machine without AVX-512 runs. */
static int apply_isa_cap(void)
{
    if (esr_isa_cap_valid() != 0) {
        fprintf(stderr, "esr: error: ESR_MAX_ISA='%s' is not a code path (avx512, avx2 or generic)\n",
                getenv("ESR_MAX_ISA"));
        return -1;
    }
    const enum esr_isa cap = esr_isa_cap();
    if (cap < ESR_ISA_AVX512 && dnnl_set_max_cpu_isa(cap == ESR_ISA_AVX2 ? dnnl_cpu_isa_avx2 : dnnl_cpu_isa_sse41) !=
                                    dnnl_success) {
        fprintf(stderr, "esr: error: oneDNN refused ESR_MAX_ISA='%s'\n", getenv("ESR_MAX_ISA"));
        return -1;
    }
    return 0;
}

extern const char esr_build_commit[]; /* generated at build time (cmake/version.cmake) */

/* `esr --version`: what a bug report needs: the release, the commit built, and the code paths
 * this CPU gets (the MLP kernels pick AVX-512, AVX2 or generic at run time; the hot loops have
 * an x86-64-v3 clone beside the portable one). */
static void print_version(void)
{
    printf("esr %s (commit %s, built %s)\n", ESR_VERSION, esr_build_commit, __DATE__);
    printf("code paths on this CPU: MLP kernels %s, hot loops %s%s%s\n", esr_gemm_isa(), esr_hot_loops_isa(),
           esr_isa_cap() < ESR_ISA_AVX512 ? "; capped by ESR_MAX_ISA=" : "",
           esr_isa_cap() < ESR_ISA_AVX512 ? esr_isa_name(esr_isa_cap()) : "");
}

static const struct esr_command *find_command(const char *name)
{
    for (int i = 0; cli_commands[i]; i++)
        if (!strcmp(name, cli_commands[i]->name))
            return cli_commands[i];
    return NULL;
}

/* An unknown command: the nearest one by name, not the whole help. */
static int unknown_command(const char *name)
{
    const char *names[32]; /* more than esr has */
    int n = 0;
    for (; cli_commands[n] && n < 32; n++)
        names[n] = cli_commands[n]->name;
    const char *near = esr_suggest(name, names, n);
    fprintf(stderr, "esr: unknown command '%s'%s%s%s\n(`esr --help` lists the commands)\n", name,
            near ? " (did you mean " : "", near ? near : "", near ? "?)" : "");
    return 1;
}

int main(int argc, char **argv)
{
    if (apply_memory_limit() != 0 || apply_isa_cap() != 0)
        return 1;
    if (argc < 2) {
        print_help(stderr);
        return 1;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V") || !strcmp(argv[1], "version")) {
        print_version();
        return 0;
    }
    if (!strcmp(argv[1], "help") && argc >= 3) { /* esr help CMD: CMD's own --help */
        const struct esr_command *cmd = find_command(argv[2]);
        if (!cmd)
            return unknown_command(argv[2]);
        char *help_argv[] = {(char *)cmd->name, (char *)"--help", NULL};
        return cmd->run(2, help_argv);
    }
    if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
        print_help(stdout);
        return 0;
    }
    const struct esr_command *cmd = find_command(argv[1]);
    if (!cmd)
        return unknown_command(argv[1]);
    if (cmd->view_loop)
        keep_freed_memory();
    return cmd->run(argc - 1, argv + 1); /* the command parses its arguments (cli_parse) */
}
