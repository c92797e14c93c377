/* esr: emissive source reconstruction. Dispatches to the subcommands in commands.h. */
#include <malloc.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "core/error.h"
#include "core/limits.h"

/* One row per subcommand, in the order `esr --help` lists them. */
static const struct esr_command *const commands[] = {
    NULL, /* keeps the table non-empty; skipped */
    &cmd_demo,
    &cmd_info,
    &cmd_import,
    &cmd_metrics,
    &cmd_synth,
    &cmd_train,
    &cmd_render,
    &cmd_eval,
    &cmd_export,
    &cmd_lights,
    &cmd_edit,
    &cmd_bench,
};
#define N_COMMANDS (int)(sizeof commands / sizeof commands[0])

int cli_wants_help(const struct esr_command *cmd, int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "-h") || !strcmp(argv[i], "--help")) {
            printf("%s", cmd->usage);
            return 1;
        }
    }
    return 0;
}

int cli_fail(const struct esr_command *cmd, const char *fmt, ...)
{
    fprintf(stderr, "esr %s: error: ", cmd->name);
    va_list args;
    va_start(args, fmt);
    vfprintf(stderr, fmt, args);
    va_end(args);
    fprintf(stderr, "\n(see `esr %s --help`)\n", cmd->name);
    return 1;
}

int cli_fail_lib(const struct esr_command *cmd)
{
    fprintf(stderr, "esr %s: error: %s\n", cmd->name,
            esr_error_pending() ? esr_error_message() : "unknown failure");
    return 1;
}

static void print_help(FILE *out)
{
    fprintf(out, "esr - emissive source reconstruction (ESR-NeRF in C)\n\n"
                 "usage: esr <command> [options]\n\ncommands:\n");
    for (int i = 0; i < N_COMMANDS; i++)
        if (commands[i])
            fprintf(out, "  %-10s %s\n", commands[i]->name, commands[i]->summary);
    fprintf(out, "\n`esr <command> --help` describes a command's options.\n");
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

int main(int argc, char **argv)
{
    if (apply_memory_limit() != 0)
        return 1;
    if (argc < 2) {
        print_help(stderr);
        return 1;
    }
    if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
        print_help(stdout);
        return 0;
    }
    for (int i = 0; i < N_COMMANDS; i++)
        if (commands[i] && !strcmp(argv[1], commands[i]->name)) {
            if (commands[i]->view_loop)
                keep_freed_memory();
            return commands[i]->run(argc - 1, argv + 1);
        }
    fprintf(stderr, "esr: unknown command '%s'\n\n", argv[1]);
    print_help(stderr);
    return 1;
}
