/* The esr subcommands. Each lives in its own cmd_<name>.c and is listed once in main.c's table. */
#ifndef ESR_CLI_COMMANDS_H
#define ESR_CLI_COMMANDS_H

struct esr_command {
    const char *name;
    const char *summary; /* one line for `esr --help` */
    const char *usage;   /* full text for `esr <cmd> --help` (options included) */
    int (*run)(int argc, char **argv); /* argv[0] is the command name; returns the exit code */
    int view_loop; /* 1: renders view after view, each with its own workspaces (main.c keeps
                      freed memory for the next view) */
};

/* Prints "esr <cmd>: error: <message>" (with the library's pending error if any) and the
 * command's usage hint; returns exit code 1. */
int cli_fail(const struct esr_command *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Prints the library's pending error for cmd and returns 1. */
int cli_fail_lib(const struct esr_command *cmd);
/* 1 if argv contains -h or --help (then usage has been printed). */
int cli_wants_help(const struct esr_command *cmd, int argc, char **argv);
/* The grammar every command shares (cli/options.c), applied before the command parses its
 * arguments: `--name=value` becomes `--name value`, an option spelt with "colour" or "color"
 * takes the spelling the command's usage uses, and an option the usage text does not name is
 * refused with the nearest one it does. 0 with *argc, *argv replaced; 1 (said) on an unknown
 * option. */
int cli_normalise_args(const struct esr_command *cmd, int *argc, char ***argv);
/* 1 when cmd's usage text names the option (e.g. "--orbit"). */
int cli_option_known(const struct esr_command *cmd, const char *name);
/* Parses a whole-string decimal integer in [lo, hi] (lo, hi within int); 0 on success, -1 else. */
int cli_parse_int(const char *text, long lo, long hi, int *out);
/* A decimal number in [lo, hi] (no leading space or '+', no hexadecimal, inf or nan): 0 on
 * success, -1 otherwise. */
int cli_parse_double(const char *text, double lo, double hi, double *out);

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
extern const struct esr_command cmd_bench;
extern const struct esr_command cmd_demo;

#endif
