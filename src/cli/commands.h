/* The esr subcommands. Each lives in its own cmd_<name>.c and is listed once in command_list.c. */
#ifndef ESR_CLI_COMMANDS_H
#define ESR_CLI_COMMANDS_H

#include <stdio.h>

#include "cli/option_table.h"

struct esr_command {
    const char *name;
    const char *summary; /* one line for `esr --help` */
    const char *usage;   /* `esr <cmd> --help`'s synopsis and what the command does; the options
                            part follows from `options` (cli_print_help) */
    const struct cli_option *options; /* what the command takes (cli_parse), ended by {0} */
    void (*help_more)(FILE *out); /* what --help says after the options (synth's scenes, train's
                                     configuration table); NULL: nothing */
    int (*run)(int argc, char **argv); /* argv[0] is the command name; returns the exit code */
    int view_loop; /* 1: renders view after view, each with its own workspaces (main.c keeps
                      freed memory for the next view) */
};

/* Every command, in the order `esr --help` lists them, ended by NULL (cli/command_list.c). */
extern const struct esr_command *const cli_commands[];

/* Prints "esr <cmd>: error: <message>" (with the library's pending error if any) and the
 * command's usage hint; returns exit code 1. */
int cli_fail(const struct esr_command *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints the library's pending error for cmd and returns 1. */
int cli_fail_lib(const struct esr_command *cmd);
/* Parses a whole-string decimal integer in [lo, hi] (lo, hi within int); 0 on success, -1 else. */
int cli_parse_int(const char *text, long lo, long hi, int *out);
/* A decimal number in [lo, hi] (no leading space or '+', no hexadecimal, inf or nan): 0 on
 * success, -1 otherwise. */
int cli_parse_double(const char *text, double lo, double hi, double *out);

/* Interruption of a command that writes results (cli/interrupt.c). at_once 0: SIGINT/SIGTERM
 * set a flag (cli_interrupted: the signal's number) that the command checks between units of
 * work; 1: the registered temporary files are removed and the process exits (128 + signal). */
void cli_catch_interrupt(const struct esr_command *cmd, int at_once);
int cli_interrupted(void);
/* Registers a temporary file for removal on an at-once interruption; returns the stored path
 * (NULL when the table is full). cli_aside_clear forgets them all (once they are in place). */
const char *cli_aside_register(const char *path);
void cli_aside_clear(void);
/* Holds SIGINT and SIGTERM back (hold 1) while results move into place, or lets them in (0). */
int cli_hold_signals(int hold);

/* Files that belong together (a phase's scores and the report that shows them), written aside
 * under temporary names and moved into place together once all are complete (signals held off
 * meanwhile), so a failed or interrupted command leaves the earlier set, never a mix. */
#define CLI_ASIDE_MAX 8
struct cli_aside {
    int n;
    char final[CLI_ASIDE_MAX][4200];
    char temp[CLI_ASIDE_MAX][4300];
};
/* The temporary path to write `final` to (registered for an at-once interruption); NULL when
 * the set is full or the path too long. */
const char *cli_aside_add(struct cli_aside *s, const char *final);
/* Moves every written temporary file onto its final name (ESR_ERR naming the file, the rest
 * removed, on failure); cli_aside_discard removes them instead. */
int cli_aside_commit(struct cli_aside *s);
void cli_aside_discard(struct cli_aside *s);

/* An output file given by `option`: refused (ESR_ERR, said why) unless its name ends in ext
 * (".ply", ".glb", ".json", ".png"; case aside) or when it names a folder; its missing folders
 * are made now, before any work (made: the outermost one made, for esr_dir_remove_made). */
int cli_output_file(const char *option, const char *path, const char *ext, char *made, size_t n);
/* 1 when path ends in ext (".png"), case aside, and has a name before it. */
int cli_ends_with(const char *path, const char *ext);
/* The folder path lies in (trailing slashes of path aside): "." for a bare name, "/" for a name
 * under the root. */
void cli_parent_dir(const char *path, char *out, size_t n);

/* The record of what made an output (cli/record.c): {"command": "esr NAME ARGS", "argv": [...],
 * "esr": version, "commit", "time": ISO 8601 UTC}; the caller owns it. ARGS are argv's: what was
 * typed (cli_parse reads --name=value as it stands), or what `esr demo` gave its step. */
struct cJSON *cli_record(const char *cmd_name, int argc, char **argv);
/* Sets key to item (taken over, freed on failure) in the JSON object at path, rewritten atomically. */
int cli_json_set(const char *path, const char *key, struct cJSON *item);
/* Sets that record as "made_by" in the JSON object at path (rewritten atomically). */
int cli_record_into(const char *path, const char *cmd_name, int argc, char **argv);

/* Add `extern const struct esr_command cmd_<name>;` here and a row in main.c's table. */
extern const struct esr_command cmd_metrics;
extern const struct esr_command cmd_info;
extern const struct esr_command cmd_import;
extern const struct esr_command cmd_synth;
extern const struct esr_command cmd_train;
extern const struct esr_command cmd_render;
extern const struct esr_command cmd_eval;
extern const struct esr_command cmd_export;
extern const struct esr_command cmd_lights;
extern const struct esr_command cmd_edit;
extern const struct esr_command cmd_lightmix;
extern const struct esr_command cmd_bench;
extern const struct esr_command cmd_demo;

#endif
