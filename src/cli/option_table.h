/* A command's arguments as one table, from which both its parsing and the options part of its
 * --help come, so what --help lists and what is accepted cannot drift apart. */
#ifndef ESR_CLI_OPTION_TABLE_H
#define ESR_CLI_OPTION_TABLE_H

#include <stddef.h>
#include <stdio.h>

struct esr_command;

/* What an option takes and where it goes. `at` is the destination's offset in the command's
 * own argument struct (offsetof), so one static table serves every parse; a positional's slot
 * starts NULL (empty). */
enum cli_kind {
    CLI_FLAG,   /* no value: the int at `at` becomes 1 */
    CLI_INT,    /* an integer in [lo, hi] (cli_parse_int) into the int at `at` */
    CLI_DOUBLE, /* a number in [lo, hi] (cli_parse_double) into the double at `at` */
    CLI_TEXT,   /* the value itself into the const char * at `at` */
    CLI_TEXTS,  /* repeatable: appended to the struct cli_texts at `at`, at most hi of them */
    CLI_CALL,   /* nothing stored: `call` does it all (a group of options, a value of its own kind) */
    /* positional arguments (name: the synopsis's word, "RUN"; not an option, not in the list) */
    CLI_ARG,    /* one, into the const char * at `at`; a second is refused */
    CLI_ARGS,   /* up to hi, in order, into the struct cli_texts at `at` */
};

/* The most entries one table has (tests/test_cli_options.c checks every command's). */
#define CLI_OPTIONS_MAX 64

/* The values of a repeatable option or the positional arguments, in the order given. */
#define CLI_TEXTS_MAX 64
struct cli_texts {
    const char *v[CLI_TEXTS_MAX];
    int n;
};

/* One row of a table. The tables give the first four fields in order and the rest by name:
 *   {"--spp", "N", "samples per pixel", CLI_INT, .at = AT(spp), .lo = 1, .hi = 4096},
 * with AT(field) the command's offsetof its argument struct. */
struct cli_option {
    const char *name; /* "--spp" (or a positional's "RUN"); NULL ends the table */
    const char *arg;  /* the value's name in --help ("N"); NULL for a flag */
    const char *help; /* what --help says: one paragraph, wrapped at 96 columns (a '\n' starts
                         a new line) */
    enum cli_kind kind;
    size_t at;        /* where the value goes (above) */
    double lo, hi;    /* CLI_INT, CLI_DOUBLE: the range; CLI_TEXTS, CLI_ARGS: hi the most values */
    int once; /* 1: given twice is refused ("--spp given twice"); 0: the last one counts */
    /* the refusal of a malformed or out-of-range value (CLI_INT, CLI_DOUBLE; for CLI_ARGS of one
     * too many), a printf format whose one %s is the value; NULL: "NAME must be an integer in
     * LO..HI, got 'V'" and the like */
    const char *bad;
    /* CLI_CALL: the option's whole handling; any other kind: called once the value is stored,
     * for the option's own rules. value is NULL for a flag. 0, or 1 when it refused (said). */
    int (*call)(void *args, const struct cli_option *o, const char *value);
};

/* What cli_parse did. */
enum { CLI_PARSED = 0, CLI_REFUSED = 1, CLI_HELPED = 2 };

/* Parses argv (argv[0] the command's name) into args by cmd->options:
 *  - an option is `--name value` or `--name=value`; a name spelt with "colour" or "color" takes
 *    the table's spelling; a "--word" anywhere (a value's place too) that names no option is
 *    refused with the nearest one (core/suggest) before anything is read;
 *  - -h or --help anywhere prints the help (cli_print_help): CLI_HELPED;
 *  - then the arguments in order: a missing value, a value given to a flag, a value out of
 *    range, an option given twice that may be given once, too many positional arguments are
 *    refused, the message naming the option (CLI_REFUSED, said as cli_fail says).
 * Only what is given is stored: args holds the defaults beforehand. */
int cli_parse(const struct esr_command *cmd, int argc, char **argv, void *args);
/* cmd's usage text, then the options of its table: one aligned row each, and -h, --help; then
 * cmd->help_more's text. */
void cli_print_help(const struct esr_command *cmd, FILE *out);
/* The table's option named name ("--spp"; "--colour" finds "--color"), or NULL. */
const struct cli_option *cli_option_find(const struct cli_option *table, const char *name);

#endif
