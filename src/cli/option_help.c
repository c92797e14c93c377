/* A command's --help: its usage text, then the options part made from its option table
 * (option_table.h), one aligned row an option, so that the list is what the parser accepts;
 * then what the command adds (esr_command.help_more). */
#include <string.h>

#include "cli/commands.h"

#define HELP_WIDTH 96 /* the columns a row's text wraps at */
#define LABEL_MAX 22  /* a longer "--name ARG" stands on its own line, its text below it */

static void label_of(const struct cli_option *o, char *out, size_t n)
{
    snprintf(out, n, "%s%s%s", o->name, o->arg ? " " : "", o->arg ? o->arg : "");
}

/* "  LABEL  text..." with the text from column col on, wrapped at HELP_WIDTH. */
static void print_row(FILE *out, const char *label, const char *text, int col)
{
    int at = fprintf(out, "  %s", label);
    if (at + 2 > col) {
        fputc('\n', out);
        at = 0;
    }
    at += fprintf(out, "%*s", col - at, "");
    for (const char *w = text; *w;) {
        if (*w == ' ') {
            w++;
            continue;
        }
        size_t len = strcspn(w, " \n");
        const char *close = *w == '`' ? strchr(w + 1, '`') : NULL;
        if (close && (size_t)(close - w) >= len) /* `esr train --help` is not broken up */
            len = (size_t)(close + 1 - w) + strcspn(close + 1, " \n");
        if (*w == '\n' || (at > col && at + 1 + (int)len > HELP_WIDTH)) {
            at = fprintf(out, "\n%*s", col, "") - 1;
            w += *w == '\n';
            continue;
        }
        if (at > col)
            at += fprintf(out, " ");
        at += fprintf(out, "%.*s", (int)len, w);
        w += len;
    }
    fputc('\n', out);
}

void cli_print_help(const struct esr_command *cmd, FILE *out)
{
    static const char help[] = "-h, --help";
    int width = (int)strlen(help);
    char label[128];
    for (const struct cli_option *o = cmd->options; o->name; o++) {
        label_of(o, label, sizeof label);
        const int len = (int)strlen(label);
        if (o->name[0] == '-' && len <= LABEL_MAX && len > width)
            width = len;
    }
    fprintf(out, "%s\noptions:\n", cmd->usage);
    for (const struct cli_option *o = cmd->options; o->name; o++) {
        if (o->name[0] != '-')
            continue; /* a positional argument: the usage's synopsis names it */
        label_of(o, label, sizeof label);
        print_row(out, label, o->help, 2 + width + 2);
    }
    print_row(out, help, "this text", 2 + width + 2);
    if (cmd->help_more) {
        fputc('\n', out);
        cmd->help_more(out);
    }
}
